// The AjarSim_* controls (ajar/drivers/gts_sim_control.hpp, checked against its declarations at
// the end): time scale and manual clock, injected faults, failing calls, call delay, encoder lag,
// and what tests read back (call counts, the last GT_Update and GT_Stop, the simulated time).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <type_traits>

#include "ajar/drivers/gts_sim_control.hpp"
#include "gts_sim_model.hpp"

using namespace ajar::drivers::cardsim;

namespace {

constexpr double kFollowingErrorOffset = 500.0;

}  // namespace

// --- Control ----------------------------------------------------------------------------------

AJAR_SIM_EXPORT void AjarSim_ReleaseBlockedCalls();

AJAR_SIM_EXPORT void AjarSim_Reset() {
  control(0, [](Sim& s) {
    s.open = false;
    s.reset_axes();
    for (FailRule& r : s.rules)
      r = FailRule{};
    std::fill(std::begin(s.calls), std::end(s.calls), 0);
    s.total_calls = 0;
    s.last_update_mask = s.last_stop_mask = s.last_stop_option = 0;
    s.scale = 1.0;
    s.manual_clock = false;
    s.lag_ms = 1.0;
    s.now_ns = 0;
    s.sim_base_ns = 0;
    s.real_base = Clock::now();
    s.delay_us.store(0, std::memory_order_relaxed);
    return 0;
  });
  AjarSim_ReleaseBlockedCalls();
}

AJAR_SIM_EXPORT void AjarSim_SetTimeScale(double scale) {
  if (!(scale > 0) || !std::isfinite(scale)) return;
  control(0, [scale](Sim& s) {
    s.advance();
    s.rebase();
    s.scale = scale;
    return 0;
  });
}

AJAR_SIM_EXPORT void AjarSim_SetManualClock(int manual) {
  control(0, [manual](Sim& s) {
    s.advance();
    s.manual_clock = manual != 0;
    s.rebase();
    return 0;
  });
}

AJAR_SIM_EXPORT void AjarSim_AdvanceClockNs(long long ns) {
  if (ns <= 0) return;
  control(0, [ns](Sim& s) {
    if (!s.manual_clock) return 0;
    constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
    s.now_ns = ns > kMax - s.now_ns ? kMax : s.now_ns + ns;
    s.advance();
    return 0;
  });
}

AJAR_SIM_EXPORT void AjarSim_InjectFault(short axis, int fault) {
  if (!valid_axis(axis)) return;
  control(0, [axis, fault](Sim& s) {
    s.advance();
    Axis& a = axis_at(s, axis);
    switch (static_cast<ajar::drivers::SimFault>(fault)) {
      case ajar::drivers::SimFault::kNone:
        a.alarm = a.following_error = a.positive_limit = a.negative_limit = false;
        a.enc_offset = 0;
        break;
      case ajar::drivers::SimFault::kDriveAlarm:
        a.alarm = true;
        a.servo = false;
        a.servo_on_at_ns = -1;
        a.halt();
        break;
      case ajar::drivers::SimFault::kFollowingError:
        a.following_error = true;
        a.enc_offset = kFollowingErrorOffset;
        a.halt();
        break;
      case ajar::drivers::SimFault::kPositiveLimit:
        a.positive_limit = true;
        if (a.moving && a.dir > 0) a.halt();
        break;
      case ajar::drivers::SimFault::kNegativeLimit:
        a.negative_limit = true;
        if (a.moving && a.dir < 0) a.halt();
        break;
    }
    return 0;
  });
}

AJAR_SIM_EXPORT void AjarSim_FailNextCalls(const char* function, short code, int count) {
  const bool any = function == nullptr || *function == '\0' || std::strcmp(function, "*") == 0;
  const int index = any ? -1 : function_index(function);
  if (!any && index < 0) return;  // not a simulated call: nothing would ever match
  control(0, [index, code, count](Sim& s) {
    for (FailRule& r : s.rules) {
      if (r.remaining != 0 && r.function == index) r = FailRule{};
    }
    if (count == 0) return 0;
    for (FailRule& r : s.rules) {
      if (r.remaining == 0) {
        r = FailRule{index, code, count};
        break;
      }
    }
    return 0;
  });
}

