// MockMotionCard's test configuration (mock_card.hpp): the constant-speed model, the call log and
// counters, the one-shot faults and the behaviour switches the daemon's tests rely on. On a fake
// clock, each change checked just before and at the instant it is due.
#include <gtest/gtest.h>

#include <array>

#include "ajar/drivers/mock_card.hpp"
#include "card_test_support.hpp"
#include "fake_clock.hpp"

namespace ajar::drivers {
namespace {

using ajar::testing::FakeClock;
using testing::status_of;

using testing::kWheels;
constexpr std::array<int, 1> kLeft{1};
constexpr AxisMove kBothWheelsMove[] = {{1, 500}, {2, -200}};
// 2 counts/ms; the ramps are ignored by the constant-speed model.
constexpr TrapezoidProfile kProfile{2, 0.01, 0.01, 0};
constexpr JogProfile kSlowJog{0.01, 0.01, 0};
constexpr std::int64_t kStopDelayNs = 6'000'000;

struct MockCardConfig : ::testing::Test {
  void SetUp() override {
    card.set_motion_model(MockMotionModel::kConstantSpeed, kStopDelayNs);
    card.record_calls(true);
    ASSERT_TRUE(card.open().ok());
    ASSERT_EQ(card.enable_axes(kWheels), ErrorCode::kOk);
  }
  std::int64_t position(int axis) { return status_of(card, axis)->encoder_position_counts; }
  bool moving(int axis) { return status_of(card, axis)->moving; }

  FakeClock clock;
  MockMotionCard card{MockFault::kNone, 0, 1.0, 4, clock.clock()};
};

TEST_F(MockCardConfig, ConstantSpeedMovesRunAtTheProfileVelocityFromTheFirstInstant) {
  ASSERT_EQ(card.move_relative(kBothWheelsMove, kProfile), ErrorCode::kOk);
  clock.advance_ms(10);
  EXPECT_EQ(position(1), 20);
  EXPECT_EQ(position(2), -20);
  clock.advance_ms(89);  // axis 2: 200 counts take 100 ms
  EXPECT_TRUE(moving(2));
  clock.advance_ms(1);
  EXPECT_FALSE(moving(2));
  EXPECT_EQ(position(2), -200);
  clock.advance_ms(149);  // axis 1: 500 counts take 250 ms
  EXPECT_TRUE(moving(1));
  clock.advance_ms(1);
  EXPECT_FALSE(moving(1));
  EXPECT_EQ(position(1), 500);
}

TEST_F(MockCardConfig, ConstantSpeedJogsTakeTheirVelocityAtOnceAndStopsRestAfterTheDelay) {
  const AxisVelocity v[] = {{1, 3.0}};
  ASSERT_EQ(card.jog(v, kSlowJog), ErrorCode::kOk);
  EXPECT_TRUE(card.jogging(1));
  clock.advance_ms(10);
  EXPECT_EQ(position(1), 30);
  ASSERT_EQ(card.smooth_stop(kLeft), ErrorCode::kOk);
  EXPECT_TRUE(card.peek(1).smooth_stopped);
  clock.advance_ns(kStopDelayNs - 1);
  EXPECT_TRUE(moving(1));
  clock.advance_ns(1);
  EXPECT_FALSE(moving(1));
  EXPECT_FALSE(card.jogging(1));
  card.set_motion_model(MockMotionModel::kConstantSpeed, 0);  // stops rest at once
  ASSERT_EQ(card.jog(v, kSlowJog), ErrorCode::kOk);
  ASSERT_EQ(card.smooth_stop(kLeft), ErrorCode::kOk);
  EXPECT_FALSE(moving(1));
}

TEST_F(MockCardConfig, TheLogRecordsCommandingCallsWithTheirArgumentsAndCountersCountEveryCall) {
  const std::size_t start = card.log_size();
  EXPECT_EQ(start, 1U);  // the set-up's enable_axes
  ASSERT_EQ(card.move_relative(kBothWheelsMove, kProfile), ErrorCode::kOk);
  EXPECT_EQ(card.motion_call(1), start);
  AxisStatus st;
  ASSERT_EQ(card.axis_status(1, st), ErrorCode::kOk);  // counted, not logged
  ASSERT_EQ(card.emergency_stop(kWheels), ErrorCode::kOk);
  const auto log = card.log_from(start);
  ASSERT_EQ(log.size(), 2U);
  EXPECT_EQ(log[0].kind, CardCall::kMoveRelative);
  EXPECT_EQ(log[0].distance_counts(1), 500);
  EXPECT_EQ(log[0].distance_counts(2), -200);
  EXPECT_EQ(log[0].distance_counts(3), 0);
  EXPECT_EQ(log[0].profile.velocity_counts_per_ms, 2);
  EXPECT_EQ(log[1].kind, CardCall::kEmergencyStop);
  EXPECT_EQ(log[1].axes, std::vector<int>(kWheels.begin(), kWheels.end()));
  EXPECT_EQ(card.calls(CardCall::kAxisStatus), 1U);
  EXPECT_EQ(card.calls(CardCall::kMoveRelative), 1U);
  EXPECT_EQ(card.calls(), 5U);  // open, enable, move, status, emergency stop
}

TEST_F(MockCardConfig, NotAnsweringFailsTheNextCallsButNeverTheEmergencyStop) {
  ASSERT_EQ(card.move_relative(kBothWheelsMove, kProfile), ErrorCode::kOk);
  const std::size_t start = card.log_size();
  card.fail_next_calls(2);
  AxisStatus st;
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kCardCommunication);
  EXPECT_EQ(card.emergency_stop(kWheels), ErrorCode::kOk);  // not one of the two
  EXPECT_FALSE(card.peek(2).moving);
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kCardCommunication);
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kOk);
  const auto log = card.log_from(start);
  ASSERT_EQ(log.size(), 1U);  // failed calls reached nothing
  EXPECT_EQ(log[0].kind, CardCall::kEmergencyStop);
}

