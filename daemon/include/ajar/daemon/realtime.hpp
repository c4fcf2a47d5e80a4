// Realtime helpers for the control thread: the monotonic clock, absolute sleeps, SCHED_FIFO and
// mlockall with graceful fallback (a refusal becomes a warning string; nothing here logs).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ajar/protocol/messages.hpp"

namespace ajar::daemon {

// CLOCK_MONOTONIC in nanoseconds.
std::int64_t monotonic_now_ns() noexcept;
// Sleeps until the absolute CLOCK_MONOTONIC time (TIMER_ABSTIME; retries on EINTR).
void sleep_until_ns(std::int64_t deadline_ns) noexcept;

struct RealtimeRequest {
  bool realtime = false;  // SCHED_FIFO at `priority` for the calling thread
  int priority = 80;
  // mlockall(MCL_CURRENT | MCL_FUTURE | MCL_ONFAULT): what is resident and whatever is touched
  // later stays resident; the code the loop may run (the executable, the C/C++ runtime, the card's
  // library: every object but the TLS, config, logging and systemd libraries) is locked in full;
  // the stack is pre-faulted.
  bool lock_memory = false;
};

// Call once at start, before any thread is created: when memory is to be locked, new threads get
// kLockedThreadStackBytes of stack instead of glibc's default (RLIMIT_STACK, 8 MiB): a stack page
// once touched stays locked, so a deep call once would keep its pages for good.
inline constexpr std::size_t kLockedThreadStackBytes = 1024 * 1024;
void prepare_process(const RealtimeRequest& request) noexcept;

// Applies what is requested to the calling thread/process. Returns one warning per refused item,
// e.g. "control.realtime: SCHED_FIFO priority 80 refused (Operation not permitted); running with
// normal scheduling". Empty when everything was granted (or nothing requested). Records what the
// thread really got (read back from the kernel) for realtime_granted().
std::vector<std::string> apply_realtime(const RealtimeRequest& request);

// What the last apply_realtime() obtained: the calling (control) thread's policy and priority as
// the kernel reports them, and whether mlockall succeeded. Before any call: SCHED_OTHER, unlocked.
struct RealtimeGranted {
  int policy = 0;  // SCHED_OTHER, SCHED_FIFO, SCHED_RR (<sched.h>)
  int priority = 0;
  bool memory_locked = false;
};
RealtimeGranted realtime_granted() noexcept;
// The same, as Status reports it.
protocol::RealtimeState to_wire(const RealtimeGranted& granted) noexcept;
// One line for the start-up log, e.g. "control thread SCHED_FIFO priority 80; memory locked
// (mlockall on fault, the loop's code in full; 14.2 MiB resident now)" or "control thread
// SCHED_OTHER (control.realtime: false); memory not locked (control.lock_memory: false)". Reads
// /proc/self/status for the resident size.
std::string describe_realtime(const RealtimeRequest& requested, const RealtimeGranted& granted);

}  // namespace ajar::daemon
