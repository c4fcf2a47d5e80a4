// The lifecycle every driver goes through, enforced by a wrapper so that no implementation can be
// driven out of order (modelled on ros2_control's hardware_interface::System):
//
//   unconfigured --configure()--> inactive --activate()--> active --deactivate()--> inactive
//        ^------------------------cleanup()-----------------'
//   any state --(an error from the implementation)--> fault --recover()--> unconfigured/inactive
//
// Motion calls (move_relative, jog, hand_off, ...) are refused unless active: with kDriverNotActive
// when unconfigured or inactive; a card in kFault refuses with the code that latched the fault (the
// root cause, e.g. kCardCommunication), so that a caller which latches what it is told reports
// why the card is unusable rather than that it is. Stops (smooth_stop, emergency_stop, stop) are
// always passed through: stopping is never refused.
//
// Transitions called in the wrong state return kWrongState and change nothing. A failing
// configure() leaves the wrapper unconfigured; any other failing call that means the hardware is
// unhealthy latches kFault (the call's own error is returned). What latches:
// - card: kCardCommunication, kCardOpenFailed, kAxisAlarm, kFollowingError, kMotionTimeout (the
//   servo did not come on), and an axis_status() that reports a drive alarm or following error;
// - arm: kDriverError and kInternal (the implementation is broken). Link trouble
//   (kArmDisconnected, kArmTimeout) and refusals (kArmRejected) do not latch here: the serial
//   driver reconnects on its own and reports them in status(); the procedure latches its own fault.
// Not latched (the caller's or the situation's doing): kCardBadParameter, kCardBusy, kLimitHit,
// kEmergencyStopped, kDriverError from the card (e.g. servo off).
//
// The MotionCard / Manipulator interface of a wrapper drives the lifecycle too, so code that only
// knows the interface brings a wrapped driver up in the usual order:
//   open() = configure(); close() = deactivate() (if active) + cleanup();
//   enable_axes() is allowed when inactive or active and makes it active (the servo comes on a few
//     ms later, see motion_card.hpp: poll axis_status().enabled);
//   disable_axes() is allowed in any configured state and makes an active wrapper inactive;
//   clear_faults() in kFault = the implementation's clear_faults() + the checks of recover();
//   axis_status() is always passed through;
//   emergency_stop_out_of_band() is passed through in every state and touches none of the
//   wrapper's state (it is called from another thread while the owner thread may be inside a
//   call of the wrapper).
// The card's realtime calls stay realtime through the wrapper (noexcept, no allocation, no
// waiting); last_failure() is the wrapper's own refusal or the implementation's failure. The
// transitions (configure, activate, deactivate, cleanup, recover) are start-up calls: they may
// wait (activate() for servo-on, deactivate() for the stop) and return text.
//   connect() = configure(); disconnect() = deactivate() (if active) + cleanup();
//   clear_fault() in kFault = recover(); status() is always passed through.
//
// Threading: like the drivers they wrap, one owner thread (the card: the control thread); the
// card's emergency_stop_out_of_band() from any thread.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>

#include "ajar/drivers/manipulator.hpp"
#include "ajar/drivers/motion_card.hpp"
#include "ajar/core/words.hpp"

namespace ajar::drivers {

enum class LifecycleState : std::uint8_t {
  kUnconfigured = 0,
  kInactive = 1,
  kActive = 2,
  kFault = 3
};
inline constexpr std::array<Word<LifecycleState>, 4> kLifecycleWords{
    {{LifecycleState::kUnconfigured, "unconfigured"},
     {LifecycleState::kInactive, "inactive"},
     {LifecycleState::kActive, "active"},
     {LifecycleState::kFault, "fault"}}};
const char* to_string(LifecycleState s) noexcept;

// Wraps a MotionCard; itself a MotionCard so the control loop depends on the interface only.
class ManagedMotionCard final : public MotionCard {
 public:
  // `axes` are the axes this card drives (the two wheels, at most 8): activate() enables exactly
  // those and waits up to enable_timeout_ms for servo-on. deactivate() waits up to
  // stop_timeout_ms for the smooth stop before it disables them. Throws std::invalid_argument for
  // more than 8 axes or a null impl.
  ManagedMotionCard(std::unique_ptr<MotionCard> impl, std::span<const int> axes,
                    int stop_timeout_ms = 5000, int enable_timeout_ms = 2000);

