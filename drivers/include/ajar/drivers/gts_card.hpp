// GtsMotionCard: the real GoogolTech GTS motion-card driver. It loads the vendor's C library at run
// time (dlopen of GtsCardSettings::library_path) and resolves the GT_* calls of gts_abi.hpp;
// the card simulator (libajar_gts_sim.so) is loaded through exactly the same path.
//
// Threading: the vendor API is not thread-safe. One thread owns a GtsMotionCard (the control
// thread); nothing here locks. Every call returns as soon as the vendor calls it makes return:
// nothing sleeps or polls (enable_axes() issues servo-on; the caller watches axis_status()).
// The exception is emergency_stop_out_of_band(): one GT_Stop(mask, mask) straight from the
// calling thread, touching no driver state; whether the vendor library lets it through while the
// owner thread is blocked inside another GT_* call is the vendor's (its gts.h documents return
// code -8, "multi-thread lock error": then kCardBusy). docs/drivers.md, "Stopping a stalled loop".
//
// Errors: every vendor return code maps to a named ajar::ErrorCode (gts_error_code()); the
// realtime calls return that code and keep the call, the axis and the raw vendor code in
// last_failure() (no text is built). move_relative() reads each axis' status first and refuses
// with kAxisAlarm / kFollowingError / kLimitHit (moving into an active limit) / kEmergencyStopped /
// kDriverError (servo off) before it commands anything. Limits and alarms are never disabled.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <string_view>

#include "ajar/drivers/motion_card.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

// Vendor return code -> error: 1 kDriverError (execution error), 7 kCardBadParameter,
// -1..-5 kCardCommunication, -6 kCardOpenFailed, -7 kCardCommunication (no response),
// -8 kCardBusy, anything else kDriverError (0 kOk).
ErrorCode gts_error_code(short code) noexcept;
// The same as an Error whose message names the call, the axis (0 = the call is not about one
// axis), the vendor code and its meaning. Start-up and the I/O side only (allocates).
Error gts_error(short code, std::string_view call, int axis);

class GtsMotionCard final : public MotionCard {
 public:
  // Loads the library and resolves every symbol. Throws DriverStartupError naming the library path
  // (cannot be loaded) or the missing symbol. Does not talk to the card (open() does).
  explicit GtsMotionCard(GtsCardSettings settings);
  // Closes the card if it is open (GT_Close; motion is not stopped here: deactivate first).
  ~GtsMotionCard() override;
  GtsMotionCard(const GtsMotionCard&) = delete;
  GtsMotionCard& operator=(const GtsMotionCard&) = delete;

  // GT_Open(channel, 1), GT_Reset, GT_LoadConfig (when card_config_path is set), GT_ClrSts of all
  // axes. When a step after GT_Open fails the card is closed again (GT_Close) and the first
  // error is returned; opening an open card closes it first.
  Outcome open() override;
  Outcome close() override;  // GT_Close
  // GT_GetSts per axis (kAxisAlarm if a drive alarm is latched: nothing is switched on), then
  // GT_AxisOn per axis. The servo comes on a few ms later (status 0x200).
  ErrorCode enable_axes(std::span<const int> axes) noexcept override;
  ErrorCode disable_axes(std::span<const int> axes) noexcept override;  // GT_AxisOff per axis
  ErrorCode clear_faults(std::span<const int> axes) noexcept override;  // GT_ClrSts per axis
  // Per axis: GT_PrfTrap, GT_SetTrapPrm, GT_GetPrfPos, GT_SetPos(current + distance), GT_SetVel;
  // then one GT_Update(mask) so that the axes start together.
  ErrorCode move_relative(std::span<const AxisMove> moves,
                          const TrapezoidProfile& profile) noexcept override;
  // Status check per axis (like move_relative); then per axis GT_PrfJog (unless the driver put the
  // axis in jog mode already: the card refuses a mode change while the axis moves),
  // GT_SetJogPrm, GT_SetVel(signed velocity); then one GT_Update(mask).
  ErrorCode jog(std::span<const AxisVelocity> axes, const JogProfile& profile) noexcept override;
  // GT_Stop(mask, 0): the card decelerates along the mode's deceleration. An empty list is a no-op;
  // invalid axes are reported after the valid ones were stopped.
  ErrorCode smooth_stop(std::span<const int> axes) noexcept override;
  ErrorCode emergency_stop(std::span<const int> axes) noexcept override;  // GT_Stop(mask, mask)
  // GT_GetSts, GT_GetPrfPos, GT_GetEncPos.
  ErrorCode axis_status(int axis, AxisStatus& out) noexcept override;
  CardFailure last_failure() const noexcept override { return last_; }
  // GT_Stop(mask, mask) from the calling thread (any thread); the vendor code as an ErrorCode
  // (gts_error_code), kCardBadParameter without a valid axis, kDriverError while not open.
  ErrorCode emergency_stop_out_of_band(std::span<const int> axes) noexcept override;

  const GtsCardSettings& settings() const noexcept { return settings_; }

 private:
  struct Api;
  ErrorCode check_open(const char* call) noexcept;
  ErrorCode check_axes(std::span<const int> axes, const char* call) noexcept;
  ErrorCode call(short code, const char* name, int axis) noexcept;
  Outcome start_up_call(short code, std::string_view name) const;

  GtsCardSettings settings_;
  void* handle_ = nullptr;
  std::unique_ptr<Api> api_;
  std::atomic<bool> open_{false};  // also read by emergency_stop_out_of_band() on another thread
  bool jog_mode_[9] = {};          // per axis 1..8: the driver selected jog mode (GT_PrfJog) last
  CardFailure last_;
};

}  // namespace ajar::drivers
