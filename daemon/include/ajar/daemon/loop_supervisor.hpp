// LoopSupervisor: watches the control loop from outside it, on its own thread, and acts when the
// loop stops cycling (docs/control-loop.md, "Stalled loop"). The loop's cycle makes vendor calls;
// one that does not return stalls the loop, and with it every stop, deadline and deadman the loop
// enforces, while the card keeps running its last move or jog.
//
// Every check period the supervisor reads when the loop's last cycle ended. The loop is stalled
// when it made no cycle for stall_timeout (control.stall_timeout_s, at least 2 loop periods), not
// counting the time the control thread spent waiting for a CPU, AND the supervisor itself saw no
// cycle end in its last kQuietChecks checks. A thread that is runnable but not scheduled (a loaded
// machine, the thread's CPU time given to others) is the scheduler's doing, not a hung call, and
// its wait is excused — unless the thread is realtime (SCHED_FIFO/RR): then only another realtime
// thread can keep it waiting, a fault of the robot's set-up that leaves the base unsupervised all
// the same. A hung call either sleeps in the kernel or spins on a CPU, and both count.
// The wait is read from the kernel (thread_cpu()) and from the control thread (LoopSleep), three
// ways, each wait counted once:
//   - the waits that have ended: the schedstat run_delay, which the kernel adds to only when the
//     thread gets a CPU (or moves the waiting thread to another CPU: the part so far);
//   - the wait going on, exactly: the control thread publishes, just before its sleep between
//     cycles, the wake-up it asks for and its schedstat switch-ins and run_delay, and "awake" as
//     soon as it wakes (thread_schedule.hpp). Found in that sleep past its wake-up, with the
//     switch-ins it went to sleep with (it has had no CPU since), it has waited for one since
//     its wake-up, however late the supervisor looks (a supervisor starved itself saw only the
//     end of such a wait: tests/attack/FINDINGS.md, wave 12, A3); of that wait, run_delay minus
//     the one it slept with shows already. The supervisor then knows every earlier wait is in
//     run_delay (the thread read it after them). A thread hung in a card call is not in that
//     sleep: it woke, or it had a CPU since;
//   - the wait going on elsewhere (the thread kept off its CPU mid-cycle, or no sleep record):
//     runnable at two checks in a row with no CPU time between them (a thread cannot fall
//     asleep without a CPU, so it waited all of that interval, give or take the instants of the
//     two reads).
// A wait seen going on stays excused once it ends until run_delay shows it (one check can read
// run_delay just before the thread gets its CPU and its clock just after), and what run_delay
// shows of it is not excused again: the seen part is what run_delay does not show yet. Without
// those statistics the wall clock decides. Whatever was excused, a loop silent for kLatestLatchNs
// is stalled: a thread that never gets a CPU (a higher SCHED_FIFO thread spinning, RT throttling
// off) or whose CPU time the kernel does not count (interrupts, a hypervisor's steal) stops the
// base's supervision as surely as a hung call, and systemd's watchdog must not come first. The
// quiet checks keep a process that was not scheduled at all (supervisor included) from being
// taken for a stalled loop: it acts only on silence it watched.
// Then, once per stall, in this order:
//   1. loop.latch_stalled(): the loop latches kLoopStalled the moment the hung call returns
//      (nothing it posted before moves; what that call reports is latched as kLoopStalled);
//   2. the stall is published (stalls()): the engine latches LOOP_STALLED on the I/O thread,
//      tells every session (fault_latched) and persists it, whatever the card does next;
//   3. card.emergency_stop_out_of_band(wheels): the base is stopped by a path that does not need
//      the control thread (motion_card.hpp; what the real card offers: docs/drivers.md); its
//      answer is published after it (stops(), last_stall().stop_result): the engine journals it.
//      Should the vendor library make that call wait behind the hung one, the latch of 1 and 2
//      is already out.
// When the loop completes a cycle again the supervisor re-arms (a later stall is a new one); the
// fault stays latched until an operator's Reset, which the engine refuses while stalled() holds.
// The systemd watchdog stays the last resort: ajard stops petting it while the loop is unhealthy
// (ControlLoop::healthy()), and systemd aborts it WatchdogSec later, after the supervisor acted.
//
// Threading: check() runs on the supervisor's thread (or on a test's, by hand: no thread then);
// stalls(), last_stall(), stalled() on any thread. The supervisor never blocks the loop and never
// calls the card but for its out-of-band stop.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "ajar/core/error.hpp"
#include "ajar/daemon/config.hpp"
#include "ajar/daemon/thread_schedule.hpp"
#include "ajar/drivers/motion_card.hpp"

