// Driving through the engine (Drive, Approach), on the manual loop and the deterministic card: the
// command timeout, refusals, stale measurements, the door distance, stops, deadman, one-read races.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "ajar/core/driving.hpp"
#include "ajar/core/geometry.hpp"
#include "manual_engine.hpp"

namespace ajar::testing {
namespace {

class EngineDrive : public ManualEngine {
 protected:
  int jogs_with_speed() const { return count_calls(*card, CardCall::kJog, 0, true); }
  // Holds the "key" for `seconds`: the Drive re-sent every 0.2 s (fake time), loop cycles between.
  void hold(double linear, double angular, double seconds) {
    for (double t = 0; t < seconds; t += 0.2) {
      expect_accepted(send(protocol::Drive{linear, angular}));
      cycles(100);
    }
  }
  void release_and_rest() {
    expect_accepted(send(protocol::Drive{0.0, 0.0}));
    cycles(500);
    ASSERT_FALSE(engine->telemetry().moving);
  }
  static void expect_accepted(const protocol::Message& reply) {
    const auto* e = std::get_if<protocol::ErrorReply>(&reply);
    ASSERT_EQ(e, nullptr) << to_string(e->code) << ": " << e->message.view();
  }
  const protocol::Event* last(EventKind kind) const {
    for (auto it = events.rbegin(); it != events.rend(); ++it)
      if (it->kind == kind) return &*it;
    return nullptr;
  }
  bool paired() const {
    return count(EventKind::kMotionStarted) ==
           count(EventKind::kMotionStopped) + count(EventKind::kMotionFinished);
  }
};

TEST_F(EngineDrive, TheCommandTimeoutStopsAJogWhileTheControllerKeepsPinging) {
  cycles(3);
  expect_accepted(send(protocol::Drive{0.1, 0.0}));
  EXPECT_EQ(count(EventKind::kMotionStarted), 1);
  cycles(100);  // 0.2 s
  EXPECT_TRUE(engine->telemetry().moving);
  EXPECT_GT(engine->telemetry().commanded_linear_m_s, 0.05);
  cycles(1000);  // 2 s with heartbeats but no Drive
  EXPECT_FALSE(engine->telemetry().moving);
  EXPECT_EQ(engine->telemetry().commanded_linear_m_s, 0.0);
  ASSERT_NE(last(EventKind::kMotionFinished), nullptr);
  EXPECT_NE(std::string(last(EventKind::kMotionFinished)->detail.view()).find("command_timeout"),
            std::string::npos);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  EXPECT_TRUE(paired());
  // The odometry saw the base move straight ahead.
  const auto s = engine->status();
  EXPECT_GT(s.odometry_x_m, 0.01);
  EXPECT_NEAR(s.odometry_y_m, 0.0, 1e-9);
}

TEST_F(EngineDrive, AZeroDriveWithNothingMovingDoesNothing) {
  cycles(3);
  expect_accepted(send(protocol::Drive{0.0, 0.0}));
  cycles(10);
  EXPECT_EQ(count(EventKind::kMotionStarted), 0);
  EXPECT_EQ(jogs_with_speed(), 0);
}

TEST_F(EngineDrive, MeasurementsAlignAndApproachWaitWhileTheBaseIsDriven) {
  to_ready_to_align();
  expect_accepted(send(protocol::Drive{0.05, 0.0}));
  cycles(10);
  expect_refused(send(good_width()), ErrorCode::kMotionInProgress);
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kMotionInProgress);
  expect_refused(send(protocol::Approach{1.0}), ErrorCode::kMotionInProgress);
  expect_accepted(send(protocol::Stop{}));
  // The wheels are still stopping: one code for every motion command (issue 24: Drive and
  // Approach answered DRIVE_NOT_ALLOWED, AlignBase and Engage MOTION_IN_PROGRESS).
  expect_refused(send(protocol::Drive{0.05, 0.0}), ErrorCode::kMotionInProgress);
  expect_refused(send(protocol::Approach{1.0}), ErrorCode::kMotionInProgress);
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kMotionInProgress);
  cycles(300);
  EXPECT_TRUE(paired());
}

TEST_F(EngineDrive, DriveIsRefusedWhileAligningAndWhileEngaged) {
  to_ready_to_align();
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  expect_refused(send(protocol::Drive{0.1, 0.0}), ErrorCode::kMotionInProgress);
  cycles(1000);
  expect_ack(send(good_contact()), ProcedureState::kReadyToEngage);
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
  expect_refused(send(protocol::Drive{0.1, 0.0}), ErrorCode::kDriveNotAllowed);
  expect_refused(send(protocol::Approach{1.0}), ErrorCode::kDriveNotAllowed);
  EXPECT_EQ(jogs_with_speed(), 0);
}

