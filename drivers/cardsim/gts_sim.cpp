// libajar_gts_sim.so: a simulated GTS motion card behind the vendor's C API (gts_abi.hpp) plus
// the AjarSim_* control functions (gts_sim_control.hpp). One card with gts::kMaxAxes axes.
//
// Model (simulated time in integer nanoseconds = the monotonic clock x time scale, or a manual
// clock; brought up to date on each call, no thread):
// - Motion is closed form (drivers/src/motion_profile.hpp): a profile is planned when it starts
//   and evaluated exactly at the simulated time of each call, so any call rate sees the same
//   trajectory and a time jump costs O(1) under the lock.
// - GT_AxisOn: servo on 5 ms later (not while a drive alarm is latched).
// - GT_PrfTrap / GT_PrfJog select the axis' profile mode (refused, 1, while the axis moves in the
//   other mode). GT_SetVel: trap mode > 0; jog mode signed (the sign is the direction).
// - GT_Update starts the axes in the mask together: trap = trapezoid to GT_SetPos's target; jog =
//   ramp to GT_SetVel's velocity at the jog acc/dec and hold it. Refused (1) for an axis with no
//   profile mode, servo off, alarmed, following error, emergency-stopped, or moving into an active
//   limit.
// - GT_Stop: option bit set = emergency stop (halt at once, 0x100 latched until GT_ClrSts, blocks
//   GT_Update); clear = smooth stop along the mode's deceleration (0x80, cleared by the next
//   GT_Update).
// - Encoder = profile position delayed by the encoder lag while moving; equal at rest.
// - Faults: drive alarm (servo off, halt), following error (halt, encoder offset), limits (halt
//   when moving into them). GT_ClrSts clears all latched bits.
// No exported function lets an exception out: a GT_* call that fails inside returns 1 (execution
// error), an AjarSim_* control does nothing (or returns -1 where it returns a number).
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <mutex>
#include <thread>
#include <type_traits>

#include "ajar/drivers/gts_abi.hpp"
#include "ajar/drivers/gts_sim_control.hpp"
#include "ajar/drivers/motion_profile.hpp"

#define AJAR_SIM_EXPORT extern "C" __attribute__((visibility("default")))

