// The loop supervisor on a fake clock, by hand (check(now), no thread): a fake loop whose last
// cycle end the test sets, and the mock card, whose out-of-band stop it must reach. What latches a
// stall, when it does not, once per stall, in which order, and re-arming.
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/loop_supervisor.hpp"
#include "ajar/drivers/mock_card.hpp"
#include "fake_clock.hpp"
#include "fake_door.hpp"

namespace ajar::daemon {
namespace {

using drivers::CardCall;

using ajar::testing::kMs;
constexpr std::array<int, 2> kWheels{1, 2};

class LoopSupervisorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    card.set_manual_clock(true);
    ASSERT_TRUE(card.open().ok());
    ASSERT_EQ(card.enable_axes(kWheels), ErrorCode::kOk);
    const drivers::AxisVelocity jog[2] = {{1, 5.0}, {2, -5.0}};
    ASSERT_EQ(card.jog(jog, {}), ErrorCode::kOk);  // the wheels turn: a jog
    settings.rate_hz = 500;
    settings.stall_timeout_s = 0.1;
    make();
  }
  void make() {
    supervisor = std::make_unique<LoopSupervisor>(
        SupervisedLoop{[this] { return running; }, [this] { return last_end_ns; },
                       [this] {
                         // The order: the loop's latch comes before the card's stop.
                         latch_calls.push_back(card.calls(CardCall::kEmergencyStopOutOfBand));
                       },
                       [this] { return run_delay_ns; }},
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
  std::int64_t run_delay_ns = -1;          // the loop thread's wait for a CPU; -1: unknown
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

TEST_F(LoopSupervisorTest, ALoopThreadWaitingForACpuIsNotStalledAHungOneIs) {
  // The loop thread is runnable but not scheduled for 2 s (its run_delay grows with the clock):
  // the scheduler's doing, excused. Then it waits no more but still makes no cycle: a hung call.
  run_delay_ns = 0;
  const std::int64_t start = 1'000 * kMs;
  ASSERT_FALSE(cycle_and_check(start));
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t t = start;
  for (; t < start + 2'000 * kMs; t += step) {
    run_delay_ns += step;
    ASSERT_FALSE(supervisor->check(t + step)) << t;
  }
  EXPECT_EQ(supervisor->stalls(), 0U);
  EXPECT_EQ(oob_stops(), 0U);
  std::int64_t latched_at = -1;
  for (int i = 1; i <= 20 && latched_at < 0; ++i) {  // run_delay_ns stands still now
    if (supervisor->check(t + i * step)) latched_at = t + i * step;
  }
  ASSERT_GE(latched_at, 0);
  EXPECT_GE(latched_at - t, supervisor->stall_timeout_ns());  // only the unexcused silence counts
  const auto stall = supervisor->last_stall();
  EXPECT_EQ(stall.silent_ns, latched_at - start);
  EXPECT_EQ(stall.excused_ns, t - start);
  EXPECT_EQ(oob_stops(), 1U);
}

TEST_F(LoopSupervisorTest, AHungCallThatSpinsOnACpuCounts) {
  // A call that spins (busy-waits on the card) runs on a CPU: no wait for a CPU, the silence
  // counts as for a call that sleeps.
  run_delay_ns = 5'000 * kMs;  // whatever it waited before
  ASSERT_FALSE(cycle_and_check(1'000 * kMs));
  EXPECT_GE(quiet_checks(1'000 * kMs + 1, 1'000 * kMs), 0);
  EXPECT_EQ(supervisor->last_stall().excused_ns, 0);
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
  settings.rate_hz = 10;  // 100 ms periods
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

TEST(LoopSupervisorSchedstat, TheKernelsWaitForACpuIsReadForAThreadOfThisProcess) {
  EXPECT_EQ(thread_run_delay_ns(0), -1);
  EXPECT_EQ(thread_run_delay_ns(-5), -1);
  const std::int64_t first = thread_run_delay_ns(static_cast<int>(::gettid()));
  if (first < 0) GTEST_SKIP() << "no /proc/self/task/TID/schedstat here: the wall clock decides";
  EXPECT_GE(thread_run_delay_ns(static_cast<int>(::gettid())), first);  // it only grows
}

// The systemd watchdog stays the last resort: systemd aborts ajard WatchdogSec after the last ping,
// that is at least WatchdogSec / 2 (the ping interval) after the loop stalled; the supervisor acts
// at worst one check after control.stall_timeout_s (a check lands just before the timeout) — for
// the largest timeout the config accepts, before that.
TEST(LoopSupervisorWatchdog, TheSupervisorActsBeforeSystemdsWatchdogForEveryAcceptedTimeout) {
  std::ifstream unit(AJAR_SOURCE_DIR "/systemd/ajard.service");
  ASSERT_TRUE(unit);
  double watchdog_s = 0;
  for (std::string line; std::getline(unit, line);) {
    if (line.rfind("WatchdogSec=", 0) == 0) watchdog_s = std::stod(line.substr(12));
  }
  ASSERT_GT(watchdog_s, 0) << "no WatchdogSec in systemd/ajard.service";

  ajar::testing::TempDir dir;
  const auto config_with = [&](double timeout_s) {
    const std::string path = dir.path() + "/stall.yaml";
    std::ofstream(path) << "control:\n  stall_timeout_s: " << timeout_s << "\n";
    return load_config(path);
  };
  constexpr double kLargest = 0.5;  // config_fields.hpp
  EXPECT_THROW(config_with(kLargest + 0.01), ConfigError);
  const Config c = config_with(kLargest);
  ASSERT_EQ(c.control.stall_timeout_s, kLargest);

  drivers::MockMotionCard card;
  LoopSupervisorSettings settings;
  settings.rate_hz = 10;  // the slowest loop the config accepts: the longest floor
  settings.stall_timeout_s = c.control.stall_timeout_s;
  const LoopSupervisor supervisor(SupervisedLoop{[] { return true; }, [] { return 0; }, [] {}, {}},
                                  card, kWheels, settings);
  const double worst_s =
      static_cast<double>(supervisor.stall_timeout_ns() + supervisor.check_period_ns()) / 1e9;
  EXPECT_LT(worst_s, watchdog_s / 2);
}

}  // namespace
}  // namespace ajar::daemon
