// The loop supervisor on a fake clock, by hand (check(now), no thread): a fake loop whose last
// cycle end the test sets, and the mock card, whose out-of-band stop it must reach. What latches a
// stall, when it does not, once per stall, in which order, and re-arming.
#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <vector>

#include "ajar/daemon/loop_supervisor.hpp"
#include "ajar/drivers/mock_card.hpp"

namespace ajar::daemon {
namespace {

using drivers::CardCall;

constexpr std::int64_t kMs = 1'000'000;
constexpr std::array<int, 2> kWheels{1, 2};

class LoopSupervisorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    card.set_manual_clock(true);
    ASSERT_TRUE(card.open().ok());
    ASSERT_EQ(card.enable_axes(kWheels), ErrorCode::kOk);
    const drivers::AxisVelocity jog[2] = {{1, 5.0}, {2, -5.0}};
    ASSERT_EQ(card.jog(jog, {}), ErrorCode::kOk);  // the wheels turn: a jog
    settings.loop_rate_hz = 500;
    settings.stall_timeout_s = 0.1;
    make();
  }
  void make() {
    supervisor = std::make_unique<LoopSupervisor>(
        SupervisedLoop{[this] { return running; }, [this] { return last_end_ns; },
                       [this] {
                         // The order: the loop's latch comes before the card's stop.
                         latch_calls.push_back(card.calls(CardCall::kEmergencyStopOutOfBand));
                       }},
        card, kWheels, settings);
  }
  // The loop completes a cycle at `t` and the supervisor checks right after.
  bool cycle_and_check(std::int64_t t) {
    last_end_ns = t;
    return supervisor->check(t);
  }
  // Checks every check period from `from` for `span_ns` with no cycle; the first check that
  // latched (its time), or -1.
  std::int64_t quiet_checks(std::int64_t from, std::int64_t span_ns) {
    const std::int64_t step = supervisor->check_period_ns();
    for (std::int64_t t = from; t <= from + span_ns; t += step) {
      if (supervisor->check(t)) return t;
    }
    return -1;
  }
  std::uint64_t oob_stops() const { return card.calls(CardCall::kEmergencyStopOutOfBand); }

  drivers::MockMotionCard card{drivers::MockFault::kNone, 0, 1.0, 4};
  LoopSupervisorSettings settings;
  std::unique_ptr<LoopSupervisor> supervisor;
  bool running = true;
  std::int64_t last_end_ns = 1'000 * kMs;
  std::vector<std::uint64_t> latch_calls;  // out-of-band stops already made at each latch
};

TEST_F(LoopSupervisorTest, ALoopThatKeepsCyclingIsNeverTakenForStalled) {
  for (std::int64_t t = 1'000 * kMs; t < 3'000 * kMs; t += 2 * kMs) {
    ASSERT_FALSE(cycle_and_check(t)) << t;
  }
  EXPECT_EQ(supervisor->stalls(), 0U);
  EXPECT_FALSE(supervisor->stalled());
  EXPECT_TRUE(latch_calls.empty());
  EXPECT_EQ(oob_stops(), 0U);
  EXPECT_TRUE(card.jogging(1));
}

