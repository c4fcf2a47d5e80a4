// The engine over the real mock drivers (make_engine with drivers.kind = kMock): the mock card
// simulates trapezoidal motion in (sped-up) time, the mock arm finishes a task after a while.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/engine.hpp"
#include "fake_door.hpp"

namespace ajar::testing {
namespace {

using protocol::ProcedureState;

class MockDriversEngine : public ::testing::Test {
 protected:
  void SetUp() override {
    config.drivers.kind = drivers::DriverKind::kMock;
    config.drivers.sim_speedup = 20.0;  // simulated motion runs 20x faster than real time
  }
  bool wait_for_state(ProcedureState s) {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (std::chrono::steady_clock::now() < give_up) {
      engine->controller_heartbeat();
      engine->poll();
      if (engine->status().state == s) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return false;
  }
  protocol::ProcedureState ack_state(const protocol::Message& reply) {
    const auto* ack = std::get_if<protocol::Ack>(&reply);
    if (ack == nullptr) {
      ADD_FAILURE() << "refused: " << std::get<protocol::ErrorReply>(reply).message.view();
      return ProcedureState::kFault;
    }
    return ack->state;
  }
  protocol::Message send(const protocol::Message& m) {
    engine->controller_heartbeat();
    return engine->handle_command(m);
  }

  TempDir tmp;
  daemon::Config config = test_config(tmp.path());
  std::unique_ptr<daemon::Engine> engine;
};

TEST_F(MockDriversEngine, CompletesTheProcedure) {
  engine = daemon::make_engine(config);
  engine->start();
  EXPECT_EQ(ack_state(send(good_width())), ProcedureState::kAwaitingHandle);
  EXPECT_EQ(ack_state(send(good_handle())), ProcedureState::kAwaitingPlane);
  EXPECT_EQ(ack_state(send(plane_at_yaw(0.1))), ProcedureState::kReadyToAlign);
  EXPECT_EQ(ack_state(send(protocol::AlignBase{})), ProcedureState::kAligning);
  ASSERT_TRUE(wait_for_state(ProcedureState::kAligned))
      << "fault " << to_string(engine->status().latched_fault);
  // Odometry from the mock's encoders: the base turned by about the commanded yaw.
  const auto status = engine->status();
  EXPECT_NEAR(std::abs(status.base_yaw_odometry_rad), std::abs(status.plane.yaw_deviation_rad),
              1e-3);
  EXPECT_EQ(ack_state(send(good_contact())), ProcedureState::kReadyToEngage);
  EXPECT_EQ(ack_state(send(protocol::Engage{})), ProcedureState::kEngaging);
  ASSERT_TRUE(wait_for_state(ProcedureState::kEngaged));
  engine->shutdown();
}

TEST_F(MockDriversEngine, StuckCardHitsTheMotionDeadline) {
  config.drivers.mock.card_fault = drivers::MockFault::kStuck;
  config.control.motion_timeout_margin_s = 0.05;
  config.base.max_wheel_speed_rad_s = 50;
  config.base.max_wheel_accel_rad_s2 = 500;
  engine = daemon::make_engine(config);
  engine->start();
  send(good_width());
  send(good_handle());
  send(plane_at_yaw(0.1));
  EXPECT_EQ(ack_state(send(protocol::AlignBase{})), ProcedureState::kAligning);
  ASSERT_TRUE(wait_for_state(ProcedureState::kFault));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kMotionTimeout);
}

}  // namespace
}  // namespace ajar::testing