  Outcome configure();  // open(): unconfigured -> inactive
  // Clear faults, enable axes, poll (1 ms sleeps) until every axis reports servo-on: inactive ->
  // active. kMotionTimeout after enable_timeout_ms, kAxisAlarm if a drive alarm shows (the wrapper
  // then stays inactive).
  Outcome activate();
  // Smooth stop, poll (1 ms sleeps) until the axes rest or stop_timeout_ms passed (then emergency
  // stop), disable axes: active -> inactive.
  Outcome deactivate();
  Outcome cleanup();  // close(): inactive or fault -> unconfigured
  // fault -> inactive: clear faults, then every axis must answer axis_status() without a drive
  // alarm or following error; otherwise stays in fault and returns why.
  Outcome recover();
  LifecycleState state() const noexcept { return state_; }

  Outcome open() override;
  Outcome close() override;
  ErrorCode enable_axes(std::span<const int> axes) noexcept override;
  ErrorCode disable_axes(std::span<const int> axes) noexcept override;
  ErrorCode clear_faults(std::span<const int> axes) noexcept override;
  ErrorCode move_relative(std::span<const AxisMove> moves,
                          const TrapezoidProfile& profile) noexcept override;
  ErrorCode jog(std::span<const AxisVelocity> axes, const JogProfile& profile) noexcept override;
  ErrorCode smooth_stop(std::span<const int> axes) noexcept override;
  ErrorCode emergency_stop(std::span<const int> axes) noexcept override;
  ErrorCode axis_status(int axis, AxisStatus& out) noexcept override;
  CardFailure last_failure() const noexcept override { return last_; }
  ErrorCode emergency_stop_out_of_band(std::span<const int> axes) noexcept override {
    return impl_->emergency_stop_out_of_band(axes);
  }

 private:
  std::unique_ptr<MotionCard> impl_;
  int axes_[8] = {};
  std::size_t axis_count_ = 0;
  int stop_timeout_ms_ = 5000;
  int enable_timeout_ms_ = 2000;
  LifecycleState state_ = LifecycleState::kUnconfigured;
  ErrorCode fault_cause_ = ErrorCode::kOk;  // the error that latched kFault
  CardFailure last_;

  std::span<const int> axes() const noexcept { return {axes_, axis_count_}; }
  // An implementation call's result: keeps its failure and latches kFault if it is unhealthy.
  ErrorCode track(ErrorCode e) noexcept;
  void latch_fault(ErrorCode cause) noexcept;
  ErrorCode refuse(const char* call) noexcept;  // a motion call outside kActive
  ErrorCode recover_axes() noexcept;            // recover() without text
  Outcome as_status(ErrorCode e) const;         // kOk or the failure as text
};

class ManagedManipulator final : public Manipulator {
 public:
  // Throws std::invalid_argument for a null impl.
  explicit ManagedManipulator(std::unique_ptr<Manipulator> impl);

  Outcome configure();   // connect(): unconfigured -> inactive
  Outcome activate();    // inactive -> active
  Outcome deactivate();  // stop(): active -> inactive
  Outcome cleanup();     // disconnect(): inactive or fault -> unconfigured
  Outcome recover();     // fault -> inactive (clear_fault)
  LifecycleState state() const noexcept { return state_; }

  Outcome connect() override;
  Outcome disconnect() override;
  Result<std::uint32_t> hand_off(const DoorTask& task) override;
  Outcome stop() override;
  Outcome clear_fault() override;
  ArmStatus status() const override;

 private:
  std::unique_ptr<Manipulator> impl_;
  LifecycleState state_ = LifecycleState::kUnconfigured;

  Outcome track(Outcome s);
};

}  // namespace ajar::drivers