TEST_F(MockCardConfig, RefusedAndStuckMovesAreOneShot) {
  card.refuse_next_move(ErrorCode::kCardBusy);
  EXPECT_EQ(card.move_relative(kBothWheelsMove, kProfile), ErrorCode::kCardBusy);
  EXPECT_EQ(card.last_failure().code, ErrorCode::kCardBusy);
  EXPECT_FALSE(moving(1));
  card.stick_next_move();
  ASSERT_EQ(card.move_relative(kBothWheelsMove, kProfile), ErrorCode::kOk);
  clock.advance_ms(1000);
  EXPECT_TRUE(moving(1));
  EXPECT_EQ(position(1), 0);
  ASSERT_EQ(card.smooth_stop(kWheels), ErrorCode::kOk);  // stops still work
  EXPECT_FALSE(moving(1));
  ASSERT_EQ(card.move_relative(kBothWheelsMove, kProfile), ErrorCode::kOk);  // the next one runs
  clock.advance_ms(1000);
  EXPECT_EQ(position(1), 500);
}

TEST_F(MockCardConfig, StopsThatNeverRestRestOnceCleared) {
  card.set_stops_never_rest(true);
  ASSERT_EQ(card.move_relative(kBothWheelsMove, kProfile), ErrorCode::kOk);
  clock.advance_ms(10);
  ASSERT_EQ(card.smooth_stop(kWheels), ErrorCode::kOk);
  clock.advance_ms(24 * 3600e3);
  EXPECT_TRUE(moving(1));
  EXPECT_TRUE(card.peek(1).smooth_stopped);
  EXPECT_EQ(position(1), 20);  // where it was told to stop
  card.set_stops_never_rest(false);
  EXPECT_FALSE(moving(1));
  EXPECT_FALSE(card.any_moving());
}

