// A thread's scheduling as the kernel shows it, and the control thread's own schedstat
// (thread_schedule.hpp).
#include "ajar/daemon/thread_schedule.hpp"

#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>

namespace ajar::daemon {
namespace {

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

// A schedstat's "<ns on a CPU> <ns waiting on a runqueue> <switch-ins>" into cpu.waited_ns and
// cpu.switch_ins (left unknown when the text does not hold them).
void parse_schedstat(const char* text, ThreadCpu& cpu) noexcept {
  char* end = nullptr;
  (void)std::strtoll(text, &end, 10);
  const char* second = end;
  const long long waited = std::strtoll(second, &end, 10);
  if (end == second || waited < 0) return;
  cpu.waited_ns = waited;
  const char* third = end;
  const long long switch_ins = std::strtoll(third, &end, 10);
  if (end != third && switch_ins >= 0) cpu.switch_ins = switch_ins;
}

}  // namespace

ThreadCpu thread_cpu(int tid) noexcept {
  ThreadCpu cpu;
  if (tid <= 0) return cpu;
  char text[512];
  if (read_task_file(tid, "schedstat", text, sizeof text)) parse_schedstat(text, cpu);
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
  cpu.realtime = thread_is_realtime(tid);
  return cpu;
}

bool thread_is_realtime(int tid) noexcept {
  const int policy = ::sched_getscheduler(tid);  // a thread id names the thread (Linux)
  return policy >= 0 && ((policy & ~SCHED_RESET_ON_FORK) == SCHED_FIFO ||
                         (policy & ~SCHED_RESET_ON_FORK) == SCHED_RR);
}

OwnSchedstat::OwnSchedstat() noexcept
    : fd_(::open("/proc/thread-self/schedstat", O_RDONLY | O_CLOEXEC)) {}

OwnSchedstat::~OwnSchedstat() {
  if (fd_ >= 0) ::close(fd_);
}

LoopSleep OwnSchedstat::going_to_sleep(std::int64_t wake_ns) const noexcept {
  LoopSleep sleep;
  sleep.wake_ns = wake_ns;
  char text[128];
  const ssize_t n = fd_ >= 0 ? ::pread(fd_, text, sizeof text - 1, 0) : -1;
  if (n <= 0) return sleep;
  text[n] = '\0';
  ThreadCpu own;
  parse_schedstat(text, own);
  // 0: the kernel does not count them ("0 0 0"): a thread reading its own has had a CPU.
  if (own.switch_ins <= 0) return sleep;
  sleep.switch_ins = own.switch_ins;
  sleep.waited_ns = own.waited_ns;
  return sleep;
}

}  // namespace ajar::daemon