namespace ajar::daemon {

// What the supervisor reads from and tells the loop (the engine wires it to its ControlLoop; the
// unit tests to a fake). Called on the supervisor's thread: must not block.
struct SupervisedLoop {
  std::function<bool()> running;                    // the control thread runs
  std::function<std::int64_t()> last_cycle_end_ns;  // CLOCK_MONOTONIC ns of its last cycle's end
  std::function<void()> latch_stalled;              // ControlLoop::latch_stalled()
  // Optional: the control thread's scheduling as the kernel sees it (thread_cpu()). Empty or
  // unknown fields: the wall clock alone decides.
  std::function<ThreadCpu()> thread_cpu;
  // Optional: what the control thread published of its sleep (ControlLoop::sleep_record()).
  // Empty or unknown: the exact wait is not known, the other rules still apply.
  std::function<LoopSleep()> sleep;
};

// The supervisor reads the control section: rate_hz, stall_timeout_s, realtime (SCHED_FIFO at
// `priority` for the supervisor too; the loop's priority, within the unit's LimitRTPRIO).
using LoopSupervisorSettings = ControlConfig;

class LoopSupervisor {
 public:
  // Checks per stall timeout, and how many of them in a row must see no cycle end.
  static constexpr int kChecksPerTimeout = 4;
  static constexpr int kQuietChecks = 3;
  // The longest silence latched late for the scheduler's sake: 0.75 s, so that with a check
  // period of at most 0.125 s (the config's largest timeout, 0.5 s) the supervisor acts before
  // systemd can abort ajard (WatchdogSec=2, pinged every second while the loop is healthy).
  static constexpr std::int64_t kLatestLatchNs = 750'000'000;

  // `card` and the loop behind `loop` must outlive the supervisor; `axes` are the wheels (<= 8).
  LoopSupervisor(SupervisedLoop loop, drivers::MotionCard& card, std::span<const int> axes,
                 const LoopSupervisorSettings& settings);
  ~LoopSupervisor();  // stop_thread()
  LoopSupervisor(const LoopSupervisor&) = delete;
  LoopSupervisor& operator=(const LoopSupervisor&) = delete;

  // Starts the thread (checks every check_period_ns()); returns a warning when SCHED_FIFO was
  // asked for and refused. Stops (joins) it. Both idempotent; I/O thread.
  std::vector<std::string> start_thread();
  void stop_thread() noexcept;

  // One check at `now_ns` (CLOCK_MONOTONIC ns). True when this check latched a stall.
  bool check(std::int64_t now_ns) noexcept;

  struct Stall {
    std::uint32_t count = 0;                 // stalls latched so far (this one included)
    std::int64_t silent_ns = 0;              // how long the loop had made no cycle when it latched
    std::int64_t excused_ns = 0;             // of which the control thread waited for a CPU
    std::uint32_t stops = 0;                 // out-of-band stops that have returned so far
    ErrorCode stop_result = ErrorCode::kOk;  // what the last of them answered
  };
  // Any thread. stalls() is the number latched so far, stops() the number of out-of-band stops
  // that have returned (one per stall, published after it); last_stall() the latest of each.
  std::uint32_t stalls() const noexcept { return stalls_.load(std::memory_order_acquire); }
  std::uint32_t stops() const noexcept { return stops_.load(std::memory_order_acquire); }
  Stall last_stall() const noexcept;
  // Any thread: a stall was latched and the loop has completed no cycle since (as seen by the
  // last check).
  bool stalled() const noexcept { return stalled_.load(std::memory_order_acquire); }

  std::int64_t stall_timeout_ns() const noexcept { return stall_timeout_ns_; }
  std::int64_t check_period_ns() const noexcept { return check_period_ns_; }

 private:
  void thread_main() noexcept;

  SupervisedLoop loop_;
  drivers::MotionCard& card_;
  int axes_[8] = {};
  std::size_t axis_count_ = 0;
  LoopSupervisorSettings settings_;
  std::int64_t stall_timeout_ns_;
  std::int64_t check_period_ns_;

  // The checking thread's own state.
  std::int64_t seen_end_ns_ = 0;
  bool seen_any_ = false;
  int quiet_checks_ = 0;
  ThreadCpu last_cpu_;  // the control thread at the last check
  std::int64_t last_check_ns_ = -1;
  std::int64_t excused_ns_ = 0;  // waits run_delay showed since the check that saw the last end
  std::int64_t unshown_ns_ = 0;  // waits seen (ended or going on) that run_delay does not show yet

  // Published.
  std::atomic<bool> stalled_{false};
  std::atomic<std::uint32_t> stalls_{0};
  std::atomic<std::uint32_t> stops_{0};
  std::atomic<std::int64_t> last_silent_ns_{0};
  std::atomic<std::int64_t> last_excused_ns_{0};
  std::atomic<ErrorCode> last_stop_result_{ErrorCode::kOk};

  std::mutex mutex_;  // the thread's sleep and exit only
  std::condition_variable wake_;
  bool exit_ = false;
  std::thread thread_;
};

}  // namespace ajar::daemon
