// The vendor's GT_* calls (gts_abi.hpp, checked against the driver's declarations at the end) on
// the simulated card (gts_sim_model.hpp: the model and the rules every call follows).
#include <cmath>
#include <cstdio>
#include <type_traits>

#include "gts_sim_model.hpp"

using namespace ajar::drivers::cardsim;

namespace {
namespace gts = ajar::drivers::gts;
namespace profile = ajar::drivers::profile;

constexpr std::int64_t kServoOnDelayNs = 5 * kNsPerMs;

bool valid_range(int first, int count) {
  return count >= 1 && valid_axis(first) && valid_axis(first + count - 1);
}
bool valid_mask(long mask) {
  return mask > 0 && (mask >> kAxes) == 0;
}
bool positive_finite(double v) {
  return std::isfinite(v) && v > 0;
}

// Selects a profile mode; refused while the axis moves in the other mode.
short select_mode(Sim& s, short profile, Mode mode) {
  if (!valid_axis(profile)) return gts::kCmdBadParameter;
  Axis& a = axis_at(s, profile);
  if (a.moving && a.moving_mode != mode) return gts::kCmdExecuteError;
  a.mode = mode;
  return gts::kCmdSuccess;
}

bool valid_parameters(const gts::TTrapPrm& p) {
  return positive_finite(p.acc) && positive_finite(p.dec) && p.velStart >= 0 &&
         std::isfinite(p.velStart) && p.smoothTime >= 0 && p.smoothTime <= 50;
}
bool valid_parameters(const gts::TJogPrm& p) {
  return positive_finite(p.acc) && positive_finite(p.dec) && p.smooth >= 0 && p.smooth < 1;
}

// GT_SetTrapPrm / GT_SetJogPrm: bad values are refused (7); the axis must be in `mode` (else 1).
template <typename Parameters>
short set_profile_parameters(Sim& s, short profile, const Parameters* p, Mode mode,
                             Parameters Axis::*field) {
  if (!valid_axis(profile) || p == nullptr || !valid_parameters(*p)) return gts::kCmdBadParameter;
  Axis& a = axis_at(s, profile);
  if (a.mode != mode) return gts::kCmdExecuteError;
  a.*field = *p;
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
    return set_profile_parameters(s, profile, pPrm, Mode::kTrap, &Axis::trap);
  });
}

AJAR_SIM_EXPORT short GT_PrfJog(short profile) {
  return call("GT_PrfJog", true,
              [profile](Sim& s) -> short { return select_mode(s, profile, Mode::kJog); });
}

AJAR_SIM_EXPORT short GT_SetJogPrm(short profile, gts::TJogPrm* pPrm) {
  return call("GT_SetJogPrm", true, [profile, pPrm](Sim& s) -> short {
    return set_profile_parameters(s, profile, pPrm, Mode::kJog, &Axis::jog);
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
