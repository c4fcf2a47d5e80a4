#include "ajar/daemon/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace ajar::daemon {
namespace {

constexpr std::int64_t kNsPerS = 1'000'000'000;

std::string errno_text(int error) {
  return std::strerror(error);
}

// Touches a stack region so that its pages are resident before the loop runs.
void prefault_stack() noexcept {
  volatile unsigned char stack[64 * 1024];
  for (std::size_t i = 0; i < sizeof(stack); i += 4096)
    stack[i] = 0;
}

}  // namespace

std::int64_t monotonic_now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

void sleep_until_ns(std::int64_t deadline_ns) noexcept {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(deadline_ns / kNsPerS);
  ts.tv_nsec = static_cast<long>(deadline_ns % kNsPerS);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

std::vector<std::string> apply_realtime(const RealtimeRequest& request) {
  std::vector<std::string> warnings;
  if (request.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
      warnings.push_back("control.lock_memory: mlockall refused (" + errno_text(errno) +
                         "); memory may be paged out (grant CAP_IPC_LOCK or LimitMEMLOCK)");
    } else {
      prefault_stack();
    }
  }
  if (request.realtime) {
    const int lowest = sched_get_priority_min(SCHED_FIFO);
    const int highest = sched_get_priority_max(SCHED_FIFO);
    sched_param param{};
    param.sched_priority = std::clamp(request.priority, lowest, highest);
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
    if (rc != 0) {
      warnings.push_back("control.realtime: SCHED_FIFO priority " +
                         std::to_string(param.sched_priority) + " refused (" + errno_text(rc) +
                         "); the control loop runs with normal scheduling (grant CAP_SYS_NICE "
                         "or LimitRTPRIO)");
    } else if (param.sched_priority != request.priority) {
      warnings.push_back("control.priority: " + std::to_string(request.priority) +
                         " outside SCHED_FIFO's range; using " +
                         std::to_string(param.sched_priority));
    }
  }
  return warnings;
}

}  // namespace ajar::daemon
