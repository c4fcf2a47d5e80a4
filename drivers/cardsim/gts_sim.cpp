// libajar_gts_sim.so: a simulated GTS motion card behind the vendor's C API (card_gts_abi.hpp) plus
// the AjarSim_* control functions (gts_sim_control.hpp). One card with gts::kMaxAxes axes.
//
// Model (1 ms servo period, simulated time = monotonic clock x time scale, advanced on each call):
// - GT_AxisOn: servo on after kServoOnDelayMs (not while a drive alarm is latched).
// - GT_Update starts the trapezoidal moves of all axes in the mask together; refused (1) for an
// axis
//   that is not in trap mode, servo off, alarmed, emergency-stopped, or moving into an active
//   limit.
// - GT_Stop: option bit set = emergency stop (halt at once, 0x100 latched until GT_ClrSts, blocks
//   GT_Update); clear = smooth stop along the trap deceleration (0x80, cleared by the next move).
// - Encoder = profile position delayed by the encoder lag while moving; equal at rest.
// - Faults: drive alarm (servo off, halt), following error (halt, encoder offset), limits (halt
// when
//   moving into them). GT_ClrSts clears all latched bits.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "ajar/drivers/card_gts_abi.hpp"
#include "ajar/drivers/gts_sim_control.hpp"

#define AJAR_SIM_EXPORT extern "C" __attribute__((visibility("default")))

namespace {

namespace gts = ajar::drivers::gts;
using Clock = std::chrono::steady_clock;

constexpr int kAxes = gts::kMaxAxes;
constexpr double kStepMs = 1.0;
constexpr double kServoOnDelayMs = 5.0;
constexpr double kFollowingErrorOffset = 500.0;
constexpr long kMaxSteps = 50'000'000;  // per call: bounds the work after a huge time jump

struct Axis {
  bool servo = false;
  double servo_on_at_ms = -1;  // >= 0: servo comes on at this simulated time
  bool alarm = false, following_error = false, positive_limit = false, negative_limit = false;
  bool smooth_stopped = false, emergency_stopped = false;
  bool trap_mode = false;
  gts::TTrapPrm prm{0.1, 0.1, 0.0, 0};
  long target = 0;
  double vel_cmd = 0;
  // Motion.
  bool moving = false, stopping = false;
  double pos = 0, speed = 0, goal = 0, acc = 0.1, dec = 0.1, vmax = 0;
  int dir = 1;
  double enc_offset = 0;

  void halt() {
    moving = false;
    stopping = false;
    speed = 0;
  }
};

struct FailRule {
  std::string function;  // "*" = any
  short code = 0;
  int remaining = 0;  // < 0 = forever
};

struct Sim {
  std::mutex mutex;
  bool open = false;
  double scale = 1.0;
  Clock::time_point real_base = Clock::now();
  double sim_base_ms = 0;
  double now_ms = 0;
  double lag_ms = 1.0;
  Axis axes[kAxes];
  std::vector<FailRule> rules;
  std::map<std::string, int> calls;
  int total_calls = 0;
  long last_update_mask = 0, last_stop_mask = 0, last_stop_option = 0;
  std::atomic<int> delay_us{0};

  double clock_ms() const {
    const double real_ms =
        std::chrono::duration<double, std::milli>(Clock::now() - real_base).count();
    return sim_base_ms + real_ms * scale;
  }

  void rebase() {
    sim_base_ms = std::max(now_ms, clock_ms());
    real_base = Clock::now();
  }

  bool any_active() const {
    for (const Axis& a : axes) {
      if (a.moving || a.servo_on_at_ms >= 0) return true;
    }
    return false;
  }

  void step_axis(Axis& a) {
    if (a.servo_on_at_ms >= 0 && now_ms >= a.servo_on_at_ms) {
      a.servo_on_at_ms = -1;
      if (!a.alarm) a.servo = true;
    }
    if (!a.moving) return;
    if (a.stopping) {
      a.speed = std::max(0.0, a.speed - a.dec * kStepMs);
      a.pos += a.dir * a.speed * kStepMs;
      if (a.speed <= 0) a.halt();
      return;
    }
    const double remaining = (a.goal - a.pos) * a.dir;
    if (remaining <= 0) {
      a.pos = a.goal;
      a.halt();
      return;
    }
    const double stop_distance = a.speed * a.speed / (2 * a.dec);
    if (stop_distance >= remaining) {
      a.speed -= a.dec * kStepMs;
    } else {
      a.speed = std::min(a.speed + a.acc * kStepMs, a.vmax);
    }
    if (a.speed <= 0) a.speed = std::min(a.dec * kStepMs, remaining / kStepMs);
    const double step = a.speed * kStepMs;
    if (step >= remaining) {
      a.pos = a.goal;
      a.halt();
    } else {
      a.pos += a.dir * step;
    }
  }

