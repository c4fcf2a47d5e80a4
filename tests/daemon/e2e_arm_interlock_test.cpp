// End to end, issue 22 item 2 (the base drove while the arm might be at the door): ajard in process
// on the `sim` drivers — the card simulator, and the serial arm driver over a pseudo-terminal to
// the arm-controller simulator (so the STOP's retries and the driver's "controller silent" path
// run as on the robot) — served on TCP to a TestClient. After Engage the arm controller stops
// answering and the operator sends Stop: a fault latches, every Drive / Approach / AlignBase is
// refused, the wheels never turn; Reset is refused while the arm is silent and accepted once it
// answers (docs/procedure.md, "The arm interlock").
#include <memory>

#include <gtest/gtest.h>

#include "ajar/daemon/engine.hpp"
#include "ajar/drivers/arm_simulator.hpp"
#include "ajar/drivers/factory.hpp"
#include "e2e_fixture.hpp"

namespace ajar::test {
namespace {

using protocol::ProcedureState;
using protocol::Role;

struct Pose {
  double x_m = 0, y_m = 0, yaw_rad = 0;
  bool operator==(const Pose&) const = default;
};

Pose pose_of(const protocol::Status& s) {
  return {s.odometry_x_m, s.odometry_y_m, s.base_yaw_odometry_rad};
}

TEST(EndToEndArmInterlock, ASilentArmAfterEngageAndStopLatchesAndTheBaseNeverMoves) {
  TempDir dir;
  const daemon::Config config = e2e_config(drivers::DriverKind::kSim, dir.path(), 10.0);
  drivers::DriverSet set = drivers::make_drivers(config.drivers, config.base);
  drivers::ArmControllerSimulator* arm = set.arm_simulator;
  ASSERT_NE(arm, nullptr);
  arm->set_task_duration_ms(600'000);  // the arm stays at the door handle
  auto engine = daemon::make_engine(config, std::move(set));
  ServerThread server(*engine, daemon::ServerOptions::from(config.network));
  TestClient controller(server.port());
  ASSERT_EQ(controller.hello(Role::kController, 0x2201).granted_role, Role::kController);

  measure_door(controller);
  ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  ASSERT_EQ(wait_for_state(controller, ProcedureState::kAligned).state, ProcedureState::kAligned);
  ASSERT_EQ(ack_state(controller.request(good_contact())), ProcedureState::kReadyToEngage);
  ASSERT_EQ(ack_state(controller.request(protocol::Engage{})), ProcedureState::kEngaging);
  ASSERT_TRUE(eventually([&] { return arm->phase() == drivers::arm::ControllerPhase::kBusy; }));
  ASSERT_TRUE(eventually([&] {
    return controller.request_as<protocol::Status>(protocol::GetStatus{}).arm_state ==
           protocol::ArmState::kBusy;
  }));
  const Pose before = pose_of(controller.request_as<protocol::Status>(protocol::GetStatus{}));

  arm->go_silent();  // the arm controller stops answering, its arm at the door
  ASSERT_EQ(ack_state(controller.request(protocol::Stop{})), ProcedureState::kReadyToEngage);
  // A new plane that needs a turn: AlignBase has nothing but the arm to refuse it for.
  ASSERT_EQ(ack_state(controller.request(plane_at_yaw(0.1))), ProcedureState::kReadyToAlign);

  // Until the fault latches (the STOP's retries run out, then the stop's deadline), every command
  // that would turn the wheels is refused because the arm has not reported idle.
  int refused = 0;
  protocol::Status status;
  const bool latched = eventually([&] {
    for (const protocol::Message& m :
         {protocol::Message{protocol::Drive{0.1, 0.0}}, protocol::Message{protocol::Approach{0.7}},
          protocol::Message{protocol::AlignBase{}}}) {
      const ErrorCode code = error_code_of(controller.request(m));
      EXPECT_TRUE(code == ErrorCode::kDriveNotAllowed || code == ErrorCode::kFaultLatched)
          << "a wheel motion was not refused while the arm was silent: " << to_string(code);
      refused += code != ErrorCode::kOk ? 1 : 0;
    }
    status = controller.request_as<protocol::Status>(protocol::GetStatus{});
    EXPECT_EQ(pose_of(status), before) << "the base moved while the arm may be at the door";
    return status.latched_fault != ErrorCode::kOk || ::testing::Test::HasFailure();
  });
  ASSERT_TRUE(latched) << "no fault latched for a stop the arm never confirmed";
  EXPECT_EQ(status.latched_fault, ErrorCode::kArmNotClear);
  EXPECT_GE(refused, 3);

  // Latched: ten more Drives, an Approach and an AlignBase, all refused; Reset is refused while the
  // arm is silent.
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(error_code_of(controller.request(protocol::Drive{0.1, 0.0})),
              ErrorCode::kFaultLatched);
  }
  EXPECT_EQ(error_code_of(controller.request(protocol::Approach{0.7})), ErrorCode::kFaultLatched);
  EXPECT_EQ(error_code_of(controller.request(protocol::AlignBase{})), ErrorCode::kFaultLatched);
  EXPECT_EQ(error_code_of(controller.request(protocol::Reset{})), ErrorCode::kArmNotClear);
  status = controller.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_EQ(status.latched_fault, ErrorCode::kArmNotClear);
  EXPECT_EQ(pose_of(status), before) << "the base moved while the arm may be at the door";
  EXPECT_EQ(arm->counters().stops, 0U) << "the silent controller acted on a stop";

  // The controller answers again: the driver's poll brings the link back, the owed STOP goes out,
  // the arm reports idle; then (and only then) Reset clears the fault.
  arm->answer_again();
  ASSERT_TRUE(eventually([&] {
    return controller.request_as<protocol::Status>(protocol::GetStatus{}).arm_state ==
           protocol::ArmState::kIdle;
  }));
  EXPECT_GE(arm->counters().stops, 1U);
  EXPECT_EQ(arm->phase(), drivers::arm::ControllerPhase::kIdle);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(controller.request(protocol::Reset{})));
  status = controller.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_EQ(status.latched_fault, ErrorCode::kOk);
  EXPECT_EQ(pose_of(status), before);
  // The base is the operator's again.
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(controller.request(protocol::Drive{0.1, 0.0})));
}

}  // namespace
}  // namespace ajar::test