TEST_F(EngineDrive, ApproachNeedsADistanceAndAStandoffAboveTheMinimum) {
  cycles(3);
  expect_refused(send(protocol::Approach{1.0}), ErrorCode::kNoDoorDistance);
  expect_refused(send(protocol::Approach{0.1}), ErrorCode::kStandoffOutOfRange, "standoff_m");
  expect_refused(send(protocol::Approach{std::nan("")}), ErrorCode::kStandoffOutOfRange,
                 "standoff_m");
  EXPECT_EQ(moves(), 0);
}

TEST_F(EngineDrive, ApproachFromTheWidthPointsEndsAtTheStandoff) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);  // door line 1.5 m ahead
  auto s = engine->status();
  ASSERT_TRUE(s.door.has_distance);
  const double start = s.door.distance_m;
  const auto reply = send(protocol::Approach{1.0});
  const auto* ack = std::get_if<protocol::Ack>(&reply);
  ASSERT_NE(ack, nullptr);
  const auto& body = std::get<protocol::ApproachAck>(ack->body);
  EXPECT_NEAR(body.start_distance_m, start, 1e-12);
  EXPECT_NEAR(body.travel_m, start - 1.0, 1e-12);
  const auto wheels = core::straight_command(body.travel_m, config.base);
  EXPECT_EQ(body.left_counts, wheels.left_counts);
  EXPECT_EQ(body.right_counts, wheels.right_counts);
  cycles(3000);
  ASSERT_EQ(moves(), 1);
  EXPECT_EQ(card->log_from(card->log_size() - 1).at(0).kind, CardCall::kMoveRelative);
  s = engine->status();
  EXPECT_NEAR(s.door.distance_m, 1.0, 1e-4);
  EXPECT_NEAR(s.odometry_x_m, start - 1.0, 1e-4);
  ASSERT_NE(last(EventKind::kMotionFinished), nullptr);
  EXPECT_NE(std::string(last(EventKind::kMotionFinished)->detail.view()).find("approach finished"),
            std::string::npos);
  // The width is a scalar: the procedure goes on from where it was.
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  EXPECT_TRUE(paired());
}

TEST_F(EngineDrive, StopMidApproachLeavesTheBaseBetween) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  expect_accepted(send(protocol::Approach{1.0}));
  cycles(40);
  expect_accepted(send(protocol::Stop{}));
  cycles(300);
  const auto s = engine->status();
  EXPECT_GT(s.door.distance_m, 1.0 + 1e-3);
  EXPECT_LT(s.door.distance_m, 1.5 - 1e-3);
  ASSERT_NE(last(EventKind::kMotionStopped), nullptr);
  EXPECT_EQ(s.latched_fault, ErrorCode::kOk);
  EXPECT_TRUE(paired());
  // A new approach from where it stopped reaches the standoff.
  expect_accepted(send(protocol::Approach{1.0}));
  cycles(3000);
  EXPECT_NEAR(engine->status().door.distance_m, 1.0, 1e-4);
}

TEST_F(EngineDrive, ApproachRefusesWhenNotSquareOrTooFar) {
  restart([](daemon::Config& c) { c.drive.approach_max_travel_m = 0.3; });
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  expect_refused(send(protocol::Approach{1.0}), ErrorCode::kApproachTooFar, "standoff_m");
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  expect_ack(send(plane_at_yaw(0.3)), ProcedureState::kReadyToAlign);  // 0.3 rad > 0.2
  expect_refused(send(protocol::Approach{1.4}), ErrorCode::kNotSquareToDoor, "door.yaw_rad");
  EXPECT_EQ(moves(), 0);
}

TEST_F(EngineDrive, DrivingAwayMakesThePlaneStaleForAlignBaseAndApproach) {
  to_ready_to_align();
  hold(0.1, 0.0, 1.0);
  release_and_rest();
  const auto s = engine->status();
  EXPECT_TRUE(s.staleness.plane);
  EXPECT_GT(s.staleness.travel_since_plane_m, config.drive.stale_travel_m);
  EXPECT_EQ(s.state, ProcedureState::kReadyToAlign);
  const auto align = send(protocol::AlignBase{});
  expect_refused(align, ErrorCode::kMeasurementStale, "plane");
  EXPECT_NE(std::string(std::get<protocol::ErrorReply>(align).message.view()).find("moved"),
            std::string::npos);
  expect_refused(send(protocol::Approach{1.0}), ErrorCode::kMeasurementStale, "plane");
  const int before = moves();
  // Measuring the plane again makes it fresh; AlignBase then runs.
  expect_ack(send(plane_at_yaw(0.1)), ProcedureState::kReadyToAlign);
  EXPECT_FALSE(engine->status().staleness.plane);
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  cycles(1000);
  EXPECT_EQ(moves(), before + 1);
  EXPECT_EQ(state(), ProcedureState::kAligned);
  // AlignBase's own turn did not make the plane stale.
  EXPECT_FALSE(engine->status().staleness.plane);
}

