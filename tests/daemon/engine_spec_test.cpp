// The engine's side of what docs/protocol.md now says normatively (issue 24, "The spec"), on the
// manual loop and the fake clock: zero-count motions are opened and closed by events, Telemetry's
// daemon_time_ns is when the loop sampled the wheels.
#include <gtest/gtest.h>

#include "manual_engine.hpp"

namespace ajar::testing {
namespace {

class EngineSpec : public ManualEngine {
 protected:
  std::vector<EventKind> kinds() const {
    std::vector<EventKind> out;
    for (const auto& e : events)
      out.push_back(e.kind);
    return out;
  }
};

// Before: a plane already square sent Ack(aligned) and state_changed, but no motion event, so a
// client waiting for the completion of its accepted AlignBase (5.7) waited for ever.
TEST_F(EngineSpec, AZeroCountAlignmentIsOpenedAndClosedByEvents) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  expect_ack(send(plane_at_yaw(0.0)), ProcedureState::kReadyToAlign);
  events.clear();
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligned);
  EXPECT_EQ(kinds(), (std::vector<EventKind>{EventKind::kMotionStarted, EventKind::kMotionFinished,
                                             EventKind::kStateChanged}));
  EXPECT_EQ(events.at(1).state, ProcedureState::kAligned);
  EXPECT_EQ(moves(), 0);  // nothing turned
}

TEST_F(EngineSpec, AZeroCountApproachIsOpenedAndClosedByEvents) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  const auto door = engine->status().door;
  ASSERT_TRUE(door.has_distance);
  events.clear();
  const auto reply = send(protocol::Approach{door.distance_m});
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(reply));
  const auto& body = std::get<protocol::ApproachAck>(std::get<protocol::Ack>(reply).body);
  EXPECT_EQ(body.left_counts, 0);
  EXPECT_EQ(body.right_counts, 0);
  EXPECT_EQ(kinds(),
            (std::vector<EventKind>{EventKind::kMotionStarted, EventKind::kMotionFinished}));
  EXPECT_EQ(moves(), 0);
  cycles(5);
  EXPECT_FALSE(engine->telemetry().moving);
}

// Before: Telemetry.daemon_time_ns was taken when the frame was built, while its wheel positions,
// odometry and commanded velocity are the loop's last cycle's.
TEST_F(EngineSpec, TelemetryIsStampedWithTheCycleThatSampledTheWheels) {
  cycles(3);
  const std::uint64_t cycle_time_ns = engine->telemetry().daemon_time_ns;
  clock.advance_ns(7 * kPeriodNs);  // the frame is built later than the cycle ran
  const auto t = engine->telemetry();
  EXPECT_EQ(t.daemon_time_ns, cycle_time_ns);
  EXPECT_EQ(engine->daemon_time_ns(), cycle_time_ns + 7 * kPeriodNs);
  cycles(1);
  EXPECT_EQ(engine->telemetry().daemon_time_ns, engine->daemon_time_ns());
}

}  // namespace
}  // namespace ajar::testing

namespace ajar::testing {
namespace {

// Protocol 1.2's base_motion: the procedure state stays at its step during a jog or an Approach
// (issue 24: both said awaiting_handle, only Telemetry.moving revealed the motion).
TEST_F(EngineSpec, BaseMotionSaysWhatMovesTheBaseWhileTheStateStaysAtTheStep) {
  using protocol::BaseMotion;
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  EXPECT_EQ(engine->status().base_motion, BaseMotion::kNone);
  const auto door = engine->status().door;
  events.clear();
  ASSERT_TRUE(
      std::holds_alternative<protocol::Ack>(send(protocol::Approach{door.distance_m - 0.05})));
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.front().kind, EventKind::kMotionStarted);
  EXPECT_EQ(events.front().base_motion, BaseMotion::kApproaching);
  EXPECT_EQ(events.front().state, ProcedureState::kAwaitingHandle);
  EXPECT_EQ(engine->telemetry().base_motion, BaseMotion::kApproaching);
  EXPECT_EQ(engine->status().state, ProcedureState::kAwaitingHandle);
  for (int i = 0; i < 3000 && count(EventKind::kMotionFinished) == 0; ++i)
    cycles(1);
  ASSERT_EQ(count(EventKind::kMotionFinished), 1);
  EXPECT_EQ(events.back().base_motion, BaseMotion::kNone);
  EXPECT_EQ(engine->telemetry().base_motion, BaseMotion::kNone);

  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(send(protocol::Drive{-0.05, 0.0})));
  EXPECT_EQ(engine->status().base_motion, BaseMotion::kJogging);
  cycles(20);
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(send(protocol::Stop{})));
  EXPECT_EQ(engine->telemetry().base_motion, BaseMotion::kStopping);
  for (int i = 0; i < 3000 && count(EventKind::kMotionStopped) == 0; ++i)
    cycles(1);
  EXPECT_EQ(engine->telemetry().base_motion, BaseMotion::kNone);
}

}  // namespace
}  // namespace ajar::testing