  void advance() {
    const double target = clock_ms();
    long steps = 0;
    while (now_ms + kStepMs <= target && any_active() && steps < kMaxSteps) {
      now_ms += kStepMs;
      ++steps;
      for (Axis& a : axes)
        step_axis(a);
    }
    now_ms = std::max(now_ms, target);
  }

  double encoder(const Axis& a) const {
    const double lag = a.moving ? a.dir * a.speed * lag_ms : 0.0;
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

// Runs one GT_* call: the configured delay, then under the lock: count, failure rules, open check,
// advance the clock, body.
template <typename Body>
short call(const char* name, bool needs_open, Body&& body) {
  Sim& s = sim();
  const int delay = s.delay_us.load(std::memory_order_relaxed);
  if (delay > 0) std::this_thread::sleep_for(std::chrono::microseconds(delay));
  std::lock_guard lock(s.mutex);
  ++s.calls[name];
  ++s.total_calls;
  for (FailRule& rule : s.rules) {
    if (rule.remaining == 0 || (rule.function != "*" && rule.function != name)) continue;
    if (rule.remaining > 0) --rule.remaining;
    return rule.code;
  }
  if (needs_open && !s.open) return -1;
  s.advance();
  return body(s);
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
    if (!a.servo && !a.alarm && a.servo_on_at_ms < 0) a.servo_on_at_ms = s.now_ms + kServoOnDelayMs;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_AxisOff(short axis) {
  return call("GT_AxisOff", true, [axis](Sim& s) -> short {
    if (!valid_axis(axis)) return gts::kCmdBadParameter;
    Axis& a = axis_at(s, axis);
    a.servo = false;
    a.servo_on_at_ms = -1;
    a.halt();
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_PrfTrap(short profile) {
  return call("GT_PrfTrap", true, [profile](Sim& s) -> short {
    if (!valid_axis(profile)) return gts::kCmdBadParameter;
    Axis& a = axis_at(s, profile);
    if (a.moving) return gts::kCmdExecuteError;  // no mode change while the profile runs
    a.trap_mode = true;
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_SetTrapPrm(short profile, gts::TTrapPrm* pPrm) {
  return call("GT_SetTrapPrm", true, [profile, pPrm](Sim& s) -> short {
    if (!valid_axis(profile) || pPrm == nullptr) return gts::kCmdBadParameter;
    if (!(pPrm->acc > 0) || !(pPrm->dec > 0) || !(pPrm->velStart >= 0) || pPrm->smoothTime < 0 ||
        pPrm->smoothTime > 50 || !std::isfinite(pPrm->acc) || !std::isfinite(pPrm->dec)) {
      return gts::kCmdBadParameter;
    }
    Axis& a = axis_at(s, profile);
    if (!a.trap_mode) return gts::kCmdExecuteError;
    a.prm = *pPrm;
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
    if (!valid_axis(profile) || !std::isfinite(vel) || !(vel > 0)) return gts::kCmdBadParameter;
    axis_at(s, profile).vel_cmd = vel;
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
      if (!a.trap_mode || !a.servo || a.alarm || a.following_error || a.emergency_stopped ||
          !(a.vel_cmd > 0)) {
        return gts::kCmdExecuteError;
      }
      const double delta = static_cast<double>(a.target) - a.pos;
      if ((delta > 0 && a.positive_limit) || (delta < 0 && a.negative_limit)) {
        return gts::kCmdExecuteError;
      }
    }
    for (int i = 1; i <= kAxes; ++i) {
      if ((mask & gts::axis_mask(i)) == 0) continue;
      Axis& a = axis_at(s, i);
      const double goal = static_cast<double>(a.target);
      const int dir = goal >= a.pos ? 1 : -1;
      if (a.moving && dir != a.dir) a.speed = 0;
      if (!a.moving) a.speed = a.prm.velStart;
      a.goal = goal;
      a.dir = dir;
      a.acc = a.prm.acc;
      a.dec = a.prm.dec;
      a.vmax = a.vel_cmd;
      a.stopping = false;
      a.smooth_stopped = false;
      a.moving = goal != a.pos;
    }
    return gts::kCmdSuccess;
  });
}

AJAR_SIM_EXPORT short GT_GetSts(short axis, long* pSts, short count, unsigned long* pClock) {
  return call("GT_GetSts", true, [axis, pSts, count, pClock](Sim& s) -> short {
    if (!valid_range(axis, count) || pSts == nullptr) return gts::kCmdBadParameter;
    for (int i = 0; i < count; ++i)
      pSts[i] = s.status(axis_at(s, axis + i));
    if (pClock != nullptr) *pClock = static_cast<unsigned long>(s.now_ms);
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
    if (pClock != nullptr) *pClock = static_cast<unsigned long>(s.now_ms);
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
        if (a.moving) a.stopping = true;
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
static_assert(std::is_same_v<decltype(&GT_SetPos), gts::GT_SetPos_t>);
static_assert(std::is_same_v<decltype(&GT_SetVel), gts::GT_SetVel_t>);
static_assert(std::is_same_v<decltype(&GT_Update), gts::GT_Update_t>);
static_assert(std::is_same_v<decltype(&GT_GetSts), gts::GT_GetSts_t>);
static_assert(std::is_same_v<decltype(&GT_GetPrfPos), gts::GT_GetPrfPos_t>);
static_assert(std::is_same_v<decltype(&GT_GetEncPos), gts::GT_GetEncPos_t>);

// --- Control ----------------------------------------------------------------------------------

AJAR_SIM_EXPORT void AjarSim_Reset() {
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
  s.open = false;
  s.reset_axes();
  s.rules.clear();
  s.calls.clear();
  s.total_calls = 0;
  s.last_update_mask = s.last_stop_mask = s.last_stop_option = 0;
  s.scale = 1.0;
  s.lag_ms = 1.0;
  s.now_ms = 0;
  s.sim_base_ms = 0;
  s.real_base = Clock::now();
  s.delay_us.store(0, std::memory_order_relaxed);
}

AJAR_SIM_EXPORT void AjarSim_SetTimeScale(double scale) {
  if (!(scale > 0) || !std::isfinite(scale)) return;
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
  s.advance();
  s.rebase();
  s.scale = scale;
}

AJAR_SIM_EXPORT void AjarSim_InjectFault(short axis, int fault) {
  if (!valid_axis(axis)) return;
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
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
      a.servo_on_at_ms = -1;
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
}

AJAR_SIM_EXPORT void AjarSim_FailNextCalls(const char* function, short code, int count) {
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
  const std::string name = (function == nullptr || *function == '\0') ? "*" : function;
  std::erase_if(s.rules, [&](const FailRule& r) { return r.function == name; });
  if (count != 0) s.rules.push_back(FailRule{name, code, count});
}

AJAR_SIM_EXPORT void AjarSim_SetCallDelayUs(int delay_us) {
  sim().delay_us.store(std::max(0, delay_us), std::memory_order_relaxed);
}

AJAR_SIM_EXPORT void AjarSim_SetEncoderLagMs(double lag_ms) {
  if (!(lag_ms >= 0) || !std::isfinite(lag_ms)) return;
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
  s.lag_ms = lag_ms;
}

AJAR_SIM_EXPORT int AjarSim_CallCount(const char* function) {
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
  if (function == nullptr || std::strcmp(function, "*") == 0) return s.total_calls;
  const auto it = s.calls.find(function);
  return it == s.calls.end() ? 0 : it->second;
}

AJAR_SIM_EXPORT long AjarSim_LastUpdateMask() {
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
  return s.last_update_mask;
}

AJAR_SIM_EXPORT void AjarSim_LastStop(long* mask, long* option) {
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
  if (mask != nullptr) *mask = s.last_stop_mask;
  if (option != nullptr) *option = s.last_stop_option;
}

AJAR_SIM_EXPORT double AjarSim_NowMs() {
  Sim& s = sim();
  std::lock_guard lock(s.mutex);
  s.advance();
  return s.now_ms;
}

static_assert(std::is_same_v<decltype(&AjarSim_Reset), ajar::drivers::AjarSim_Reset_t>);
static_assert(
    std::is_same_v<decltype(&AjarSim_SetTimeScale), ajar::drivers::AjarSim_SetTimeScale_t>);
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