TEST_F(EngineDrive, AlignBaseAfterASmallTurnUsesTheYawSeenFromThePoseNow) {
  to_ready_to_align();  // plane at yaw 0.1
  hold(0.0, 0.1, 0.2);  // a small turn, below stale_yaw_rad
  release_and_rest();
  const auto s = engine->status();
  ASSERT_FALSE(s.staleness.plane);
  const double turned = s.base_yaw_odometry_rad;
  ASSERT_GT(std::abs(turned), 1e-3);
  const double yaw_now = s.plane.yaw_deviation_rad - turned;
  EXPECT_NEAR(s.door.yaw_rad, yaw_now, 1e-9);
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  cycles(1);
  const auto wheels = core::wheel_command(yaw_now, config.base);
  const auto log = card->log_from(0);
  ASSERT_FALSE(log.empty());
  const auto& move = log.back();
  ASSERT_EQ(move.kind, CardCall::kMoveRelative);
  EXPECT_EQ(move.distance_counts(left_axis), wheels.left_counts);
  EXPECT_EQ(move.distance_counts(right_axis), wheels.right_counts);
  EXPECT_NE(wheels.left_counts, s.plane.left_counts);  // not the command measured before the turn
}

TEST_F(EngineDrive, EngageRefusesAContactPointTakenBeforeTheBaseMoved) {
  to_ready_to_engage();
  hold(-0.1, 0.0, 1.0);  // backwards
  release_and_rest();
  EXPECT_TRUE(engine->status().staleness.contact);
  expect_refused(send(protocol::Engage{}), ErrorCode::kMeasurementStale);
  EXPECT_TRUE(arm->tasks().empty());
}

TEST_F(EngineDrive, ADriveAndAStopInOneReadNeverJog) {
  cycles(3);
  engine->begin_read_batch();
  expect_accepted(send(protocol::Drive{0.1, 0.0}));
  expect_accepted(send(protocol::Stop{}));
  engine->end_read_batch();
  cycles(50);
  EXPECT_EQ(jogs_with_speed(), 0);
  EXPECT_EQ(count(EventKind::kMotionStarted), 1);
  EXPECT_EQ(count(EventKind::kMotionStopped), 1);
  // And Approach: the same.
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  engine->begin_read_batch();
  expect_accepted(send(protocol::Approach{1.0}));
  expect_accepted(send(protocol::EmergencyStop{}));
  engine->end_read_batch();
  cycles(50);
  EXPECT_EQ(moves(), 0);
  EXPECT_TRUE(paired());
}

TEST_F(EngineDrive, ResetStopsAJogAndAnApproach) {
  cycles(3);
  expect_accepted(send(protocol::Drive{0.1, 0.0}));
  cycles(20);
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingWidth);
  cycles(150);  // well before the command timeout would have ended the jog
  EXPECT_FALSE(engine->telemetry().moving);
  ASSERT_NE(last(EventKind::kMotionStopped), nullptr);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  expect_accepted(send(protocol::Approach{1.0}));
  cycles(20);
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingHandle);
  cycles(300);
  EXPECT_FALSE(engine->telemetry().moving);
  EXPECT_GT(engine->status().door.distance_m, 1.0 + 1e-3);  // stopped short of the standoff
  EXPECT_TRUE(paired());
}

TEST_F(EngineDrive, ControllerLostWhileDrivingStopsAndLatchesDeadman) {
  cycles(3);
  expect_accepted(send(protocol::Drive{0.1, 0.0}));
  cycles(20);
  engine->controller_lost();
  cycles(300);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kDeadman);
  EXPECT_FALSE(engine->telemetry().moving);
  EXPECT_TRUE(paired());
}

TEST_F(EngineDrive, TheDeadmanStopsAJogWhenTheControllerFallsSilent) {
  cycles(3);
  expect_accepted(send(protocol::Drive{0.1, 0.0}));
  cycles(100, /*alive=*/false);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kDeadman);
  cycles(300, false);
  EXPECT_FALSE(engine->telemetry().moving);
  EXPECT_TRUE(paired());
}

}  // namespace
}  // namespace ajar::testing