TEST_F(LoopSupervisorTest, AStalledLoopLatchesOnceAndTheOutOfBandStopReachesTheCard) {
  const std::int64_t start = 1'000 * kMs;
  ASSERT_FALSE(cycle_and_check(start));
  const std::int64_t latched_at = quiet_checks(start + supervisor->check_period_ns(), 1'000 * kMs);
  ASSERT_GE(latched_at, 0) << "no stall latched in 1 s without a cycle";
  // Not before the timeout, and after at least kQuietChecks checks that saw no cycle.
  EXPECT_GE(latched_at - start, supervisor->stall_timeout_ns());
  EXPECT_GE(latched_at - start, LoopSupervisor::kQuietChecks * supervisor->check_period_ns());
  EXPECT_EQ(supervisor->stalls(), 1U);
  EXPECT_TRUE(supervisor->stalled());
  const auto stall = supervisor->last_stall();
  EXPECT_EQ(stall.count, 1U);
  EXPECT_EQ(stall.stops, 1U);
  EXPECT_EQ(supervisor->stops(), 1U);
  EXPECT_EQ(stall.stop_result, ErrorCode::kOk);
  EXPECT_EQ(stall.silent_ns, latched_at - start);
  // The loop was told first, then the card stopped out of band: the wheels rest, latched.
  ASSERT_EQ(latch_calls.size(), 1U);
  EXPECT_EQ(latch_calls[0], 0U);
  EXPECT_EQ(oob_stops(), 1U);
  for (const int axis : kWheels) {
    const auto st = card.peek(axis);
    EXPECT_FALSE(st.moving) << axis;
    EXPECT_TRUE(st.emergency_stopped) << axis;
  }
  card.advance_clock_ns(1'000 * kMs);  // simulated time goes on: the wheels stay where they are
  const auto here = card.peek(1).encoder_position_counts;
  card.advance_clock_ns(1'000 * kMs);
  EXPECT_EQ(card.peek(1).encoder_position_counts, here);
  // The same stall is acted on once, however long it lasts.
  EXPECT_EQ(quiet_checks(latched_at + 1, 10'000 * kMs), -1);
  EXPECT_EQ(supervisor->stalls(), 1U);
  EXPECT_EQ(oob_stops(), 1U);
  EXPECT_EQ(latch_calls.size(), 1U);
}

TEST_F(LoopSupervisorTest, ItReArmsWhenTheLoopCyclesAgainAndLatchesTheNextStall) {
  std::int64_t t = 1'000 * kMs;
  ASSERT_FALSE(cycle_and_check(t));
  t = quiet_checks(t + 1, 1'000 * kMs);
  ASSERT_GE(t, 0);
  ASSERT_TRUE(supervisor->stalled());
  // The hung call returned: the loop cycles again.
  t += 500 * kMs;
  EXPECT_FALSE(cycle_and_check(t));
  EXPECT_FALSE(supervisor->stalled());
  for (int i = 0; i < 50; ++i) {
    t += 2 * kMs;
    EXPECT_FALSE(cycle_and_check(t));
  }
  EXPECT_EQ(supervisor->stalls(), 1U);
  // A second hang is a second stall.
  EXPECT_GE(quiet_checks(t + 1, 1'000 * kMs), 0);
  EXPECT_EQ(supervisor->stalls(), 2U);
  EXPECT_EQ(oob_stops(), 2U);
  EXPECT_EQ(latch_calls.size(), 2U);
}

TEST_F(LoopSupervisorTest, ALateSupervisorIsNotEnoughItMustWatchTheSilence) {
  // The whole process was not scheduled for 5 s (the supervisor included): its first check after
  // that sees an old cycle end, but it has watched no silence yet; the loop runs before its next
  // checks, so nothing latches.
  std::int64_t t = 1'000 * kMs;
  ASSERT_FALSE(cycle_and_check(t));
  t += 5'000 * kMs;
  EXPECT_FALSE(supervisor->check(t));
  t += supervisor->check_period_ns();
  EXPECT_FALSE(cycle_and_check(t - kMs));
  for (int i = 0; i < 100; ++i) {
    t += 2 * kMs;
    EXPECT_FALSE(cycle_and_check(t));
  }
  EXPECT_EQ(supervisor->stalls(), 0U);
  EXPECT_EQ(oob_stops(), 0U);
}

TEST_F(LoopSupervisorTest, QuietChecksAloneAreNotEnoughTheTimeoutMustPass) {
  // Many checks in quick succession (a supervisor woken often) but less than the timeout.
  std::int64_t t = 1'000 * kMs;
  ASSERT_FALSE(cycle_and_check(t));
  for (int i = 1; i <= 20; ++i) {
    EXPECT_FALSE(supervisor->check(t + i * (supervisor->stall_timeout_ns() / 21))) << i;
  }
  EXPECT_EQ(supervisor->stalls(), 0U);
  EXPECT_TRUE(supervisor->check(t + supervisor->stall_timeout_ns()));
  EXPECT_EQ(supervisor->stalls(), 1U);
}

TEST_F(LoopSupervisorTest, NothingIsWatchedWhileTheLoopThreadDoesNotRun) {
  running = false;
  EXPECT_EQ(quiet_checks(1'000 * kMs, 10'000 * kMs), -1);
  EXPECT_EQ(supervisor->stalls(), 0U);
  EXPECT_EQ(oob_stops(), 0U);
  // Started: watched from its first cycle on.
  running = true;
  ASSERT_FALSE(cycle_and_check(20'000 * kMs));
  EXPECT_GE(quiet_checks(20'000 * kMs + 1, 1'000 * kMs), 0);
  EXPECT_EQ(supervisor->stalls(), 1U);
}

TEST_F(LoopSupervisorTest, AStopTheCardRefusesIsReportedAndTheStallStillLatches) {
  ASSERT_TRUE(card.close().ok());  // the out-of-band stop cannot reach a closed card
  ASSERT_FALSE(cycle_and_check(1'000 * kMs));
  EXPECT_GE(quiet_checks(1'000 * kMs + 1, 1'000 * kMs), 0);
  EXPECT_EQ(supervisor->stalls(), 1U);
  EXPECT_EQ(supervisor->last_stall().stop_result, ErrorCode::kDriverError);
  EXPECT_EQ(latch_calls.size(), 1U);
}

TEST_F(LoopSupervisorTest, TheTimeoutIsAtLeastTwoLoopPeriods) {
  settings.loop_rate_hz = 10;  // 100 ms periods
  settings.stall_timeout_s = 0.005;
  make();
  EXPECT_EQ(supervisor->stall_timeout_ns(), 200 * kMs);
  // A loop at 10 Hz is not stalled between its cycles.
  for (std::int64_t t = 1'000 * kMs; t < 5'000 * kMs; t += 100 * kMs) {
    ASSERT_FALSE(cycle_and_check(t));
    ASSERT_EQ(quiet_checks(t + 1, 99 * kMs), -1);
  }
  EXPECT_EQ(supervisor->stalls(), 0U);
}

}  // namespace
}  // namespace ajar::daemon
