#include "ajar/daemon/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

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

std::atomic<int> g_policy{SCHED_OTHER};
std::atomic<int> g_priority{0};
std::atomic<bool> g_memory_locked{false};

std::string policy_name(int policy) {
  switch (policy) {
    case SCHED_FIFO:
      return "SCHED_FIFO";
    case SCHED_RR:
      return "SCHED_RR";
    case SCHED_OTHER:
      return "SCHED_OTHER";
    default:
      return "policy " + std::to_string(policy);
  }
}

// VmRSS of /proc/self/status in kB (all of it is locked after mlockall); -1 when unreadable.
long resident_kb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::strtol(line.c_str() + 6, nullptr, 10);
  }
  return -1;
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

void prepare_process(const RealtimeRequest& request) noexcept {
  if (!request.lock_memory) return;
  pthread_attr_t attr;
  if (pthread_getattr_default_np(&attr) != 0) return;
  std::size_t current = 0;
  pthread_attr_getstacksize(&attr, &current);
  if (current > kLockedThreadStackBytes) {
    pthread_attr_setstacksize(&attr, kLockedThreadStackBytes);
    pthread_setattr_default_np(&attr);
  }
  pthread_attr_destroy(&attr);
}

std::vector<std::string> apply_realtime(const RealtimeRequest& request) {
  std::vector<std::string> warnings;
  bool locked = false;
  if (request.lock_memory) {
    locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
    if (!locked) {
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
  int policy = SCHED_OTHER;
  sched_param now{};
  if (pthread_getschedparam(pthread_self(), &policy, &now) == 0) {
    g_policy.store(policy);
    g_priority.store(now.sched_priority);
  }
  g_memory_locked.store(locked);
  return warnings;
}

RealtimeGranted realtime_granted() noexcept {
  return {g_policy.load(), g_priority.load(), g_memory_locked.load()};
}

protocol::RealtimeState to_wire(const RealtimeGranted& granted) noexcept {
  protocol::RealtimeState r;
  r.policy = granted.policy == SCHED_FIFO ? protocol::SchedulingPolicy::kFifo
             : granted.policy == SCHED_RR ? protocol::SchedulingPolicy::kRoundRobin
                                          : protocol::SchedulingPolicy::kOther;
  r.priority = static_cast<std::uint8_t>(std::clamp(granted.priority, 0, 99));
  r.memory_locked = granted.memory_locked;
  return r;
}

std::string describe_realtime(const RealtimeRequest& requested, const RealtimeGranted& granted) {
  std::ostringstream out;
  out << "control thread " << policy_name(granted.policy);
  if (granted.policy == SCHED_FIFO || granted.policy == SCHED_RR)
    out << " priority " << granted.priority;
  else if (!requested.realtime)
    out << " (control.realtime: false)";
  else
    out << " (SCHED_FIFO refused)";
  out << "; memory ";
  if (granted.memory_locked) {
    char size[32];
    std::snprintf(size, sizeof size, "%.1f", static_cast<double>(resident_kb()) / 1024.0);
    out << "locked (mlockall; " << size << " MiB resident now)";
  } else {
    out << "not locked"
        << (requested.lock_memory ? " (mlockall refused)" : " (control.lock_memory: false)");
  }
  return out.str();
}

}  // namespace ajar::daemon
