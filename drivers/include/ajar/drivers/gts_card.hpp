// GtsMotionCard: the real GoogolTech GTS motion-card driver. It loads the vendor's C library at run
// time (dlopen of GtsCardSettings::library_path) and resolves the GT_* calls of card_gts_abi.hpp;
// the card simulator (libajar_gts_sim.so) is loaded through exactly the same path.
//
// Threading: the vendor API is not thread-safe. One thread owns a GtsMotionCard (the control
// thread); nothing here locks. Calls return as soon as the vendor call returns, except
// enable_axes(), which waits for servo-on by polling (1 ms sleep) up to poll_timeout_ms.
//
// Errors: every vendor return code maps to a named ajar::ErrorCode (gts_error()); the message names
// the call and the axis. move_relative() reads each axis' status first and refuses with
// kAxisAlarm / kFollowingError / kLimitHit (moving into an active limit) / kEmergencyStopped /
// kDriverError (servo off) before it commands anything. Limits and alarms are never disabled.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "ajar/drivers/motion_card.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

// Vendor return code -> error: 1 kDriverError (execution error), 7 kCardBadParameter,
// -1..-5 kCardCommunication, -6 kCardOpenFailed, -7 kCardCommunication (no response),
// -8 kCardBusy, anything else kDriverError. `axis` 0 = the call is not about one axis.
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
  Status open() override;
  Status close() override;  // GT_Close
  // GT_AxisOn per axis, then polls GT_GetSts until servo-on (kMotionTimeout after poll_timeout_ms,
  // kAxisAlarm if a drive alarm shows).
  Status enable_axes(std::span<const int> axes) override;
  Status disable_axes(std::span<const int> axes) override;  // GT_AxisOff per axis
  Status clear_faults(std::span<const int> axes) override;  // GT_ClrSts per axis
  // Per axis: GT_PrfTrap, GT_SetTrapPrm, GT_GetPrfPos, GT_SetPos(current + distance), GT_SetVel;
  // then one GT_Update(mask) so that the axes start together.
  Status move_relative(std::span<const AxisMove> moves, const TrapezoidProfile& profile) override;
  // GT_Stop(mask, 0). An empty list is a no-op; invalid axes are reported after the valid ones
  // were stopped.
  Status smooth_stop(std::span<const int> axes) override;
  Status emergency_stop(std::span<const int> axes) override;  // GT_Stop(mask, mask)
  // GT_GetSts, GT_GetPrfPos, GT_GetEncPos.
  Result<AxisStatus> axis_status(int axis) override;

  const GtsCardSettings& settings() const noexcept { return settings_; }

 private:
  struct Api;
  Status check_axes(std::span<const int> axes) const;
  Status call(short code, std::string_view name, int axis) const;

  GtsCardSettings settings_;
  void* handle_ = nullptr;
  std::unique_ptr<Api> api_;
  bool open_ = false;
};

}  // namespace ajar::drivers
