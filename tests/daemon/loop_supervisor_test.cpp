// The loop supervisor on a fake clock, by hand (check(now), no thread): a fake loop whose last
// cycle end and scheduling the test sets, and the mock card, whose out-of-band stop it must reach.
// What latches a stall, when it does not, once per stall, in which order, and re-arming. Then
// thread_cpu() on real threads (LoopSupervisorKernel) and the bound against systemd's watchdog.
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <iterator>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/loop_supervisor.hpp"
#include "ajar/daemon/realtime.hpp"
#include "ajar/daemon/seqlock.hpp"
#include "ajar/drivers/lifecycle.hpp"
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
                       [this] { return thread; }, [this] { return sleep; }},
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
  LoopSleep sleep;                         // what it published of its sleep; awake
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
  // The loop thread is runnable but gets no CPU for 0.6 s, as the kernel shows it: state R, its CPU
  // time standing still, and its schedstat wait standing still too (the kernel adds a wait to
  // run_delay only when it ends). The scheduler's doing: excused while it goes on (a supervisor
  // that read only run_delay latched here: the browser tests' LOOP_STALLED of 749 ms).
  const std::int64_t start = 1'000 * kMs;
  thread = ThreadCpu{0, 1'000 * kMs, false};  // asleep between cycles
  ASSERT_FALSE(cycle_and_check(start));
  thread.waiting = true;  // woken for the next cycle, and waiting for a CPU from now on
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t t = start;
  for (; t < start + 600 * kMs; t += step) {  // 6 timeouts, short of kLatestLatchNs
    ASSERT_FALSE(supervisor->check(t + step)) << t;
  }
  EXPECT_EQ(supervisor->stalls(), 0U);
  EXPECT_EQ(oob_stops(), 0U);
  // It gets a CPU: the kernel adds the whole wait at once; the cycle's card call then hangs
  // asleep (state S, no more CPU time). Only the silence after the wait counts (within
  // kLatestLatchNs: here the timeout comes first).
  thread = ThreadCpu{t - start, 1'001 * kMs, false};
  std::int64_t latched_at = -1;
  for (int i = 1; i <= 20 && latched_at < 0; ++i) {
    if (supervisor->check(t + i * step)) latched_at = t + i * step;
  }
  ASSERT_GE(latched_at, 0);
  EXPECT_GE(latched_at - t, supervisor->stall_timeout_ns());  // only the unexcused silence counts
  EXPECT_LE(latched_at - start, LoopSupervisor::kLatestLatchNs);
  const auto stall = supervisor->last_stall();
  EXPECT_EQ(stall.silent_ns, latched_at - start);
  EXPECT_EQ(stall.excused_ns, t - start);  // the wait once: not its seen part and its sum both
  EXPECT_EQ(oob_stops(), 1U);
}

TEST_F(LoopSupervisorTest, ALoopThatNeverGetsACpuIsStalledAtTheLatest) {
  // Runnable forever and never on a CPU (a higher SCHED_FIFO thread spinning with RT throttling
  // off; a CPU the kernel does not count, interrupts or a hypervisor's steal): excused up to
  // kLatestLatchNs of silence, then latched, for the smallest timeout and the largest.
  for (const double timeout_s : {0.1, 0.5}) {
    settings.stall_timeout_s = timeout_s;
    make();
    const std::int64_t start = 10'000 * kMs;
    thread = ThreadCpu{0, 1'000 * kMs, true};
    ASSERT_FALSE(cycle_and_check(start));
    const std::int64_t latched_at =
        quiet_checks(start + supervisor->check_period_ns(), 2'000 * kMs);
    ASSERT_GE(latched_at, 0) << timeout_s;
    EXPECT_GE(latched_at - start, LoopSupervisor::kLatestLatchNs) << timeout_s;
    EXPECT_LT(latched_at - start, LoopSupervisor::kLatestLatchNs + supervisor->check_period_ns())
        << timeout_s;
    EXPECT_GT(supervisor->last_stall().excused_ns, 0) << timeout_s;
  }
}

TEST_F(LoopSupervisorTest, ARealtimeLoopThreadKeptWaitingIsStalled) {
  // SCHED_FIFO (control.realtime granted): only another realtime thread keeps it off a CPU, and
  // the base is as unsupervised as with a hung call. Its waits, going on or ended, are not excused.
  const std::int64_t start = 1'000 * kMs;
  thread = ThreadCpu{0, 1'000 * kMs, true, true};
  ASSERT_FALSE(cycle_and_check(start));
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t latched_at = -1;
  for (int i = 1; i <= 40 && latched_at < 0; ++i) {
    if (i == 2) thread.waited_ns += 2 * step;  // a wait that ended, then another going on
    if (supervisor->check(start + i * step)) latched_at = start + i * step;
  }
  ASSERT_GE(latched_at, 0);
  EXPECT_EQ(latched_at - start, supervisor->stall_timeout_ns());
  EXPECT_EQ(supervisor->last_stall().excused_ns, 0);
}

TEST_F(LoopSupervisorTest, AWaitThatEndsBetweenTheReadsOfOneCheckStaysExcused) {
  // thread_cpu() reads run_delay, then the CPU clock around the state: the thread can get its CPU
  // in between. That check sees the wait over (the clock moved) but not yet in run_delay (the
  // kernel adds it when the thread gets the CPU, after that read); the next check sees it there.
  // The wait seen from check to check stays excused until run_delay shows it (before: the torn
  // check latched the whole wait as a hung call; tests/attack/FINDINGS.md, wave 12, A1).
  const std::int64_t start = 1'000 * kMs;
  thread = ThreadCpu{0, 1'000 * kMs, false};  // asleep between cycles
  ASSERT_FALSE(cycle_and_check(start));
  thread.waiting = true;  // woken, waiting for a CPU from now on
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t t = start + step;
  for (; t < start + 600 * kMs; t += step) {
    ASSERT_FALSE(supervisor->check(t)) << t;
  }
  // The torn check: the CPU clock read after the wait ended (on its CPU: not waiting), run_delay
  // before.
  thread = ThreadCpu{0, 1'000 * kMs + 5'000, false};
  EXPECT_FALSE(supervisor->check(t));
  // The next: run_delay shows the whole wait; the cycle's card call now hangs asleep.
  const std::int64_t waited = t - start - step / 2;
  thread = ThreadCpu{waited, 1'000 * kMs + 10'000, false};
  EXPECT_FALSE(supervisor->check(t + step));
  EXPECT_EQ(supervisor->stalls(), 0U);
  EXPECT_EQ(oob_stops(), 0U);
  // Counted once: the hang latches one timeout of unexcused silence after the wait.
  const std::int64_t latched_at = quiet_checks(t + 2 * step, 1'000 * kMs);
  ASSERT_GE(latched_at, 0);
  EXPECT_EQ(supervisor->last_stall().excused_ns, waited);
  EXPECT_GE(latched_at - start - waited, supervisor->stall_timeout_ns());
  EXPECT_LT(latched_at - start - waited, supervisor->stall_timeout_ns() + step);
}

TEST_F(LoopSupervisorTest, AWaitThatBeganLongBeforeTheSupervisorLookedIsExcusedInFull) {
  // The control thread went to sleep after its cycle, asking to wake 2 ms later, and from then on
  // waited for a CPU; the supervisor, starved as well, looks again only 300 ms later. Its sleep
  // record (planned wake-up, the switch-ins it slept with: unchanged, it has had no CPU since)
  // says it has waited since its wake-up: all of that is excused at the first look. Before, only
  // the wait from the first check that saw it on was: latched at the third check, "no cycle for
  // 350 ms" (tests/attack/FINDINGS.md, wave 12, A3: "1197 ms, 518 ms of it waiting").
  const std::int64_t start = 1'000 * kMs;
  const std::int64_t wake = start + 2 * kMs;
  thread = ThreadCpu{0, 1'000 * kMs, false, false, 7};  // asleep between cycles
  sleep = LoopSleep{wake, 7, 0};
  ASSERT_FALSE(cycle_and_check(start));
  thread.waiting = true;  // past its wake-up: runnable, no CPU (clock, run_delay, switch-ins still)
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t t = start + 300 * kMs;
  for (; t <= start + 400 * kMs; t += step) {
    ASSERT_FALSE(supervisor->check(t)) << "latched at " << (t - start) / kMs << " ms";
  }
  // It gets its CPU at 410 ms: the kernel adds the whole wait; it wakes (awake) and the cycle's
  // card call hangs asleep. The wait is excused once, not as its exact part and run_delay both.
  const std::int64_t waited = start + 410 * kMs - wake;
  thread = ThreadCpu{waited, 1'001 * kMs, false, false, 8};
  sleep = LoopSleep{};
  const std::int64_t latched_at = quiet_checks(t, 1'000 * kMs);
  ASSERT_GE(latched_at, 0);
  EXPECT_EQ(supervisor->last_stall().excused_ns, waited);
  EXPECT_GE(latched_at - start - waited, supervisor->stall_timeout_ns());
  EXPECT_LT(latched_at - start - waited, supervisor->stall_timeout_ns() + step);
  EXPECT_EQ(oob_stops(), 1U);
}

TEST_F(LoopSupervisorTest, AWaitRunDelayShowsInPartWhileItGoesOnIsCountedOnce) {
  // The kernel adds what a waiting thread has waited so far to run_delay when it moves it to
  // another CPU: the wait shows in part while it goes on. That part is not excused a second time,
  // by the sleep record (exact) nor by the checks that see the thread runnable without a CPU
  // (before: both, a wait of 388 ms excused as 548).
  for (const bool record : {true, false}) {
    make();
    const std::int64_t start = 1'000 * kMs;
    const std::int64_t wake = start + 2 * kMs;
    thread = ThreadCpu{0, 1'000 * kMs, false, false, 7};
    sleep = record ? LoopSleep{wake, 7, 0} : LoopSleep{};
    ASSERT_FALSE(cycle_and_check(start));
    thread.waiting = true;
    const std::int64_t step = supervisor->check_period_ns();
    std::int64_t t = start + step;
    for (; t < start + 400 * kMs; t += step) {
      if (t == start + 200 * kMs) thread.waited_ns = 198 * kMs;  // moved to another CPU
      ASSERT_FALSE(supervisor->check(t)) << record << " " << (t - start) / kMs;
    }
    // Its CPU at 390 ms: the rest of the wait shows; the cycle's card call hangs asleep.
    const std::int64_t waited = start + 390 * kMs - wake;
    thread = ThreadCpu{waited, 1'001 * kMs, false, false, 8};
    sleep = LoopSleep{};
    const std::int64_t latched_at = quiet_checks(t, 1'000 * kMs);
    ASSERT_GE(latched_at, 0) << record;
    EXPECT_EQ(supervisor->last_stall().excused_ns, waited) << record;
    EXPECT_GE(latched_at - start - waited, supervisor->stall_timeout_ns()) << record;
    EXPECT_LT(latched_at - start - waited, supervisor->stall_timeout_ns() + step) << record;
  }
}

TEST_F(LoopSupervisorTest, TheSleepRecordExcusesNoHungCall) {
  // The thread woke at its planned wake-up, got its CPU at once and its cycle's card call hangs:
  // asleep in the kernel or spinning. Whatever the record says, it is not a wait in the loop's
  // sleep: the thread said it woke; or (a record read before that, or a kernel that does not
  // count switch-ins) it had a CPU since, or nothing proves it had none. Latched at the timeout,
  // nothing excused.
  struct Case {
    const char* what;
    LoopSleep after;      // the record the supervisor reads during the hang
    std::int64_t ins;     // the thread's switch-ins then (7 when it went to sleep)
    std::int64_t waited;  // its run_delay then (0 when it went to sleep)
    bool spins;           // the call spins on a CPU (its clock moves, runnable)
  };
  const std::int64_t start = 1'000 * kMs;
  const std::int64_t wake = start + 2 * kMs;
  const Case cases[] = {
      {"awake, hung asleep", LoopSleep{}, 8, 0, false},
      {"awake, spinning without a switch", LoopSleep{}, 7, 0, true},
      {"stale record, hung asleep", LoopSleep{wake, 7, 0}, 8, 0, false},
      {"stale record, spinning", LoopSleep{wake, 7, 0}, 9, 0, true},
      {"switch-ins not counted", LoopSleep{wake, 0, 0}, 0, 0, false},
      {"switch-ins unknown", LoopSleep{wake, 7, 0}, -1, 0, false},
      {"run_delay unknown", LoopSleep{wake, 7, -1}, 7, -1, false},
  };
  for (const Case& c : cases) {
    make();
    thread = ThreadCpu{0, 1'000 * kMs, false, false, 7};
    sleep = LoopSleep{wake, 7, 0};
    ASSERT_FALSE(cycle_and_check(start));
    thread = ThreadCpu{c.waited, 1'000 * kMs + 10'000, c.spins, false, c.ins};
    sleep = c.after;
    const std::int64_t step = supervisor->check_period_ns();
    std::int64_t latched_at = -1;
    for (int i = 1; i <= 40 && latched_at < 0; ++i) {
      if (c.spins) thread.on_cpu_ns += step / 2;
      if (supervisor->check(start + i * step)) latched_at = start + i * step;
    }
    ASSERT_GE(latched_at, 0) << c.what;
    EXPECT_EQ(latched_at - start, supervisor->stall_timeout_ns()) << c.what;
    EXPECT_EQ(supervisor->last_stall().excused_ns, 0) << c.what;
  }
}

TEST_F(LoopSupervisorTest, ARealtimeLoopPastItsWakeUpIsNotExcused) {
  // SCHED_FIFO: the exact wait is not excused either (only another realtime thread keeps it off
  // its CPU). The A3 case: latched at the third quiet check, nothing excused.
  const std::int64_t start = 1'000 * kMs;
  thread = ThreadCpu{0, 1'000 * kMs, false, true, 7};
  sleep = LoopSleep{start + 2 * kMs, 7, 0};
  ASSERT_FALSE(cycle_and_check(start));
  thread.waiting = true;
  const std::int64_t step = supervisor->check_period_ns();
  std::int64_t latched_at = -1;
  for (std::int64_t t = start + 300 * kMs; t <= start + 700 * kMs && latched_at < 0; t += step) {
    if (supervisor->check(t)) latched_at = t;
  }
  ASSERT_GE(latched_at, 0);
  EXPECT_EQ(latched_at - start, 300 * kMs + (LoopSupervisor::kQuietChecks - 1) * step);
  EXPECT_EQ(supervisor->last_stall().excused_ns, 0);
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
    thread.waiting = i % 2 == 0;
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
// (needs two CPUs this process may use and SCHED_FIFO; skipped, saying so, without them).
class LoopSupervisorKernel : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_EQ(pthread_getaffinity_np(pthread_self(), sizeof saved_, &saved_), 0);
    for (std::size_t cpu = 0; cpu < CPU_SETSIZE && allowed_.size() < 2; ++cpu) {
      if (CPU_ISSET(cpu, &saved_)) allowed_.push_back(cpu);
    }
  }
  void TearDown() override { pthread_setaffinity_np(pthread_self(), sizeof saved_, &saved_); }
  static bool pin(std::size_t cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0;
  }
  // A SCHED_FIFO (priority 1) thread pinned to `cpu`, spinning until release(), at most 0.9 s
  // (RT throttling would let the others run at 0.95 s). The constructor returns once it spins
  // or was refused.
  class FifoSpinner {
   public:
    explicit FifoSpinner(std::size_t cpu) : thread_([this, cpu] { run(cpu); }) {
      while (state_ == 0)
        ::usleep(100);
    }
    ~FifoSpinner() { release(); }
    FifoSpinner(const FifoSpinner&) = delete;
    FifoSpinner& operator=(const FifoSpinner&) = delete;
    bool refused() const { return state_ < 0; }  // SCHED_FIFO or pinning refused
    bool gave_up() const { return gave_up_; }    // it stopped at 0.9 s, before release()
    int tid() const { return tid_; }
    void release() {
      release_ = true;
      if (thread_.joinable()) thread_.join();
    }

   private:
    void run(std::size_t cpu) {
      sched_param param{};
      param.sched_priority = 1;
      if (!pin(cpu) || pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) != 0) {
        state_ = -1;
        return;
      }
      tid_ = static_cast<int>(::gettid());
      state_ = 1;
      const auto give_up = std::chrono::steady_clock::now() + std::chrono::milliseconds(900);
      while (!release_) {
        if (std::chrono::steady_clock::now() > give_up) {
          gave_up_ = true;
          break;
        }
      }
    }
    std::atomic<int> state_{0};  // 1: spinning, -1: refused
    std::atomic<int> tid_{0};
    std::atomic<bool> release_{false};
    std::atomic<bool> gave_up_{false};
    std::thread thread_;  // last: started once the flags exist
  };
  cpu_set_t saved_{};                 // this (the test's) thread's CPUs, restored after
  std::vector<std::size_t> allowed_;  // the first two of them
};

TEST_F(LoopSupervisorKernel, UnknownThreadsAreUnknown) {
  for (const int tid : {0, -5}) {
    const ThreadCpu cpu = thread_cpu(tid);
    EXPECT_EQ(cpu.waited_ns, -1);
    EXPECT_EQ(cpu.on_cpu_ns, -1);
    EXPECT_FALSE(cpu.waiting);
  }
}

TEST_F(LoopSupervisorKernel, NeitherAThreadAsleepNorOneThatSpinsIsWaiting) {
  std::mutex mutex;
  std::condition_variable wake;
  bool spin = false;
  std::atomic<int> tid{0};
  std::atomic<bool> done{false};
  std::thread worker([&] {
    tid = static_cast<int>(::gettid());
    {
      std::unique_lock lock(mutex);
      wake.wait(lock, [&] { return spin; });  // asleep until told
    }
    while (!done) {  // busy
    }
  });
  while (tid == 0)
    ::usleep(100);
  // Asleep on the condition variable (state S once it got there: give it the time to).
  ASSERT_TRUE(eventually([&] {
    std::ifstream stat("/proc/self/task/" + std::to_string(tid.load()) + "/stat");
    std::string text((std::istreambuf_iterator<char>(stat)), {});
    return text.find(") S ") != std::string::npos;
  }));
  const ThreadCpu asleep = thread_cpu(tid);
  EXPECT_FALSE(asleep.waiting);
  EXPECT_GE(asleep.on_cpu_ns, 0);
  {
    const std::lock_guard lock(mutex);
    spin = true;
  }
  wake.notify_one();
  EXPECT_TRUE(eventually([&] { return thread_cpu(tid).on_cpu_ns > asleep.on_cpu_ns + 1'000'000; }))
      << "a spinning thread's CPU time grows";
  // On a CPU at the read (its clock moves around it), or waiting its turn on a loaded machine: a
  // thread that spins is seen on a CPU.
  EXPECT_TRUE(eventually([&] { return !thread_cpu(tid).waiting; }));
  done = true;
  worker.join();
}

TEST_F(LoopSupervisorKernel, AThreadKeptOffItsCpuIsWaitingAndItsWaitShowsOnlyWhenItEnds) {
  if (allowed_.size() < 2) GTEST_SKIP() << "needs two CPUs this process may use";
  const std::size_t contended = allowed_[1];
  if (!pin(allowed_[0])) GTEST_SKIP() << "cannot pin this thread";
  std::atomic<int> tid{0};
  std::atomic<bool> done{false};
  std::thread waiter([&] {  // wakes every 100 us: runnable at once when the CPU is taken
    if (pin(contended))
      tid = static_cast<int>(::gettid());
    else
      tid = -1;
    while (!done)
      ::usleep(100);
  });
  while (tid == 0)
    ::usleep(100);
  FifoSpinner spinner(contended);
  const auto end = [&] {
    spinner.release();
    done = true;
    waiter.join();
  };
  if (spinner.refused() || tid < 0) {
    end();
    GTEST_SKIP() << "SCHED_FIFO or pinning refused here: cannot keep a thread off its CPU";
  }
  // The waiter wants its CPU and cannot have it: waiting, no CPU time, no wait added yet.
  ThreadCpu a;
  const bool seen_waiting =
      eventually([&] { return (a = thread_cpu(tid)).waiting; }, std::chrono::milliseconds(500));
  ::usleep(20'000);
  const ThreadCpu b = thread_cpu(tid);
  const ThreadCpu hog_cpu = thread_cpu(spinner.tid());
  const bool held = !spinner.gave_up();  // the spinner still held the CPU after the second read
  spinner.release();
  if (!held) {
    end();
    GTEST_SKIP() << "this thread was not scheduled within 0.9 s: a loaded machine";
  }
  EXPECT_TRUE(seen_waiting);
  EXPECT_TRUE(b.waiting);
  EXPECT_FALSE(b.realtime);
  EXPECT_TRUE(hog_cpu.realtime) << "the SCHED_FIFO spinner";
  EXPECT_FALSE(hog_cpu.waiting) << "the spinner is on its CPU";
  EXPECT_EQ(b.on_cpu_ns, a.on_cpu_ns) << "CPU time while kept off its CPU";
  if (a.waited_ns >= 0) {
    EXPECT_EQ(b.waited_ns, a.waited_ns) << "the kernel added a wait that has not ended";
    // Once it runs, the whole wait is added, the 20 ms between the reads included.
    EXPECT_TRUE(eventually([&] { return thread_cpu(tid).waited_ns - a.waited_ns >= 20'000'000; }));
  }
  end();
}

TEST_F(LoopSupervisorKernel, ASleeperKeptOffItsCpuPastItsWakeUpHasHadNoSwitchInSinceItSlept) {
  // What the exact wait rests on, as the kernel shows it: a thread that published its record
  // (OwnSchedstat, as the control thread does) and sleeps until its wake-up, kept off its CPU
  // past it by a SCHED_FIFO thread, has the switch-ins and run_delay of its record and is
  // runnable with its clock still; once it runs, its switch-ins move and the wait shows.
  if (allowed_.size() < 2) GTEST_SKIP() << "needs two CPUs this process may use";
  const std::size_t contended = allowed_[1];
  if (!pin(allowed_[0])) GTEST_SKIP() << "cannot pin this thread";
  SeqLock<LoopSleep> published;  // as ControlLoop::sleep_record() reads it
  std::atomic<int> tid{0};
  std::atomic<std::int64_t> wake{0};
  std::atomic<bool> finish{false};
  std::thread sleeper([&] {
    if (!pin(contended)) {
      tid = -1;
      return;
    }
    const OwnSchedstat own;
    tid = static_cast<int>(::gettid());
    while (wake == 0)
      ::usleep(100);
    published.store(own.going_to_sleep(wake));
    sleep_until_ns(wake);
    published.store(LoopSleep{});
    while (!finish)  // still there for the reads after it woke
      ::usleep(100);
  });
  while (tid == 0)
    ::usleep(100);
  if (tid < 0) {
    sleeper.join();
    GTEST_SKIP() << "cannot pin a thread";
  }
  const std::int64_t w = monotonic_now_ns() + 200 * kMs;
  wake = w;
  // Asleep in its sleep (state S) with its record out, before the spinner takes its CPU.
  if (!eventually([&] {
        std::ifstream stat("/proc/self/task/" + std::to_string(tid.load()) + "/stat");
        std::string text((std::istreambuf_iterator<char>(stat)), {});
        return published.load().wake_ns == w && text.find(") S ") != std::string::npos;
      })) {
    finish = true;
    sleeper.join();
    FAIL() << "the thread did not go to sleep with its record out";
  }
  const LoopSleep record = published.load();
  FifoSpinner spinner(contended);
  const auto end = [&] {
    spinner.release();
    finish = true;
    sleeper.join();
  };
  if (spinner.refused()) {
    end();
    GTEST_SKIP() << "SCHED_FIFO or pinning refused here: cannot keep a thread off its CPU";
  }
  while (monotonic_now_ns() < w + 100 * kMs)  // past its wake-up: runnable, kept off its CPU
    ::usleep(1'000);
  const ThreadCpu past = thread_cpu(tid);
  const LoopSleep still = published.load();
  const bool held = !spinner.gave_up();
  spinner.release();
  if (!held) {
    end();
    GTEST_SKIP() << "this thread was not scheduled within 0.9 s: a loaded machine";
  }
  if (record.switch_ins < 0) {
    end();
    GTEST_SKIP() << "no schedstat switch-ins here (/proc/thread-self/schedstat)";
  }
  EXPECT_GT(record.switch_ins, 0);
  EXPECT_GE(record.waited_ns, 0);
  EXPECT_EQ(still.wake_ns, w) << "it has not woken";
  EXPECT_EQ(past.switch_ins, record.switch_ins) << "no CPU since it went to sleep";
  EXPECT_EQ(past.waited_ns, record.waited_ns) << "its wait has not ended";
  EXPECT_TRUE(past.waiting) << "runnable, its clock still";
  // It runs: its switch-ins move, the wait shows (at least the 100 ms past its wake-up), awake.
  EXPECT_TRUE(eventually([&] {
    const ThreadCpu now = thread_cpu(tid);
    return now.switch_ins > record.switch_ins && now.waited_ns - record.waited_ns >= 100 * kMs;
  }));
  EXPECT_TRUE(eventually([&] { return published.load().wake_ns == 0; })) << "awake";
  end();
}

// The control thread of a real ControlLoop (mock card, steady clock) publishes its sleep between
// cycles, with its own schedstat; hung in a card call it is not in its sleep (it said it woke):
// the exact wait never covers a hang.
TEST(LoopSupervisorLoop, TheControlThreadPublishesItsSleepAndIsAwakeInAHungCall) {
  auto mock = std::make_unique<drivers::MockMotionCard>();
  drivers::MockMotionCard& card = *mock;
  ControlLoopSettings settings;
  settings.control.rate_hz = 500;
  const int axes[2] = {settings.base.left.card_axis, settings.base.right.card_axis};
  drivers::ManagedMotionCard managed(std::move(mock), axes);
  ASSERT_TRUE(managed.configure().ok());
  ASSERT_TRUE(managed.activate().ok());
  ControlLoop loop(managed, settings);
  EXPECT_EQ(loop.sleep_record().wake_ns, 0) << "no thread: awake";
  (void)loop.start_thread();
  LoopSleep asleep;
  ASSERT_TRUE(eventually([&] { return (asleep = loop.sleep_record()).wake_ns > 0; }));
  const ThreadCpu after = thread_cpu(loop.thread_tid());
  if (after.switch_ins >= 0) {  // the kernel counts them: the thread read its own
    EXPECT_GT(asleep.switch_ins, 0);
    EXPECT_LE(asleep.switch_ins, after.switch_ins);
    EXPECT_GE(asleep.waited_ns, 0);
    EXPECT_LE(asleep.waited_ns, after.waited_ns);
  }
  card.set_block_status(true);  // the next status read hangs
  ASSERT_TRUE(eventually([&] { return card.blocked_calls() > 0; }));
  EXPECT_EQ(loop.sleep_record().wake_ns, 0) << "a thread hung in a card call is not in its sleep";
  card.set_block_status(false);
  EXPECT_TRUE(eventually([&] { return loop.sleep_record().wake_ns > 0; }));
  loop.stop_thread();
}

// A realtime control thread publishes nothing of its sleep (none of its waits is excused, so its
// cycle makes no system call for it): its record stays "awake" while it cycles.
TEST(LoopSupervisorLoop, ARealtimeControlThreadPublishesNoSleep) {
  auto mock = std::make_unique<drivers::MockMotionCard>();
  ControlLoopSettings settings;
  settings.control.rate_hz = 500;
  settings.control.realtime = true;
  settings.control.priority = 10;
  const int axes[2] = {settings.base.left.card_axis, settings.base.right.card_axis};
  drivers::ManagedMotionCard managed(std::move(mock), axes);
  ASSERT_TRUE(managed.configure().ok());
  ASSERT_TRUE(managed.activate().ok());
  ControlLoop loop(managed, settings);
  const auto refused = loop.start_thread();
  if (!refused.empty()) {
    loop.stop_thread();
    GTEST_SKIP() << "SCHED_FIFO refused here: " << refused.front();
  }
  const std::uint64_t first = loop.statistics().cycles();
  ASSERT_TRUE(eventually([&] { return loop.statistics().cycles() >= first + 50; }));
  // Sampled while it cycles (asleep most of each 2 ms period): never a planned wake-up.
  for (int i = 0; i < 2000; ++i) {
    ASSERT_EQ(loop.sleep_record().wake_ns, 0) << "sample " << i;
  }
  loop.stop_thread();
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
  const LoopSupervisor supervisor(
      SupervisedLoop{[] { return true; }, [] { return 0; }, [] {}, {}, {}}, card, kWheels,
      settings);
  // The latest latch: the timeout, or kLatestLatchNs of silence for a loop excused as starved;
  // a check period after it at worst. systemd pings every WatchdogSec / 2 while the loop is
  // healthy, so it can abort ajard WatchdogSec / 2 after the loop went silent.
  const double worst_s =
      static_cast<double>(std::max(supervisor.stall_timeout_ns(), LoopSupervisor::kLatestLatchNs) +
                          supervisor.check_period_ns()) /
      1e9;
  EXPECT_LT(worst_s, watchdog_s / 2);
}

}  // namespace
}  // namespace ajar::daemon
