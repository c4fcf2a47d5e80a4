// The loop supervisor on a fake clock, by hand (check(now), no thread): a fake loop whose last
// cycle end the test sets, and the mock card, whose out-of-band stop it must reach. What latches a
// stall, when it does not, once per stall, in which order, and re-arming.
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/loop_supervisor.hpp"
#include "ajar/drivers/mock_card.hpp"
#include "eventually.hpp"
#include "fake_clock.hpp"
#include "fake_door.hpp"

namespace ajar::daemon {
namespace {

using ajar::test::eventually;
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
                       [this] { return thread; }},
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
  ThreadCpu thread;                        // the loop thread as the kernel shows it; unknown
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
  // The loop thread is runnable but gets no CPU for 2 s, as the kernel shows it: state R, its CPU
  // time standing still, and its schedstat wait standing still too (the kernel adds a wait to
  // run_delay only when it ends). The scheduler's doing: excused while it goes on (a supervisor
  // that read only run_delay latched here: the browser tests' LOOP_STALLED of 749 ms).
  const std::int64_t start = 1'000 * kMs;
  thread = ThreadCpu{0, 1'000 * kMs, false};  // asleep between cycles
  ASSERT_FALSE(cycle_and_check(start));
  thread.runnable = true;  // woken for the next cycle, and waiting for a CPU from now on
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t t = start;
  for (; t < start + 2'000 * kMs; t += step) {
    ASSERT_FALSE(supervisor->check(t + step)) << t;
  }
  EXPECT_EQ(supervisor->stalls(), 0U);
  EXPECT_EQ(oob_stops(), 0U);
  // It gets a CPU: the kernel adds the whole wait at once; the cycle's card call then hangs
  // asleep (state S, no more CPU time). Only the silence after the wait counts.
  thread = ThreadCpu{t - start, 1'001 * kMs, false};
  std::int64_t latched_at = -1;
  for (int i = 1; i <= 20 && latched_at < 0; ++i) {
    if (supervisor->check(t + i * step)) latched_at = t + i * step;
  }
  ASSERT_GE(latched_at, 0);
  EXPECT_GE(latched_at - t, supervisor->stall_timeout_ns());  // only the unexcused silence counts
  const auto stall = supervisor->last_stall();
  EXPECT_EQ(stall.silent_ns, latched_at - start);
  EXPECT_EQ(stall.excused_ns, t - start);  // the wait once: not its seen part and its sum both
  EXPECT_EQ(oob_stops(), 1U);
}

TEST_F(LoopSupervisorTest, OnlyARunnableThreadWithoutCpuTimeBetweenTwoChecksIsWaiting) {
  // Runnable at one check and asleep at the next (or the other way round), with no CPU time in
  // between: no interval where it was surely waiting for a CPU; nothing excused.
  const std::int64_t start = 1'000 * kMs;
  thread = ThreadCpu{0, 1'000 * kMs, false};
  ASSERT_FALSE(cycle_and_check(start));
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t latched_at = -1;
  for (int i = 1; i <= 40 && latched_at < 0; ++i) {
    thread.runnable = i % 2 == 0;
    if (supervisor->check(start + i * step)) latched_at = start + i * step;
  }
  ASSERT_GE(latched_at, 0);
  EXPECT_EQ(latched_at - start, supervisor->stall_timeout_ns());
  EXPECT_EQ(supervisor->last_stall().excused_ns, 0);
}

TEST_F(LoopSupervisorTest, AHungCallThatSpinsOnACpuCounts) {
  // A call that spins (busy-waits on the card) is runnable and runs: its CPU time grows between
  // checks. No wait for a CPU; the silence counts as for a call that sleeps.
  thread = ThreadCpu{5'000 * kMs, 1'000 * kMs, true};  // whatever it waited before
  const std::int64_t start = 1'000 * kMs;
  ASSERT_FALSE(cycle_and_check(start));
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t latched_at = -1;
  for (int i = 1; i <= 40 && latched_at < 0; ++i) {
    thread.on_cpu_ns += step / 2;  // on a CPU half the time (a loaded machine), never waiting long
    if (supervisor->check(start + i * step)) latched_at = start + i * step;
  }
  ASSERT_GE(latched_at, 0);
  EXPECT_EQ(latched_at - start, supervisor->stall_timeout_ns());
  EXPECT_EQ(supervisor->last_stall().excused_ns, 0);
}

TEST_F(LoopSupervisorTest, AWaitItCannotReadIsNotExcused) {
  // Runnable with its CPU time unknown (no CPU clock): the wall clock decides.
  thread = ThreadCpu{-1, -1, true};
  ASSERT_FALSE(cycle_and_check(1'000 * kMs));
  EXPECT_EQ(quiet_checks(1'000 * kMs + supervisor->check_period_ns(), 1'000 * kMs),
            1'000 * kMs + supervisor->stall_timeout_ns());
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

// thread_cpu() on real threads of this process, as the kernel shows them: a thread asleep, one
// that spins, and one that is runnable but kept off its CPU by a SCHED_FIFO thread pinned there
// (needs SCHED_FIFO and two CPUs; skipped, saying so, without them).
class LoopSupervisorKernel : public ::testing::Test {
 protected:
  static bool pin(std::size_t cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0;
  }
};

TEST_F(LoopSupervisorKernel, UnknownThreadsAreUnknown) {
  for (const int tid : {0, -5}) {
    const ThreadCpu cpu = thread_cpu(tid);
    EXPECT_EQ(cpu.waited_ns, -1);
    EXPECT_EQ(cpu.on_cpu_ns, -1);
    EXPECT_FALSE(cpu.runnable);
  }
}

TEST_F(LoopSupervisorKernel, AThreadAsleepIsNotRunnableOneThatSpinsGetsCpuTime) {
  std::atomic<int> tid{0};
  std::atomic<bool> spin{false};
  std::atomic<bool> done{false};
  std::thread worker([&] {
    tid = static_cast<int>(::gettid());
    while (!done) {
      if (spin) continue;  // busy
      ::usleep(200);
    }
  });
  while (tid == 0)
    ::usleep(100);
  // Asleep most of the time: some read sees it asleep.
  EXPECT_TRUE(eventually([&] { return !thread_cpu(tid).runnable; })) << "never seen asleep";
  spin = true;
  const ThreadCpu first = thread_cpu(tid);
  EXPECT_TRUE(eventually([&] {
    const ThreadCpu now = thread_cpu(tid);
    return now.runnable && now.on_cpu_ns > first.on_cpu_ns;
  })) << "a spinning thread is runnable and its CPU time grows";
  done = true;
  worker.join();
}

TEST_F(LoopSupervisorKernel, AThreadKeptOffItsCpuIsRunnableAndItsWaitShowsOnlyWhenItEnds) {
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "needs two CPUs";
  const std::size_t cpu = sched_getcpu() == 0 ? 1 : 0;  // the contended CPU: not this thread's
  std::atomic<int> tid{0};
  std::atomic<bool> done{false};
  std::atomic<int> hog{0};  // 1: spinning at SCHED_FIFO, -1: refused
  std::atomic<bool> release{false};
  std::thread waiter([&] {  // wakes every 100 us: runnable at once when the CPU is taken
    (void)pin(cpu);
    tid = static_cast<int>(::gettid());
    while (!done)
      ::usleep(100);
  });
  std::thread spinner([&] {
    (void)pin(cpu);
    sched_param param{};
    param.sched_priority = 1;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) != 0) {
      hog = -1;
      return;
    }
    hog = 1;
    // Spin until released, at most 1 s (the kernel's RT throttling allows 0.95 s a second).
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    while (!release && std::chrono::steady_clock::now() < give_up) {
    }
  });
  while (hog == 0 || tid == 0)
    ::usleep(100);
  if (hog < 0) {
    done = true;
    spinner.join();
    waiter.join();
    GTEST_SKIP() << "SCHED_FIFO refused here: cannot keep a thread off its CPU";
  }
  // The waiter wants its CPU and cannot have it: runnable, no CPU time, no wait added yet.
  ThreadCpu a;
  EXPECT_TRUE(eventually([&] { return (a = thread_cpu(tid)).runnable; }));
  ::usleep(20'000);
  const ThreadCpu b = thread_cpu(tid);
  release = true;
  spinner.join();
  EXPECT_TRUE(b.runnable);
  EXPECT_EQ(b.on_cpu_ns, a.on_cpu_ns) << "CPU time while kept off its CPU";
  if (a.waited_ns >= 0) {
    EXPECT_EQ(b.waited_ns, a.waited_ns) << "the kernel added a wait that has not ended";
    // Once it runs, the whole wait is added, the 20 ms between the reads included.
    EXPECT_TRUE(eventually([&] { return thread_cpu(tid).waited_ns - a.waited_ns >= 20'000'000; }));
  }
  done = true;
  waiter.join();
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