AJAR_SIM_EXPORT void AjarSim_BlockNextCall(const char* function, int block_ms) {
  const bool any = function == nullptr || *function == '\0' || std::strcmp(function, "*") == 0;
  const int index = any ? -1 : function_index(function);
  if (!any && index < 0) return;  // not a simulated call: nothing would ever match
  try {
    Hangs& h = hangs();
    const std::lock_guard lock(h.mutex);
    h.function = index;
    h.block_ms = block_ms;
    h.armed.store(true, std::memory_order_release);
  } catch (...) {
  }
}

AJAR_SIM_EXPORT void AjarSim_ReleaseBlockedCalls() {
  try {
    hangs().release();
  } catch (...) {
  }
}

AJAR_SIM_EXPORT int AjarSim_BlockedCalls() {
  try {
    Hangs& h = hangs();
    const std::lock_guard lock(h.mutex);
    return h.hanging;
  } catch (...) {
    return -1;
  }
}

AJAR_SIM_EXPORT void AjarSim_SetCallDelayUs(int delay_us) {
  sim().delay_us.store(std::max(0, delay_us), std::memory_order_relaxed);
}

AJAR_SIM_EXPORT void AjarSim_SetEncoderLagMs(double lag_ms) {
  if (!(lag_ms >= 0) || !std::isfinite(lag_ms)) return;
  control(0, [lag_ms](Sim& s) {
    s.lag_ms = lag_ms;
    return 0;
  });
}

AJAR_SIM_EXPORT int AjarSim_CallCount(const char* function) {
  return control(-1, [function](Sim& s) {
    if (function == nullptr || std::strcmp(function, "*") == 0) return s.total_calls;
    const int index = function_index(function);
    return index < 0 ? 0 : s.calls[index];
  });
}

AJAR_SIM_EXPORT long AjarSim_LastUpdateMask() {
  return control(-1L, [](Sim& s) { return s.last_update_mask; });
}

AJAR_SIM_EXPORT void AjarSim_LastStop(long* mask, long* option) {
  control(0, [mask, option](Sim& s) {
    if (mask != nullptr) *mask = s.last_stop_mask;
    if (option != nullptr) *option = s.last_stop_option;
    return 0;
  });
}

AJAR_SIM_EXPORT double AjarSim_NowMs() {
  return control(-1.0, [](Sim& s) {
    s.advance();
    return static_cast<double>(s.now_ns) / 1e6;
  });
}

static_assert(std::is_same_v<decltype(&AjarSim_Reset), ajar::drivers::AjarSim_Reset_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_SetTimeScale), ajar::drivers::AjarSim_SetTimeScale_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_SetManualClock), ajar::drivers::AjarSim_SetManualClock_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_AdvanceClockNs), ajar::drivers::AjarSim_AdvanceClockNs_t>);
static_assert(std::is_same_v<decltype(&AjarSim_InjectFault), ajar::drivers::AjarSim_InjectFault_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_FailNextCalls), ajar::drivers::AjarSim_FailNextCalls_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_SetCallDelayUs), ajar::drivers::AjarSim_SetCallDelayUs_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_SetEncoderLagMs), ajar::drivers::AjarSim_SetEncoderLagMs_t>);
static_assert(std::is_same_v<decltype(&AjarSim_CallCount), ajar::drivers::AjarSim_CallCount_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_LastUpdateMask), ajar::drivers::AjarSim_LastUpdateMask_t>);
static_assert(std::is_same_v<decltype(&AjarSim_LastStop), ajar::drivers::AjarSim_LastStop_t>);
static_assert(std::is_same_v<decltype(&AjarSim_NowMs), ajar::drivers::AjarSim_NowMs_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_BlockNextCall), ajar::drivers::AjarSim_BlockNextCall_t>);
static_assert(std::is_same_v<decltype(&AjarSim_ReleaseBlockedCalls),
                             ajar::drivers::AjarSim_ReleaseBlockedCalls_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_BlockedCalls), ajar::drivers::AjarSim_BlockedCalls_t>);
