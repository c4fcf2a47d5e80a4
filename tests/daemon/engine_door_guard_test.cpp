// The daemon guards forward jogs near the door (issue 23), through the engine on the manual loop
// and the deterministic card: with a fresh door distance a forward jog held toward the door stops
// at drive.approach_min_standoff_m and a straight-forward Drive there is refused
// (AT_MINIMUM_STANDOFF); a stale door plane caps the forward jog speed at
// drive.stale_forward_speed_m_s; motion_started says which.
#include <algorithm>
#include <string>

#include <gtest/gtest.h>

#include "manual_engine.hpp"

namespace ajar::testing {
namespace {

class EngineDoorGuard : public ManualEngine {
 protected:
  void SetUp() override {
    start_engine([](daemon::Config& c) {
      c.base.max_wheel_speed_rad_s = 3;  // 0.3 m/s at the wheels: the drive limits bind
      c.base.max_wheel_accel_rad_s2 = 10;
    });
  }
  // Release the key and let the base rest (the engine's shutdown would wait for it otherwise).
  void TearDown() override {
    (void)send(protocol::Drive{0.0, 0.0});
    cycles(500);
    ManualEngine::TearDown();
  }
  // Holds the key for n cycles (the Drive re-sent every 0.1 s); returns how many of the re-sent
  // Drives were refused AT_MINIMUM_STANDOFF (any other refusal fails the test).
  int hold(double linear, double angular, int n) {
    int at_standoff = 0;
    for (int i = 0; i < n; i += 50) {
      const auto reply = send(protocol::Drive{linear, angular});
      if (const auto* e = std::get_if<protocol::ErrorReply>(&reply)) {
        EXPECT_EQ(e->code, ErrorCode::kAtMinimumStandoff) << e->message.view();
        ++at_standoff;
      }
      cycles(50);
    }
    return at_standoff;
  }
  static void expect_accepted(const protocol::Message& reply) {
    const auto* e = std::get_if<protocol::ErrorReply>(&reply);
    ASSERT_EQ(e, nullptr) << to_string(e->code) << ": " << e->message.view();
  }
  std::string started_detail() const {
    for (auto it = events.rbegin(); it != events.rend(); ++it)
      if (it->kind == EventKind::kMotionStarted) return std::string(it->detail.view());
    return {};
  }
};

TEST_F(EngineDoorGuard, AForwardJogHeldTowardTheDoorStopsAtTheMinimumStandoff) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);  // the door 1.5 m ahead
  const double standoff = config.drive.approach_min_standoff_m;
  // 6 s at up to 0.3 m/s: 1.8 m without the guard. Once there, the re-sent Drive is refused.
  EXPECT_GT(hold(0.3, 0.0, 3000), 0);
  const auto s = engine->status();
  ASSERT_TRUE(s.door.has_distance);
  EXPECT_GE(s.door.distance_m, standoff - 0.002) << "the jog drove past the minimum standoff";
  EXPECT_LE(s.door.distance_m, standoff + 0.005);
  EXPECT_LT(engine->telemetry().commanded_linear_m_s, 1e-3);
  EXPECT_NE(started_detail().find("forward stops at 0.400 m (door 1.500 m)"), std::string::npos)
      << started_detail();
  EXPECT_EQ(s.latched_fault, ErrorCode::kOk);
  // There, straight forward is refused and says why; turning and backing off are not.
  expect_refused(send(protocol::Drive{0.3, 0.0}), ErrorCode::kAtMinimumStandoff, "linear_m_s");
  EXPECT_EQ(hold(0.0, 0.3, 50), 0);
  EXPECT_EQ(hold(-0.1, 0.0, 300), 0);
  EXPECT_GT(engine->status().door.distance_m, standoff + 0.01);
}

TEST_F(EngineDoorGuard, AStaleDoorPlaneCapsTheForwardJogSpeed) {
  to_ready_to_align();
  hold(-0.1, 0.0, 500);  // back off about 0.08 m: the plane goes stale
  expect_accepted(send(protocol::Drive{0.0, 0.0}));
  cycles(200);
  ASSERT_TRUE(engine->status().staleness.plane);
  double fastest = 0;
  for (int i = 0; i < 10; ++i) {
    hold(0.3, 0.0, 50);
    fastest = std::max(fastest, engine->telemetry().commanded_linear_m_s);
  }
  EXPECT_NEAR(fastest, config.drive.stale_forward_speed_m_s, 1e-12);
  EXPECT_NE(started_detail().find("forward at most 0.050 m/s: stale door plane"), std::string::npos)
      << started_detail();
  // Measuring the plane again lifts the cap (the guard is the standoff again).
  expect_accepted(send(protocol::Drive{0.0, 0.0}));
  cycles(300);
  expect_ack(send(plane_at_yaw(0.0)), ProcedureState::kReadyToAlign);
  hold(0.3, 0.0, 200);  // 0.04 m: the fresh plane does not go stale on the way
  EXPECT_GT(engine->telemetry().commanded_linear_m_s, 0.15);
}

}  // namespace
}  // namespace ajar::testing
