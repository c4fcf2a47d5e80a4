// The loop supervisor (loop_supervisor.hpp): a check of the loop's last cycle end, its thread.
#include "ajar/daemon/loop_supervisor.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
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

// The text of /proc/self/task/TID/NAME into `text` (NUL-terminated); false when unreadable.
bool read_task_file(int tid, const char* name, char* text, std::size_t size) noexcept {
  char path[64];
  std::snprintf(path, sizeof path, "/proc/self/task/%d/%s", tid, name);
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const ssize_t n = ::read(fd, text, size - 1);
  ::close(fd);
  if (n <= 0) return false;
  text[n] = '\0';
  return true;
}

}  // namespace

ThreadCpu thread_cpu(int tid) noexcept {
  ThreadCpu cpu;
  if (tid <= 0) return cpu;
  char text[512];
  if (read_task_file(tid, "schedstat", text, sizeof text)) {
    // "<ns on a CPU> <ns waiting on a runqueue> <timeslices>"
    char* end = nullptr;
    (void)std::strtoll(text, &end, 10);
    const char* second = end;
    const long long waited = std::strtoll(second, &end, 10);
    if (end != second && waited >= 0) cpu.waited_ns = waited;
  }
  // The thread's CPU clock, as glibc's pthread_getcpuclockid makes it from the kernel's thread id
  // (MAKE_THREAD_CPUCLOCK(tid, CPUCLOCK_SCHED)): the kernel brings a running thread's time up to
  // date when it is read, where schedstat's first field waits for the next tick.
  const auto clock = static_cast<clockid_t>((~static_cast<unsigned>(tid) << 3) | 4U | 2U);
  const auto on_cpu_ns = [clock]() -> std::int64_t {
    timespec ts{};
    return ::clock_gettime(clock, &ts) == 0 ? ts.tv_sec * 1'000'000'000LL + ts.tv_nsec : -1;
  };
  // Waiting only when it got no CPU time around the state's read: a thread that ran (and may
  // have fallen asleep) between the reads is not taken for one that waited.
  const std::int64_t before = on_cpu_ns();
  if (read_task_file(tid, "stat", text, sizeof text)) {
    // "TID (comm) S ...": the state follows the last ')' (comm may hold any byte)
    const char* close = std::strrchr(text, ')');
    cpu.waiting = close != nullptr && close[1] == ' ' && close[2] == 'R';
  }
  cpu.on_cpu_ns = on_cpu_ns();
  cpu.waiting = cpu.waiting && before >= 0 && cpu.on_cpu_ns == before;
  const int policy = ::sched_getscheduler(tid);  // a thread id names the thread (Linux)
  cpu.realtime = policy >= 0 && ((policy & ~SCHED_RESET_ON_FORK) == SCHED_FIFO ||
                                 (policy & ~SCHED_RESET_ON_FORK) == SCHED_RR);
  return cpu;
}

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
    waiting_ns_ = 0;
    unshown_ns_ = 0;
    return false;
  }
  const std::int64_t end = loop_.last_cycle_end_ns();
  const ThreadCpu cpu = loop_.thread_cpu ? loop_.thread_cpu() : ThreadCpu{};
  // Waits that ended since the last check (the kernel adds a wait when the thread gets a CPU);
  // the wait going on now: waiting at this check and the last with no CPU time in between.
  // A realtime thread's waits are not excused (loop_supervisor.hpp).
  const std::int64_t ended_waits =
      cpu.waited_ns >= 0 && last_cpu_.waited_ns >= 0 && !cpu.realtime
          ? std::max<std::int64_t>(0, cpu.waited_ns - last_cpu_.waited_ns)
          : 0;
  const bool still_waiting = cpu.waiting && last_cpu_.waiting && !cpu.realtime &&
                             cpu.on_cpu_ns >= 0 && cpu.on_cpu_ns == last_cpu_.on_cpu_ns &&
                             last_check_ns_ >= 0;
  if (still_waiting) {
    waiting_ns_ += now_ns - last_check_ns_;
  } else {  // the wait ended: its seen part stays excused until run_delay shows the wait (a check
            // can read run_delay just before the thread gets its CPU and the clock just after)
    unshown_ns_ += waiting_ns_;
    waiting_ns_ = 0;
  }
  unshown_ns_ = std::max<std::int64_t>(0, unshown_ns_ - ended_waits);
  last_cpu_ = cpu;
  last_check_ns_ = now_ns;
  if (!seen_any_ || end != seen_end_ns_) {  // the loop made progress: (re-)armed
    seen_any_ = true;
    seen_end_ns_ = end;
    quiet_checks_ = 0;
    excused_ns_ = 0;
    unshown_ns_ = 0;
    stalled_.store(false, std::memory_order_release);
    return false;
  }
  excused_ns_ += ended_waits;  // the scheduler's, not the card's
  if (quiet_checks_ < kQuietChecks) ++quiet_checks_;
  if (stalled_.load(std::memory_order_relaxed)) return false;  // this stall was acted on
  const std::int64_t silent = now_ns - end;
  const std::int64_t excused = excused_ns_ + unshown_ns_ + waiting_ns_;
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