TEST_F(MockCardConfig, TheServoShowsOnAfterTheDelayAndAPersistingAlarmSurvivesClearFaults) {
  card.set_alarm_persists(true);
  card.inject_alarm(1);
  ASSERT_EQ(card.clear_faults(kLeft), ErrorCode::kOk);
  EXPECT_TRUE(card.peek(1).alarm);
  card.set_alarm_persists(false);
  ASSERT_EQ(card.clear_faults(kLeft), ErrorCode::kOk);
  EXPECT_FALSE(card.peek(1).alarm);
  card.set_enable_delay_reads(3);
  ASSERT_EQ(card.enable_axes(kLeft), ErrorCode::kOk);
  AxisStatus st;
  for (int read = 1; read < 3; ++read) {
    ASSERT_EQ(card.axis_status(1, st), ErrorCode::kOk);
    EXPECT_FALSE(st.enabled) << "read " << read;
  }
  ASSERT_EQ(card.axis_status(1, st), ErrorCode::kOk);
  EXPECT_TRUE(st.enabled);
}

// Card faults (the control loop's supervision and the interleaving campaign): a command accepted
// but not applied, applied but answered with an error, stale status, and a card that is silent for
// a while (the emergency stop too) while its motion goes on.
TEST_F(MockCardConfig, DroppedCallsAnswerOkChangeNothingAndAreLoggedAsNotApplied) {
  card.drop_next_calls(CardCall::kJog, 1);
  const AxisVelocity v[] = {{1, 3.0}};
  ASSERT_EQ(card.jog(v, kSlowJog), ErrorCode::kOk);
  EXPECT_FALSE(card.jogging(1));
  ASSERT_EQ(card.jog(v, kSlowJog), ErrorCode::kOk);  // only the next one
  EXPECT_TRUE(card.jogging(1));
  EXPECT_EQ(card.velocity(1), 3.0);
  card.drop_next_calls(CardCall::kSmoothStop, 1);
  ASSERT_EQ(card.smooth_stop(kWheels), ErrorCode::kOk);
  clock.advance_ms(10);
  EXPECT_TRUE(card.jogging(1)) << "a dropped stop stopped the axis";
  const auto log = card.log_from(0);
  ASSERT_GE(log.size(), 3U);
  EXPECT_FALSE(log[log.size() - 3].applied);
  EXPECT_TRUE(log[log.size() - 2].applied);
  EXPECT_FALSE(log.back().applied);
}

TEST_F(MockCardConfig, AFailAfterCallIsAppliedAndAnswersAnError) {
  card.fail_after_next_call(CardCall::kMoveRelative);
  EXPECT_EQ(card.move_relative(kBothWheelsMove, kProfile), ErrorCode::kCardCommunication);
  EXPECT_TRUE(moving(1)) << "the card took the move before it failed";
  EXPECT_EQ(card.log_from(0).back().result, ErrorCode::kCardCommunication);
}

TEST_F(MockCardConfig, StaleStatusRepeatsTheLastAnswerOfEachAxis) {
  const AxisVelocity v[] = {{1, 3.0}};
  ASSERT_EQ(card.jog(v, kSlowJog), ErrorCode::kOk);
  clock.advance_ms(10);
  const std::int64_t before = position(1);
  card.set_stale_status_reads(2);
  clock.advance_ms(10);
  EXPECT_EQ(position(1), before);
  EXPECT_EQ(position(1), before);
  EXPECT_EQ(position(1), before + 30);  // fresh again
}

TEST_F(MockCardConfig, ASilentCardFailsEveryCallTheEmergencyStopTooWhileItsMotionGoesOn) {
  const AxisVelocity v[] = {{1, 3.0}};
  ASSERT_EQ(card.jog(v, kSlowJog), ErrorCode::kOk);
  card.stop_answering_for_ns(20'000'000);
  EXPECT_FALSE(card.answering());
  AxisStatus st;
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kCardCommunication);
  EXPECT_EQ(card.emergency_stop(kWheels), ErrorCode::kCardCommunication);
  clock.advance_ms(19);
  EXPECT_EQ(card.smooth_stop(kWheels), ErrorCode::kCardCommunication);
  EXPECT_TRUE(card.jogging(1));
  clock.advance_ms(1);
  EXPECT_TRUE(card.answering());
  EXPECT_EQ(card.emergency_stop(kWheels), ErrorCode::kOk);
  EXPECT_FALSE(card.any_moving());
}

}  // namespace
}  // namespace ajar::drivers
