// Realtime helpers for the control thread: the monotonic clock, absolute sleeps, SCHED_FIFO and
// mlockall with graceful fallback (a refusal becomes a warning string; nothing here logs).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ajar::daemon {

// CLOCK_MONOTONIC in nanoseconds.
std::int64_t monotonic_now_ns() noexcept;
// Sleeps until the absolute CLOCK_MONOTONIC time (TIMER_ABSTIME; retries on EINTR).
void sleep_until_ns(std::int64_t deadline_ns) noexcept;

struct RealtimeRequest {
  bool realtime = false;  // SCHED_FIFO at `priority` for the calling thread
  int priority = 80;
  bool lock_memory = false;  // mlockall(MCL_CURRENT | MCL_FUTURE) and pre-fault the stack
};

// Applies what is requested to the calling thread/process. Returns one warning per refused item,
// e.g. "control.realtime: SCHED_FIFO priority 80 refused (Operation not permitted); running with
// normal scheduling". Empty when everything was granted (or nothing requested).
std::vector<std::string> apply_realtime(const RealtimeRequest& request);

}  // namespace ajar::daemon
