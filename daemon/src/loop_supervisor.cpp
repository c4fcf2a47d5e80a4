// The loop supervisor (loop_supervisor.hpp): a check of the loop's last cycle end, its thread.
#include "ajar/daemon/loop_supervisor.hpp"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <future>
#include <stdexcept>

#include "ajar/daemon/realtime.hpp"
#include "control_loop_units.hpp"

namespace ajar::daemon {
namespace {

// SCHED_FIFO for the calling thread; empty when granted, else the warning.
std::string make_realtime(int priority) {
  const int lo = sched_get_priority_min(SCHED_FIFO);
  const int hi = sched_get_priority_max(SCHED_FIFO);
  sched_param param{};
  param.sched_priority = std::clamp(priority, lo, hi);
  const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  if (rc == 0) return {};
  return "control.realtime: the loop supervisor's SCHED_FIFO priority " +
         std::to_string(param.sched_priority) + " refused (" + std::strerror(rc) +
         "); it runs with normal scheduling";
}

}  // namespace

LoopSupervisor::LoopSupervisor(SupervisedLoop loop, drivers::MotionCard& card,
                               std::span<const int> axes, const LoopSupervisorSettings& settings)
    : loop_(std::move(loop)),
      card_(card),
      settings_(settings),
      stall_timeout_ns_(
          std::max(seconds_to_ns(settings.stall_timeout_s), seconds_to_ns(2.0 / settings.rate_hz))),
      check_period_ns_(std::max<std::int64_t>(stall_timeout_ns_ / kChecksPerTimeout, 1)) {
  if (!loop_.running || !loop_.last_cycle_end_ns || !loop_.latch_stalled) {
    throw std::invalid_argument("LoopSupervisor: the loop's hooks are required");
  }
  if (axes.size() > std::size(axes_)) throw std::invalid_argument("LoopSupervisor: > 8 axes");
  for (const int axis : axes)
    axes_[axis_count_++] = axis;
}

LoopSupervisor::~LoopSupervisor() {
  stop_thread();
}

bool LoopSupervisor::check(std::int64_t now_ns) noexcept {
  if (!loop_.running()) {  // not started, or stopping: nothing to watch
    seen_any_ = false;
    quiet_checks_ = 0;
    last_cpu_ = {};  // a thread started again is another thread
    last_check_ns_ = -1;
    unshown_ns_ = 0;
    return false;
  }
  const std::int64_t end = loop_.last_cycle_end_ns();
  const ThreadCpu cpu = loop_.thread_cpu ? loop_.thread_cpu() : ThreadCpu{};
  const LoopSleep sleep = loop_.sleep ? loop_.sleep() : LoopSleep{};
  // A realtime thread's waits are not excused (loop_supervisor.hpp).
  const bool excusable = !cpu.realtime;
  // Waits that ended since the last check (the kernel adds a wait when the thread gets a CPU, or
  // what it has waited so far when it moves it to another CPU).
  const std::int64_t ended_waits =
      excusable && cpu.waited_ns >= 0 && last_cpu_.waited_ns >= 0
          ? std::max<std::int64_t>(0, cpu.waited_ns - last_cpu_.waited_ns)
          : 0;
  // The wait going on, from check to check: waiting at this check and the last with no CPU time
  // in between.
  const bool still_waiting = excusable && cpu.waiting && last_cpu_.waiting && cpu.on_cpu_ns >= 0 &&
                             cpu.on_cpu_ns == last_cpu_.on_cpu_ns && last_check_ns_ >= 0;
  // The wait going on, exactly: the thread is in the loop's sleep and has had no CPU since it
  // went to sleep; past its planned wake-up it waits for one (thread_schedule.hpp, LoopSleep).
  const bool in_its_sleep = excusable && sleep.wake_ns > 0 && sleep.switch_ins > 0 &&
                            cpu.switch_ins == sleep.switch_ins && sleep.waited_ns >= 0 &&
                            cpu.waited_ns >= sleep.waited_ns;
  const std::int64_t shown_since_sleep = in_its_sleep ? cpu.waited_ns - sleep.waited_ns : 0;
  if (in_its_sleep) {  // every earlier wait is in run_delay (the thread read it after them)
    unshown_ns_ = std::max<std::int64_t>(
        0, std::max<std::int64_t>(0, now_ns - sleep.wake_ns) - shown_since_sleep);
  } else {  // the seen part of a wait stays excused until run_delay shows it (a check can read
            // run_delay just before the thread gets its CPU and its clock just after)
    unshown_ns_ = std::max<std::int64_t>(
        0, unshown_ns_ + (still_waiting ? now_ns - last_check_ns_ : 0) - ended_waits);
  }
  last_cpu_ = cpu;
  last_check_ns_ = now_ns;
  if (!seen_any_ || end != seen_end_ns_) {  // the loop made progress: (re-)armed
    seen_any_ = true;
    seen_end_ns_ = end;
    quiet_checks_ = 0;
    // The silence starts at the new end: of the waits so far only one going on in the sleep
    // after it belongs to it (the thread had a CPU for that cycle).
    excused_ns_ = shown_since_sleep;
    if (!in_its_sleep) unshown_ns_ = 0;
    stalled_.store(false, std::memory_order_release);
    return false;
  }
  excused_ns_ += ended_waits;  // the scheduler's, not the card's
  if (quiet_checks_ < kQuietChecks) ++quiet_checks_;
  if (stalled_.load(std::memory_order_relaxed)) return false;  // this stall was acted on
  const std::int64_t silent = now_ns - end;
  const std::int64_t excused = excused_ns_ + unshown_ns_;
  if (quiet_checks_ < kQuietChecks) return false;
  if (silent - excused < stall_timeout_ns_ && silent < kLatestLatchNs) return false;
  // Stalled. The loop first (a call returning now must find the latch), the engine next (its
  // latch must not wait for the card), then the card.
  stalled_.store(true, std::memory_order_release);
  loop_.latch_stalled();
  last_silent_ns_.store(silent, std::memory_order_relaxed);
  last_excused_ns_.store(excused, std::memory_order_relaxed);
  stalls_.fetch_add(1, std::memory_order_acq_rel);
  const ErrorCode stop = card_.emergency_stop_out_of_band({axes_, axis_count_});
  last_stop_result_.store(stop, std::memory_order_relaxed);
  stops_.fetch_add(1, std::memory_order_acq_rel);
  return true;
}

LoopSupervisor::Stall LoopSupervisor::last_stall() const noexcept {
  Stall s;
  s.count = stalls_.load(std::memory_order_acquire);
  s.stops = stops_.load(std::memory_order_acquire);
  s.silent_ns = last_silent_ns_.load(std::memory_order_relaxed);
  s.excused_ns = last_excused_ns_.load(std::memory_order_relaxed);
  s.stop_result = last_stop_result_.load(std::memory_order_relaxed);
  return s;
}

std::vector<std::string> LoopSupervisor::start_thread() {
  if (thread_.joinable()) return {};
  {
    const std::lock_guard lock(mutex_);
    exit_ = false;
  }
  std::promise<std::string> refused;
  auto warning = refused.get_future();
  thread_ = std::thread([this, realtime = settings_.realtime, priority = settings_.priority,
                         promise = std::move(refused)]() mutable {
    pthread_setname_np(pthread_self(), "ajar-supervisor");
    promise.set_value(realtime ? make_realtime(priority) : std::string());
    thread_main();
  });
  std::string w = warning.get();
  if (w.empty()) return {};
  return {std::move(w)};
}

void LoopSupervisor::stop_thread() noexcept {
  {
    const std::lock_guard lock(mutex_);
    exit_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void LoopSupervisor::thread_main() noexcept {
  using Clock = std::chrono::steady_clock;  // CLOCK_MONOTONIC, as the loop's cycle ends
  const auto period = std::chrono::nanoseconds(check_period_ns_);
  auto next = Clock::now();
  std::unique_lock lock(mutex_);
  while (!exit_) {
    next += period;
    if (wake_.wait_until(lock, next, [this] { return exit_; })) break;
    lock.unlock();
    (void)check(monotonic_now_ns());
    lock.lock();
    if (const auto now = Clock::now(); now > next + period) next = now;  // late: no burst
  }
}

}  // namespace ajar::daemon