namespace {

namespace gts = ajar::drivers::gts;
namespace profile = ajar::drivers::profile;
using Clock = std::chrono::steady_clock;

constexpr int kAxes = gts::kMaxAxes;
constexpr std::int64_t kNsPerMs = 1'000'000;
constexpr std::int64_t kServoOnDelayNs = 5 * kNsPerMs;
constexpr double kFollowingErrorOffset = 500.0;

// The GT_* calls, for call counting and failure rules without allocation.
constexpr std::array<const char*, 18> kFunctions = {
    "GT_Open",    "GT_Close",   "GT_Reset",      "GT_LoadConfig", "GT_ClrSts",    "GT_AxisOn",
    "GT_AxisOff", "GT_PrfTrap", "GT_SetTrapPrm", "GT_PrfJog",     "GT_SetJogPrm", "GT_SetPos",
    "GT_SetVel",  "GT_Update",  "GT_GetSts",     "GT_GetPrfPos",  "GT_GetEncPos", "GT_Stop"};
int function_index(const char* name) {
  for (std::size_t i = 0; i < kFunctions.size(); ++i) {
    if (std::strcmp(kFunctions[i], name) == 0) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

enum class Mode : std::uint8_t { kNone, kTrap, kJog };

struct Axis {
  bool servo = false;
  std::int64_t servo_on_at_ns = -1;  // >= 0: servo comes on at this simulated time
  bool alarm = false, following_error = false, positive_limit = false, negative_limit = false;
  bool smooth_stopped = false, emergency_stopped = false;
  Mode mode = Mode::kNone;
  gts::TTrapPrm trap{0.1, 0.1, 0.0, 0};
  gts::TJogPrm jog{0.1, 0.1, 0.0};
  long target = 0;
  double vel_cmd = 0;
  // Motion: `motion` runs while `moving`; pos/vel are its last sample (the rest position when
  // not moving).
  bool moving = false;
  Mode moving_mode = Mode::kNone;
  profile::Motion motion;
  double pos = 0, vel = 0;
  double dir = 1;  // direction of the current (or last) motion, for limits
  double enc_offset = 0;

  void halt() {
    moving = false;
    vel = 0;
  }
  void refresh(std::int64_t now_ns) {
    if (servo_on_at_ns >= 0 && now_ns >= servo_on_at_ns) {
      servo_on_at_ns = -1;
      if (!alarm) servo = true;
    }
    if (!moving) return;
    const profile::Sample s = profile::sample(motion, now_ns);
    pos = s.position;
    vel = s.velocity;
    if (s.done) halt();
  }
  double deceleration() const { return moving_mode == Mode::kJog ? jog.dec : trap.dec; }
};

struct FailRule {
  int function = -1;  // index into kFunctions; -1 = any
  short code = 0;
  int remaining = 0;  // < 0 = forever, 0 = unused slot
};

struct Sim {
  std::mutex mutex;
  bool open = false;
  double scale = 1.0;
  bool manual_clock = false;
  Clock::time_point real_base = Clock::now();
  std::int64_t sim_base_ns = 0;
  std::int64_t now_ns = 0;
  double lag_ms = 1.0;
  Axis axes[kAxes];
  FailRule rules[16];
  int calls[kFunctions.size()] = {};
  int total_calls = 0;
  long last_update_mask = 0, last_stop_mask = 0, last_stop_option = 0;
  std::atomic<int> delay_us{0};

  std::int64_t clock_ns() const {
    if (manual_clock) return now_ns;
    const auto real_ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - real_base).count();
    return sim_base_ns + std::llround(static_cast<double>(real_ns) * scale);
  }

  void rebase() {
    sim_base_ns = now_ns;
    real_base = Clock::now();
  }

  // Brings every axis to the current simulated time: O(axes), whatever the time since the last
  // call.
  void advance() {
    now_ns = std::max(now_ns, clock_ns());
    for (Axis& a : axes)
      a.refresh(now_ns);
  }

  double encoder(const Axis& a) const {
    const double lag = a.moving ? a.vel * lag_ms : 0.0;
    return a.pos - lag + a.enc_offset;
  }

  long status(const Axis& a) const {
    long s = 0;
    if (a.alarm) s |= gts::kStsDriveAlarm;
    if (a.following_error) s |= gts::kStsFollowingError;
    if (a.positive_limit) s |= gts::kStsPositiveLimit;
    if (a.negative_limit) s |= gts::kStsNegativeLimit;
    if (a.smooth_stopped) s |= gts::kStsSmoothStop;
    if (a.emergency_stopped) s |= gts::kStsEmergencyStop;
    if (a.servo) s |= gts::kStsServoOn;
    if (a.moving) s |= gts::kStsProfileMoving;
    if (!a.moving && a.servo && std::fabs(encoder(a) - a.pos) < 1.0) s |= gts::kStsInPosition;
    return s;
  }

  void reset_axes() {
    for (Axis& a : axes)
      a = Axis{};
  }
};

Sim& sim() {
  static Sim s;
  return s;
}

bool valid_axis(int axis) {
  return axis >= 1 && axis <= kAxes;
}
bool valid_range(int first, int count) {
  return count >= 1 && valid_axis(first) && valid_axis(first + count - 1);
}
bool valid_mask(long mask) {
  return mask > 0 && (mask >> kAxes) == 0;
}
Axis& axis_at(Sim& s, int axis) {
  return s.axes[axis - 1];
}
bool positive_finite(double v) {
  return std::isfinite(v) && v > 0;
}

// Runs one GT_* call: the configured delay, then under the lock: count, failure rules, open check,
// advance the clock, body. Nothing escapes: an exception inside is execution error (1).
template <typename Body>
short call(const char* name, bool needs_open, Body&& body) noexcept {
  try {
    Sim& s = sim();
    const int delay = s.delay_us.load(std::memory_order_relaxed);
    if (delay > 0) std::this_thread::sleep_for(std::chrono::microseconds(delay));
    std::lock_guard lock(s.mutex);
    const int index = function_index(name);
    if (index >= 0) ++s.calls[index];
    ++s.total_calls;
    for (FailRule& rule : s.rules) {
      if (rule.remaining == 0 || (rule.function != -1 && rule.function != index)) continue;
      if (rule.remaining > 0) --rule.remaining;
      return rule.code;
    }
    if (needs_open && !s.open) return -1;
    s.advance();
    return body(s);
  } catch (...) {
    return gts::kCmdExecuteError;
  }
}

// Runs one AjarSim_* control under the lock; an exception inside is swallowed (returns `failed`).
template <typename R, typename Body>
R control(R failed, Body&& body) noexcept {
  try {
    Sim& s = sim();
    std::lock_guard lock(s.mutex);
    return body(s);
  } catch (...) {
    return failed;
  }
}

// Selects a profile mode; refused while the axis moves in the other mode.
short select_mode(Sim& s, short profile, Mode mode) {
  if (!valid_axis(profile)) return gts::kCmdBadParameter;
  Axis& a = axis_at(s, profile);
  if (a.moving && a.moving_mode != mode) return gts::kCmdExecuteError;
  a.mode = mode;
  return gts::kCmdSuccess;
}

}  // namespace

// --- The vendor API ---------------------------------------------------------------------------

AJAR_SIM_EXPORT short GT_Open(short channel, short param) {
  (void)channel;
  (void)param;
  return call("GT_Open", false, [](Sim& s) -> short {
    s.open = true;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_Close() {
  return call("GT_Close", false, [](Sim& s) -> short {
    s.open = false;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_Reset() {
  return call("GT_Reset", true, [](Sim& s) -> short {
    s.reset_axes();
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_LoadConfig(char* pFile) {
  return call("GT_LoadConfig", true, [pFile](Sim&) -> short {
    if (pFile == nullptr) return gts::kCmdBadParameter;
    std::FILE* f = std::fopen(pFile, "r");
    if (f == nullptr) return gts::kCmdExecuteError;
    std::fclose(f);
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_ClrSts(short axis, short count) {
  return call("GT_ClrSts", true, [axis, count](Sim& s) -> short {
    if (!valid_range(axis, count)) return gts::kCmdBadParameter;
    for (int i = axis; i < axis + count; ++i) {
      Axis& a = axis_at(s, i);
      a.alarm = a.following_error = a.positive_limit = a.negative_limit = false;
      a.smooth_stopped = a.emergency_stopped = false;
      a.enc_offset = 0;
    }
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_AxisOn(short axis) {
  return call("GT_AxisOn", true, [axis](Sim& s) -> short {
    if (!valid_axis(axis)) return gts::kCmdBadParameter;
    Axis& a = axis_at(s, axis);
    if (!a.servo && !a.alarm && a.servo_on_at_ns < 0) a.servo_on_at_ns = s.now_ns + kServoOnDelayNs;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_AxisOff(short axis) {
  return call("GT_AxisOff", true, [axis](Sim& s) -> short {
    if (!valid_axis(axis)) return gts::kCmdBadParameter;
    Axis& a = axis_at(s, axis);
    a.servo = false;
    a.servo_on_at_ns = -1;
    a.halt();
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_PrfTrap(short profile) {
  return call("GT_PrfTrap", true,
              [profile](Sim& s) -> short { return select_mode(s, profile, Mode::kTrap); });
}

AJAR_SIM_EXPORT short GT_SetTrapPrm(short profile, gts::TTrapPrm* pPrm) {
  return call("GT_SetTrapPrm", true, [profile, pPrm](Sim& s) -> short {
    if (!valid_axis(profile) || pPrm == nullptr) return gts::kCmdBadParameter;
    if (!positive_finite(pPrm->acc) || !positive_finite(pPrm->dec) || !(pPrm->velStart >= 0) ||
        !std::isfinite(pPrm->velStart) || pPrm->smoothTime < 0 || pPrm->smoothTime > 50) {
      return gts::kCmdBadParameter;
    }
    Axis& a = axis_at(s, profile);
    if (a.mode != Mode::kTrap) return gts::kCmdExecuteError;
    a.trap = *pPrm;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_PrfJog(short profile) {
  return call("GT_PrfJog", true,
              [profile](Sim& s) -> short { return select_mode(s, profile, Mode::kJog); });
}

AJAR_SIM_EXPORT short GT_SetJogPrm(short profile, gts::TJogPrm* pPrm) {
  return call("GT_SetJogPrm", true, [profile, pPrm](Sim& s) -> short {
    if (!valid_axis(profile) || pPrm == nullptr) return gts::kCmdBadParameter;
    if (!positive_finite(pPrm->acc) || !positive_finite(pPrm->dec) || !(pPrm->smooth >= 0) ||
        !(pPrm->smooth < 1)) {
      return gts::kCmdBadParameter;
    }
    Axis& a = axis_at(s, profile);
    if (a.mode != Mode::kJog) return gts::kCmdExecuteError;
    a.jog = *pPrm;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_SetPos(short profile, long pos) {
  return call("GT_SetPos", true, [profile, pos](Sim& s) -> short {
    if (!valid_axis(profile)) return gts::kCmdBadParameter;
    axis_at(s, profile).target = pos;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_SetVel(short profile, double vel) {
  return call("GT_SetVel", true, [profile, vel](Sim& s) -> short {
    if (!valid_axis(profile) || !std::isfinite(vel)) return gts::kCmdBadParameter;
    Axis& a = axis_at(s, profile);
    if (a.mode != Mode::kJog && !(vel > 0)) return gts::kCmdBadParameter;
    a.vel_cmd = vel;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_Update(long mask) {
  return call("GT_Update", true, [mask](Sim& s) -> short {
    if (!valid_mask(mask)) return gts::kCmdBadParameter;
    s.last_update_mask = mask;
    // All or nothing: check every axis first.
    for (int i = 1; i <= kAxes; ++i) {
      if ((mask & gts::axis_mask(i)) == 0) continue;
      const Axis& a = axis_at(s, i);
      if (a.mode == Mode::kNone || !a.servo || a.alarm || a.following_error ||
          a.emergency_stopped || (a.mode == Mode::kTrap && !(a.vel_cmd > 0))) {
        return gts::kCmdExecuteError;
      }
      const double direction =
          a.mode == Mode::kTrap ? static_cast<double>(a.target) - a.pos : a.vel_cmd;
      if ((direction > 0 && a.positive_limit) || (direction < 0 && a.negative_limit)) {
        return gts::kCmdExecuteError;
      }
    }
    for (int i = 1; i <= kAxes; ++i) {
      if ((mask & gts::axis_mask(i)) == 0) continue;
      Axis& a = axis_at(s, i);
      const double v = a.moving ? a.vel : 0.0;
      if (a.mode == Mode::kTrap) {
        const double goal = static_cast<double>(a.target);
        const double start = a.moving ? v : profile::sign(goal - a.pos) * a.trap.velStart;
        a.motion =
            profile::plan_trap(s.now_ns, a.pos, start, goal, a.vel_cmd, a.trap.acc, a.trap.dec);
        a.dir = goal >= a.pos ? 1 : -1;
      } else {
        a.motion = profile::plan_jog(s.now_ns, a.pos, v, a.vel_cmd, a.jog.acc, a.jog.dec);
        a.dir = a.vel_cmd != 0 ? profile::sign(a.vel_cmd) : profile::sign(v);
      }
      a.moving_mode = a.mode;
      a.smooth_stopped = false;
      a.moving = true;
      a.refresh(s.now_ns);  // a motion with nothing to do ends here
    }
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_GetSts(short axis, long* pSts, short count, unsigned long* pClock) {
  return call("GT_GetSts", true, [axis, pSts, count, pClock](Sim& s) -> short {
    if (!valid_range(axis, count) || pSts == nullptr) return gts::kCmdBadParameter;
    for (int i = 0; i < count; ++i)
      pSts[i] = s.status(axis_at(s, axis + i));
    if (pClock != nullptr) *pClock = static_cast<unsigned long>(s.now_ns / kNsPerMs);
    return gts::kCmdSuccess;
  });
}

namespace {

// GT_GetPrfPos / GT_GetEncPos: `count` positions from `first` on, rounded to whole pulses.
template <typename Position>
short read_positions(const char* name, short first, double* pValue, short count,
                     unsigned long* pClock, Position position) {
  return call(name, true, [first, pValue, count, pClock, position](Sim& s) -> short {
    if (!valid_range(first, count) || pValue == nullptr) return gts::kCmdBadParameter;
    for (int i = 0; i < count; ++i)
      pValue[i] = std::round(position(s, axis_at(s, first + i)));
    if (pClock != nullptr) *pClock = static_cast<unsigned long>(s.now_ns / kNsPerMs);
    return gts::kCmdSuccess;
  });
}

}  // namespace

AJAR_SIM_EXPORT short GT_GetPrfPos(short profile, double* pValue, short count,
                                   unsigned long* pClock) {
  return read_positions("GT_GetPrfPos", profile, pValue, count, pClock,
                        [](Sim&, const auto& axis) { return axis.pos; });
}

AJAR_SIM_EXPORT short GT_GetEncPos(short encoder, double* pValue, short count,
                                   unsigned long* pClock) {
  return read_positions("GT_GetEncPos", encoder, pValue, count, pClock,
                        [](Sim& s, const auto& axis) { return s.encoder(axis); });
}

#ifndef AJAR_SIM_OMIT_GT_STOP  // the test build of a library that lacks a vendor symbol
AJAR_SIM_EXPORT short GT_Stop(long mask, long option) {
  return call("GT_Stop", true, [mask, option](Sim& s) -> short {
    if (!valid_mask(mask)) return gts::kCmdBadParameter;
    s.last_stop_mask = mask;
    s.last_stop_option = option;
    for (int i = 1; i <= kAxes; ++i) {
      if ((mask & gts::axis_mask(i)) == 0) continue;
      Axis& a = axis_at(s, i);
      if ((option & gts::axis_mask(i)) != 0) {
        a.halt();
        a.emergency_stopped = true;
      } else {
        a.smooth_stopped = true;
        if (a.moving) {
          a.motion = profile::plan_stop(s.now_ns, a.pos, a.vel, a.deceleration());
          a.refresh(s.now_ns);
        }
      }
    }
    return gts::kCmdSuccess;
  });
}
#endif

// The vendor ABI, checked against the driver's declarations.
static_assert(std::is_same_v<decltype(&GT_Open), gts::GT_Open_t>);
static_assert(std::is_same_v<decltype(&GT_Close), gts::GT_Close_t>);
static_assert(std::is_same_v<decltype(&GT_Reset), gts::GT_Reset_t>);
static_assert(std::is_same_v<decltype(&GT_LoadConfig), gts::GT_LoadConfig_t>);
static_assert(std::is_same_v<decltype(&GT_ClrSts), gts::GT_ClrSts_t>);
static_assert(std::is_same_v<decltype(&GT_AxisOn), gts::GT_AxisOn_t>);
static_assert(std::is_same_v<decltype(&GT_AxisOff), gts::GT_AxisOff_t>);
static_assert(std::is_same_v<decltype(&GT_PrfTrap), gts::GT_PrfTrap_t>);
static_assert(std::is_same_v<decltype(&GT_SetTrapPrm), gts::GT_SetTrapPrm_t>);
static_assert(std::is_same_v<decltype(&GT_PrfJog), gts::GT_PrfJog_t>);
static_assert(std::is_same_v<decltype(&GT_SetJogPrm), gts::GT_SetJogPrm_t>);
static_assert(std::is_same_v<decltype(&GT_SetPos), gts::GT_SetPos_t>);
static_assert(std::is_same_v<decltype(&GT_SetVel), gts::GT_SetVel_t>);
static_assert(std::is_same_v<decltype(&GT_Update), gts::GT_Update_t>);
static_assert(std::is_same_v<decltype(&GT_GetSts), gts::GT_GetSts_t>);
static_assert(std::is_same_v<decltype(&GT_GetPrfPos), gts::GT_GetPrfPos_t>);
static_assert(std::is_same_v<decltype(&GT_GetEncPos), gts::GT_GetEncPos_t>);

// --- Control ----------------------------------------------------------------------------------

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
