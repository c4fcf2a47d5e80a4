#include "ajar/drivers/gts_card.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "ajar/drivers/card_checks.hpp"
#include "ajar/drivers/gts_abi.hpp"
#include "ajar/drivers/factory.hpp"
#include "library_symbol.hpp"

namespace ajar::drivers {

namespace {

using card::fail;

constexpr const char* kGtsCardLibrary = "GTS card library";

// Decodes a GT_GetSts word (positions left at 0).
AxisStatus decode_status(long sts) {
  AxisStatus st;
  st.enabled = (sts & gts::kStsServoOn) != 0;
  st.moving = (sts & gts::kStsProfileMoving) != 0;
  st.in_position = (sts & gts::kStsInPosition) != 0;
  st.alarm = (sts & gts::kStsDriveAlarm) != 0;
  st.following_error = (sts & gts::kStsFollowingError) != 0;
  st.positive_limit = (sts & gts::kStsPositiveLimit) != 0;
  st.negative_limit = (sts & gts::kStsNegativeLimit) != 0;
  st.smooth_stopped = (sts & gts::kStsSmoothStop) != 0;
  st.emergency_stopped = (sts & gts::kStsEmergencyStop) != 0;
  return st;
}

// The mask of the valid axes in `axes` (stops act on those even if others are invalid).
long valid_mask(std::span<const int> axes, int axis_count) {
  long mask = 0;
  for (const int axis : axes) {
    if (axis >= 1 && axis <= axis_count) mask |= gts::axis_mask(axis);
  }
  return mask;
}

}  // namespace

ErrorCode gts_error_code(short code) noexcept {
  if (code == gts::kCmdSuccess) return ErrorCode::kOk;
  if (code == gts::kCmdBadParameter) return ErrorCode::kCardBadParameter;
  if ((code >= -5 && code <= -1) || code == gts::kCmdNoResponse) {
    return ErrorCode::kCardCommunication;
  }
  if (code == gts::kCmdOpenFailed) return ErrorCode::kCardOpenFailed;
  if (code == gts::kCmdBusy) return ErrorCode::kCardBusy;
  return ErrorCode::kDriverError;  // 1 (execution error) and anything unknown
}

Error gts_error(short code, std::string_view call, int axis) {
  const std::string name(call);
  const ErrorCode ec = gts_error_code(code);
  return make_error(ec, "", describe(CardFailure{ec, axis, code, name.c_str(), ""}));
}

struct GtsMotionCard::Api {
  gts::GT_Open_t open;
  gts::GT_Close_t close;
  gts::GT_Reset_t reset;
  gts::GT_LoadConfig_t load_config;
  gts::GT_ClrSts_t clr_sts;
  gts::GT_AxisOn_t axis_on;
  gts::GT_AxisOff_t axis_off;
  gts::GT_PrfTrap_t prf_trap;
  gts::GT_SetTrapPrm_t set_trap_prm;
  gts::GT_PrfJog_t prf_jog;
  gts::GT_SetJogPrm_t set_jog_prm;
  gts::GT_SetPos_t set_pos;
  gts::GT_SetVel_t set_vel;
  gts::GT_Update_t update;
  gts::GT_GetSts_t get_sts;
  gts::GT_GetPrfPos_t get_prf_pos;
  gts::GT_GetEncPos_t get_enc_pos;
  gts::GT_Stop_t stop;
};

GtsMotionCard::GtsMotionCard(GtsCardSettings settings) : settings_(std::move(settings)) {
  const std::string& path = settings_.library_path;
  if (path.empty()) throw DriverStartupError("GTS card library path is empty (drivers.card)");
  if (settings_.axis_count < 1 || settings_.axis_count > gts::kMaxAxes) {
    throw DriverStartupError("GTS card axis_count " + std::to_string(settings_.axis_count) +
                             " outside 1.." + std::to_string(gts::kMaxAxes));
  }
  handle_ = open_library(kGtsCardLibrary, path);
  try {
    const LibrarySymbols library(handle_, kGtsCardLibrary, path);
    api_ = std::make_unique<Api>(Api{
        library.get<gts::GT_Open_t>("GT_Open"),
        library.get<gts::GT_Close_t>("GT_Close"),
        library.get<gts::GT_Reset_t>("GT_Reset"),
        library.get<gts::GT_LoadConfig_t>("GT_LoadConfig"),
        library.get<gts::GT_ClrSts_t>("GT_ClrSts"),
        library.get<gts::GT_AxisOn_t>("GT_AxisOn"),
        library.get<gts::GT_AxisOff_t>("GT_AxisOff"),
        library.get<gts::GT_PrfTrap_t>("GT_PrfTrap"),
        library.get<gts::GT_SetTrapPrm_t>("GT_SetTrapPrm"),
        library.get<gts::GT_PrfJog_t>("GT_PrfJog"),
        library.get<gts::GT_SetJogPrm_t>("GT_SetJogPrm"),
        library.get<gts::GT_SetPos_t>("GT_SetPos"),
        library.get<gts::GT_SetVel_t>("GT_SetVel"),
        library.get<gts::GT_Update_t>("GT_Update"),
        library.get<gts::GT_GetSts_t>("GT_GetSts"),
        library.get<gts::GT_GetPrfPos_t>("GT_GetPrfPos"),
        library.get<gts::GT_GetEncPos_t>("GT_GetEncPos"),
        library.get<gts::GT_Stop_t>("GT_Stop"),
    });
  } catch (...) {
    dlclose(handle_);
    throw;
  }
}

GtsMotionCard::~GtsMotionCard() {
  if (open_) api_->close();
  dlclose(handle_);
}

ErrorCode GtsMotionCard::call(short code, const char* name, int axis) noexcept {
  if (code == gts::kCmdSuccess) return ErrorCode::kOk;
  return fail(last_, gts_error_code(code), name, axis, "", code);
}

Outcome GtsMotionCard::start_up_call(short code, std::string_view name) const {
  if (code == gts::kCmdSuccess) return Ok{};
  return gts_error(code, name, 0);
}

ErrorCode GtsMotionCard::check_open(const char* name) noexcept {
  if (!open_) return fail(last_, ErrorCode::kDriverError, name, 0, "GTS card is not open");
  return ErrorCode::kOk;
}

ErrorCode GtsMotionCard::check_axes(std::span<const int> axes, const char* name) noexcept {
  if (const auto e = check_open(name); e != ErrorCode::kOk) return e;
  return card::check_axes(axes, settings_.axis_count, name, last_);
}

Outcome GtsMotionCard::open() {
  if (open_) (void)close();  // GT_Open on an open card: start over
  if (auto s = start_up_call(api_->open(static_cast<short>(settings_.channel), 1), "GT_Open"); !s) {
    return s;
  }
  open_ = true;
  std::fill(std::begin(jog_mode_), std::end(jog_mode_), false);  // GT_Reset: no profile mode
  Outcome s = [&]() -> Outcome {
    if (auto r = start_up_call(api_->reset(), "GT_Reset"); !r) return r;
    if (!settings_.card_config_path.empty()) {
      std::string file = settings_.card_config_path;
      if (auto r = start_up_call(api_->load_config(file.data()), "GT_LoadConfig"); !r) {
        return make_error(r.error().code, "card_config_path",
                          r.error().message + " for " + settings_.card_config_path);
      }
    }
    return start_up_call(api_->clr_sts(1, static_cast<short>(settings_.axis_count)), "GT_ClrSts");
  }();
  if (!s) (void)close();  // failed: do not hold the card open
  return s;
}

Outcome GtsMotionCard::close() {
  if (!open_) return Ok{};
  open_ = false;
  return start_up_call(api_->close(), "GT_Close");
}

ErrorCode GtsMotionCard::enable_axes(std::span<const int> axes) noexcept {
  if (const auto e = check_axes(axes, "enable_axes"); e != ErrorCode::kOk) return e;
  for (const int axis : axes) {  // all checked before any is switched on
    long sts = 0;
    const auto a = static_cast<short>(axis);
    if (const auto e = call(api_->get_sts(a, &sts, 1, nullptr), "GT_GetSts", axis);
        e != ErrorCode::kOk) {
      return e;
    }
    if ((sts & gts::kStsDriveAlarm) != 0) {
      return fail(last_, ErrorCode::kAxisAlarm, "enable_axes", axis,
                  "drive alarm latched: clear faults first");
    }
  }
  for (const int axis : axes) {
    if (const auto e = call(api_->axis_on(static_cast<short>(axis)), "GT_AxisOn", axis);
        e != ErrorCode::kOk) {
      return e;
    }
  }
  return ErrorCode::kOk;
}

ErrorCode GtsMotionCard::disable_axes(std::span<const int> axes) noexcept {
  if (const auto e = check_axes(axes, "disable_axes"); e != ErrorCode::kOk) return e;
  for (const int axis : axes) {
    if (const auto e = call(api_->axis_off(static_cast<short>(axis)), "GT_AxisOff", axis);
        e != ErrorCode::kOk) {
      return e;
    }
  }
  return ErrorCode::kOk;
}

ErrorCode GtsMotionCard::clear_faults(std::span<const int> axes) noexcept {
  if (const auto e = check_axes(axes, "clear_faults"); e != ErrorCode::kOk) return e;
  for (const int axis : axes) {
    if (const auto e = call(api_->clr_sts(static_cast<short>(axis), 1), "GT_ClrSts", axis);
        e != ErrorCode::kOk) {
      return e;
    }
  }
  return ErrorCode::kOk;
}

ErrorCode GtsMotionCard::move_relative(std::span<const AxisMove> moves,
                                       const TrapezoidProfile& profile) noexcept {
  if (const auto e = check_open("move_relative"); e != ErrorCode::kOk) return e;
  if (const auto e = card::check_move(moves, profile, settings_.axis_count, last_);
      e != ErrorCode::kOk) {
    return e;
  }
  // Refuse with a named error before anything is commanded.
  for (const AxisMove& m : moves) {
    long sts = 0;
    const auto a = static_cast<short>(m.axis);
    if (const auto e = call(api_->get_sts(a, &sts, 1, nullptr), "GT_GetSts", m.axis);
        e != ErrorCode::kOk) {
      return e;
    }
    if (const auto e = card::check_can_move(decode_status(sts), m.axis, m.distance_counts,
                                            "move_relative", last_);
        e != ErrorCode::kOk) {
      return e;
    }
  }
  gts::TTrapPrm prm{profile.acceleration_counts_per_ms2, profile.deceleration_counts_per_ms2, 0.0,
                    static_cast<short>(std::lround(profile.smooth_time_ms))};
  long mask = 0;
  for (const AxisMove& m : moves) {
    const auto axis = static_cast<short>(m.axis);
    if (const auto e = call(api_->prf_trap(axis), "GT_PrfTrap", m.axis); e != ErrorCode::kOk) {
      return e;
    }
    jog_mode_[m.axis] = false;
    if (const auto e = call(api_->set_trap_prm(axis, &prm), "GT_SetTrapPrm", m.axis);
        e != ErrorCode::kOk) {
      return e;
    }
    double current = 0;
    if (const auto e = call(api_->get_prf_pos(axis, &current, 1, nullptr), "GT_GetPrfPos", m.axis);
        e != ErrorCode::kOk) {
      return e;
    }
    // The card's position registers are 32-bit.
    const double target = std::round(current) + static_cast<double>(m.distance_counts);
    if (!std::isfinite(target) || std::fabs(target) > 2147483647.0) {
      return fail(last_, ErrorCode::kCardBadParameter, "move_relative", m.axis,
                  "target position outside the card's 32-bit range");
    }
    if (const auto e = call(api_->set_pos(axis, std::lround(target)), "GT_SetPos", m.axis);
        e != ErrorCode::kOk) {
      return e;
    }
    if (const auto e =
            call(api_->set_vel(axis, profile.velocity_counts_per_ms), "GT_SetVel", m.axis);
        e != ErrorCode::kOk) {
      return e;
    }
    mask |= gts::axis_mask(m.axis);
  }
  return call(api_->update(mask), "GT_Update", 0);
}

ErrorCode GtsMotionCard::jog(std::span<const AxisVelocity> axes,
                             const JogProfile& profile) noexcept {
  if (const auto e = check_open("jog"); e != ErrorCode::kOk) return e;
  if (const auto e = card::check_jog(axes, profile, settings_.axis_count, last_);
      e != ErrorCode::kOk) {
    return e;
  }
  for (const AxisVelocity& v : axes) {  // refuse with a named error before anything is commanded
    long sts = 0;
    if (const auto e =
            call(api_->get_sts(static_cast<short>(v.axis), &sts, 1, nullptr), "GT_GetSts", v.axis);
        e != ErrorCode::kOk) {
      return e;
    }
    const std::int64_t direction =
        v.velocity_counts_per_ms > 0 ? 1 : (v.velocity_counts_per_ms < 0 ? -1 : 0);
    if (const auto e = card::check_can_move(decode_status(sts), v.axis, direction, "jog", last_);
        e != ErrorCode::kOk) {
      return e;
    }
  }
  gts::TJogPrm prm{profile.acceleration_counts_per_ms2, profile.deceleration_counts_per_ms2,
                   profile.smooth};
  long mask = 0;
  for (const AxisVelocity& v : axes) {
    const auto axis = static_cast<short>(v.axis);
    if (!jog_mode_[v.axis]) {
      if (const auto e = call(api_->prf_jog(axis), "GT_PrfJog", v.axis); e != ErrorCode::kOk) {
        return e;
      }
      jog_mode_[v.axis] = true;
    }
    if (const auto e = call(api_->set_jog_prm(axis, &prm), "GT_SetJogPrm", v.axis);
        e != ErrorCode::kOk) {
      return e;
    }
    if (const auto e = call(api_->set_vel(axis, v.velocity_counts_per_ms), "GT_SetVel", v.axis);
        e != ErrorCode::kOk) {
      return e;
    }
    mask |= gts::axis_mask(v.axis);
  }
  return call(api_->update(mask), "GT_Update", 0);
}

ErrorCode GtsMotionCard::smooth_stop(std::span<const int> axes) noexcept {
  if (const auto e = check_open("smooth_stop"); e != ErrorCode::kOk) return e;
  if (const long mask = valid_mask(axes, settings_.axis_count); mask != 0) {
    if (const auto e = call(api_->stop(mask, 0), "GT_Stop", 0); e != ErrorCode::kOk) return e;
  }
  return check_axes(axes, "smooth_stop");
}

ErrorCode GtsMotionCard::emergency_stop(std::span<const int> axes) noexcept {
  if (const auto e = check_open("emergency_stop"); e != ErrorCode::kOk) return e;
  if (const long mask = valid_mask(axes, settings_.axis_count); mask != 0) {
    if (const auto e = call(api_->stop(mask, mask), "GT_Stop", 0); e != ErrorCode::kOk) return e;
  }
  return check_axes(axes, "emergency_stop");
}

ErrorCode GtsMotionCard::emergency_stop_out_of_band(std::span<const int> axes) noexcept {
  // No last_, no jog_mode_: those belong to the owner thread, which may be inside a call now.
  if (!open_.load(std::memory_order_acquire)) return ErrorCode::kDriverError;
  const long mask = valid_mask(axes, settings_.axis_count);
  if (mask == 0) return ErrorCode::kCardBadParameter;
  return gts_error_code(api_->stop(mask, mask));
}

ErrorCode GtsMotionCard::axis_status(int axis, AxisStatus& out) noexcept {
  const int one[] = {axis};
  if (const auto e = check_axes(one, "axis_status"); e != ErrorCode::kOk) return e;
  const auto a = static_cast<short>(axis);
  long sts = 0;
  double prf = 0;
  double enc = 0;
  if (const auto e = call(api_->get_sts(a, &sts, 1, nullptr), "GT_GetSts", axis);
      e != ErrorCode::kOk) {
    return e;
  }
  if (const auto e = call(api_->get_prf_pos(a, &prf, 1, nullptr), "GT_GetPrfPos", axis);
      e != ErrorCode::kOk) {
    return e;
  }
  if (const auto e = call(api_->get_enc_pos(a, &enc, 1, nullptr), "GT_GetEncPos", axis);
      e != ErrorCode::kOk) {
    return e;
  }
  if (!std::isfinite(prf) || !std::isfinite(enc) || std::fabs(prf) > 9.0e18 ||
      std::fabs(enc) > 9.0e18) {
    return fail(last_, ErrorCode::kDriverError, "axis_status", axis,
                "card reported a non-finite or out-of-range position");
  }
  AxisStatus st = decode_status(sts);
  st.profile_position_counts = std::llround(prf);
  st.encoder_position_counts = std::llround(enc);
  out = st;
  return ErrorCode::kOk;
}

}  // namespace ajar::drivers
