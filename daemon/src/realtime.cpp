#include "ajar/daemon/realtime.hpp"

#include <link.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdint>
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

// Libraries the control thread never calls into (TLS, config parsing, logging, systemd
// notification and what they pull in): locked only as far as they are used (MCL_ONFAULT), not
// populated in full. Everything else mapped from a file — the executable, the C and C++ runtime,
// the motion card's vendor library, any library not named here — is locked in full.
constexpr const char* kNotLoopLibraries[] = {
    "libssl.",    "libcrypto.",    "libyaml-cpp.", "libspdlog.", "libfmt.", "libsystemd.",
    "libgcrypt.", "libgpg-error.", "liblzma.",     "libzstd.",   "liblz4.", "libcap."};

bool loop_calls_into(const char* path) noexcept {
  const char* slash = std::strrchr(path, '/');
  const char* name = slash != nullptr ? slash + 1 : path;
  for (const char* skip : kNotLoopLibraries)
    if (std::strncmp(name, skip, std::strlen(skip)) == 0) return false;
  return true;
}

// mlock() (which populates) every loadable segment of the objects the loop may execute.
int lock_loop_code(dl_phdr_info* info, std::size_t, void* failed) noexcept {
  if (info->dlpi_name != nullptr && info->dlpi_name[0] != '\0' && !loop_calls_into(info->dlpi_name))
    return 0;
  const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  for (int i = 0; i < info->dlpi_phnum; ++i) {
    const ElfW(Phdr)& ph = info->dlpi_phdr[i];
    if (ph.p_type != PT_LOAD || ph.p_memsz == 0) continue;
    const std::uintptr_t start = (info->dlpi_addr + ph.p_vaddr) & ~(page - 1);
    const std::uintptr_t end = info->dlpi_addr + ph.p_vaddr + ph.p_memsz;
    if (mlock(reinterpret_cast<const void*>(start), end - start) != 0)
      *static_cast<int*>(failed) = errno;
  }
  return 0;
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
    // What is resident now and every page touched later stays resident (MCL_ONFAULT: nothing is
    // populated just because it is mapped — not the libraries' unused code, not 8 MiB thread
    // stacks); what the loop may execute is populated and locked in full, and its stack
    // pre-faulted. The loop's data (queues, snapshots, histograms) is allocated and touched
    // before the loop starts, so it is locked by MCL_CURRENT.
    locked = mlockall(MCL_CURRENT | MCL_FUTURE | MCL_ONFAULT) == 0;
    if (!locked) {
      warnings.push_back("control.lock_memory: mlockall refused (" + errno_text(errno) +
                         "); memory may be paged out (grant CAP_IPC_LOCK or LimitMEMLOCK)");
    } else {
      int failed = 0;
      dl_iterate_phdr(lock_loop_code, &failed);
      if (failed != 0)
        warnings.push_back("control.lock_memory: locking the loop's code in full failed (" +
                           errno_text(failed) + "); it is locked as it runs");
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
    out << "locked (mlockall on fault, the loop's code in full; " << size << " MiB resident now)";
  } else {
    out << "not locked"
        << (requested.lock_memory ? " (mlockall refused)" : " (control.lock_memory: false)");
  }
  return out.str();
}

}  // namespace ajar::daemon
