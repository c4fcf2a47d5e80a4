#include "ajar/drivers/lifecycle.hpp"

#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>

namespace ajar::drivers {

namespace {

bool card_unhealthy(ErrorCode code) {
  switch (code) {
    case ErrorCode::kCardCommunication:
    case ErrorCode::kCardOpenFailed:
    case ErrorCode::kAxisAlarm:
    case ErrorCode::kFollowingError:
    case ErrorCode::kMotionTimeout:
      return true;
    default:
      return false;
  }
}

bool arm_unhealthy(ErrorCode code) {
  return code == ErrorCode::kDriverError || code == ErrorCode::kInternal;
}

Error wrong_state(const char* what, const char* needs, LifecycleState state) {
  return make_error(ErrorCode::kWrongState, "",
                    std::string("driver lifecycle: ") + what + " needs " + needs + ", state is " +
                        to_string(state));
}

Error not_active(const char* what, LifecycleState state) {
  std::string msg =
      std::string("driver lifecycle: ") + what + " refused, state is " + to_string(state);
  if (state == LifecycleState::kFault) msg += " (recover first)";
  return make_error(ErrorCode::kDriverNotActive, "", msg);
}

// close() / disconnect(): deactivate() when active, then cleanup(); from any state to unconfigured.
// The first error is returned (the cleanup runs also when the deactivation failed).
template <typename Managed>
Outcome shut_down(Managed& driver) {
  if (driver.state() == LifecycleState::kUnconfigured) return Ok{};
  Outcome stopped = Ok{};
  if (driver.state() == LifecycleState::kActive) stopped = driver.deactivate();
  Outcome closed = driver.cleanup();
  if (!stopped) return stopped;
  return closed;
}

}  // namespace

const char* to_string(LifecycleState s) noexcept {
  return word_of(kLifecycleWords, s).data();
}

// --- ManagedMotionCard ------------------------------------------------------------------------

ManagedMotionCard::ManagedMotionCard(std::unique_ptr<MotionCard> impl, std::span<const int> axes,
                                     int stop_timeout_ms, int enable_timeout_ms)
    : impl_(std::move(impl)),
      stop_timeout_ms_(stop_timeout_ms),
      enable_timeout_ms_(enable_timeout_ms) {
  if (!impl_) throw std::invalid_argument("ManagedMotionCard: no card");
  if (axes.size() > std::size(axes_)) throw std::invalid_argument("ManagedMotionCard: > 8 axes");
  for (const int axis : axes)
    axes_[axis_count_++] = axis;
}

void ManagedMotionCard::latch_fault(ErrorCode cause) noexcept {
  if (state_ == LifecycleState::kUnconfigured) return;
  if (state_ != LifecycleState::kFault) fault_cause_ = cause;  // the first is the root cause
  state_ = LifecycleState::kFault;
}

ErrorCode ManagedMotionCard::track(ErrorCode e) noexcept {
  if (e == ErrorCode::kOk) return e;
  last_ = impl_->last_failure();
  if (last_.code != e) last_ = CardFailure{e, 0, 0, "card", ""};  // impl keeps no detail
  if (card_unhealthy(e)) latch_fault(e);
  return e;
}

ErrorCode ManagedMotionCard::refuse(const char* call) noexcept {
  switch (state_) {
    case LifecycleState::kFault:
      last_ = CardFailure{fault_cause_, 0, 0, call, "card lifecycle in fault: recover first"};
      return fault_cause_;
    case LifecycleState::kInactive:
      last_ = CardFailure{ErrorCode::kDriverNotActive, 0, 0, call,
                          "card lifecycle inactive: enable the axes first"};
      return ErrorCode::kDriverNotActive;
    default:
      last_ = CardFailure{ErrorCode::kDriverNotActive, 0, 0, call,
                          "card lifecycle unconfigured: open the card first"};
      return ErrorCode::kDriverNotActive;
  }
}

Outcome ManagedMotionCard::as_status(ErrorCode e) const {
  if (e == ErrorCode::kOk) return Ok{};
  return make_error(e, last_.axis != 0 ? "axis" : "", describe(last_));
}

Outcome ManagedMotionCard::configure() {
  if (state_ != LifecycleState::kUnconfigured) {
    return wrong_state("configure()", "unconfigured", state_);
  }
  if (auto s = impl_->open(); !s) return s;
  state_ = LifecycleState::kInactive;
  fault_cause_ = ErrorCode::kOk;
  return Ok{};
}

Outcome ManagedMotionCard::activate() {
  if (state_ != LifecycleState::kInactive) return wrong_state("activate()", "inactive", state_);
  if (const auto e = track(impl_->clear_faults(axes())); e != ErrorCode::kOk) return as_status(e);
  if (const auto e = track(impl_->enable_axes(axes())); e != ErrorCode::kOk) return as_status(e);
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(enable_timeout_ms_);
  while (true) {
    bool all_on = true;
    for (const int axis : axes()) {
      AxisStatus st;
      if (const auto e = track(impl_->axis_status(axis, st)); e != ErrorCode::kOk) {
        return as_status(e);
      }
      if (st.alarm) {
        return make_error(
            ErrorCode::kAxisAlarm, "axis",
            "driver lifecycle: axis " + std::to_string(axis) + ": drive alarm while enabling");
      }
      all_on = all_on && st.enabled;
    }
    if (state_ == LifecycleState::kFault) return as_status(fault_cause_);
    if (all_on) break;
    if (std::chrono::steady_clock::now() >= deadline) {
      return make_error(
          ErrorCode::kMotionTimeout, "",
          "driver lifecycle: servo not on within " + std::to_string(enable_timeout_ms_) + " ms");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  state_ = LifecycleState::kActive;
  return Ok{};
}

Outcome ManagedMotionCard::deactivate() {
  if (state_ != LifecycleState::kActive) return wrong_state("deactivate()", "active", state_);
  Outcome stopped = as_status(track(impl_->smooth_stop(axes())));
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(stop_timeout_ms_);
  bool resting = false;
  while (stopped && !resting) {
    resting = true;
    for (const int axis : axes()) {
      AxisStatus st;
      if (const auto e = track(impl_->axis_status(axis, st)); e != ErrorCode::kOk) {
        stopped = as_status(e);
        break;
      }
      resting = resting && !st.moving;
    }
    if (resting || !stopped) break;
    if (std::chrono::steady_clock::now() >= deadline) {
      stopped =
          make_error(ErrorCode::kMotionTimeout, "",
                     "driver lifecycle: axes still moving " + std::to_string(stop_timeout_ms_) +
                         " ms after a smooth stop: emergency stop");
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (!stopped) (void)track(impl_->emergency_stop(axes()));
  Outcome disabled = as_status(track(impl_->disable_axes(axes())));
  if (state_ == LifecycleState::kActive) state_ = LifecycleState::kInactive;
  if (!stopped) return stopped;
  return disabled;
}

Outcome ManagedMotionCard::cleanup() {
  if (state_ != LifecycleState::kInactive && state_ != LifecycleState::kFault) {
    return wrong_state("cleanup()", "inactive or fault", state_);
  }
  Outcome s = impl_->close();
  state_ = LifecycleState::kUnconfigured;
  fault_cause_ = ErrorCode::kOk;
  return s;
}

ErrorCode ManagedMotionCard::recover_axes() noexcept {
  if (const auto e = impl_->clear_faults(axes()); e != ErrorCode::kOk) {
    last_ = impl_->last_failure();
    return e;
  }
  for (const int axis : axes()) {
    AxisStatus st;
    if (const auto e = impl_->axis_status(axis, st); e != ErrorCode::kOk) {
      last_ = impl_->last_failure();
      return e;
    }
    if (st.alarm) {
      last_ = CardFailure{ErrorCode::kAxisAlarm, axis, 0, "recover", "drive alarm persists"};
      return ErrorCode::kAxisAlarm;
    }
    if (st.following_error) {
      last_ =
          CardFailure{ErrorCode::kFollowingError, axis, 0, "recover", "following error persists"};
      return ErrorCode::kFollowingError;
    }
  }
  state_ = LifecycleState::kInactive;
  fault_cause_ = ErrorCode::kOk;
  return ErrorCode::kOk;
}

Outcome ManagedMotionCard::recover() {
  if (state_ != LifecycleState::kFault) return wrong_state("recover()", "fault", state_);
  return as_status(recover_axes());
}

Outcome ManagedMotionCard::open() {
  return configure();
}

Outcome ManagedMotionCard::close() {
  return shut_down(*this);
}

ErrorCode ManagedMotionCard::enable_axes(std::span<const int> axes) noexcept {
  if (state_ != LifecycleState::kInactive && state_ != LifecycleState::kActive) {
    return refuse("enable_axes");
  }
  if (const auto e = track(impl_->enable_axes(axes)); e != ErrorCode::kOk) return e;
  if (state_ == LifecycleState::kInactive) state_ = LifecycleState::kActive;
  return ErrorCode::kOk;
}

ErrorCode ManagedMotionCard::disable_axes(std::span<const int> axes) noexcept {
  if (state_ == LifecycleState::kUnconfigured) return refuse("disable_axes");
  const ErrorCode e = track(impl_->disable_axes(axes));
  if (e == ErrorCode::kOk && state_ == LifecycleState::kActive) state_ = LifecycleState::kInactive;
  return e;
}

ErrorCode ManagedMotionCard::clear_faults(std::span<const int> axes) noexcept {
  if (state_ == LifecycleState::kUnconfigured) return refuse("clear_faults");
  if (state_ == LifecycleState::kFault) {
    if (const auto e = impl_->clear_faults(axes); e != ErrorCode::kOk) {
      last_ = impl_->last_failure();
      return e;
    }
    return recover_axes();
  }
  return track(impl_->clear_faults(axes));
}

ErrorCode ManagedMotionCard::move_relative(std::span<const AxisMove> moves,
                                           const TrapezoidProfile& profile) noexcept {
  if (state_ != LifecycleState::kActive) return refuse("move_relative");
  return track(impl_->move_relative(moves, profile));
}

ErrorCode ManagedMotionCard::jog(std::span<const AxisVelocity> axes,
                                 const JogProfile& profile) noexcept {
  if (state_ != LifecycleState::kActive) return refuse("jog");
  return track(impl_->jog(axes, profile));
}

ErrorCode ManagedMotionCard::smooth_stop(std::span<const int> axes) noexcept {
  return track(impl_->smooth_stop(axes));
}

ErrorCode ManagedMotionCard::emergency_stop(std::span<const int> axes) noexcept {
  return track(impl_->emergency_stop(axes));
}

ErrorCode ManagedMotionCard::axis_status(int axis, AxisStatus& out) noexcept {
  AxisStatus st;
  if (const auto e = track(impl_->axis_status(axis, st)); e != ErrorCode::kOk) return e;
  if (st.alarm) {
    latch_fault(ErrorCode::kAxisAlarm);
  } else if (st.following_error) {
    latch_fault(ErrorCode::kFollowingError);
  }
  out = st;
  return ErrorCode::kOk;
}

// --- ManagedManipulator -----------------------------------------------------------------------

ManagedManipulator::ManagedManipulator(std::unique_ptr<Manipulator> impl) : impl_(std::move(impl)) {
  if (!impl_) throw std::invalid_argument("ManagedManipulator: no manipulator");
}

Outcome ManagedManipulator::track(Outcome s) {
  if (!s && state_ != LifecycleState::kUnconfigured && arm_unhealthy(s.error().code)) {
    state_ = LifecycleState::kFault;
  }
  return s;
}

Outcome ManagedManipulator::configure() {
  if (state_ != LifecycleState::kUnconfigured) {
    return wrong_state("configure()", "unconfigured", state_);
  }
  if (auto s = impl_->connect(); !s) return s;
  state_ = LifecycleState::kInactive;
  return Ok{};
}

Outcome ManagedManipulator::activate() {
  if (state_ != LifecycleState::kInactive) return wrong_state("activate()", "inactive", state_);
  state_ = LifecycleState::kActive;
  return Ok{};
}

Outcome ManagedManipulator::deactivate() {
  if (state_ != LifecycleState::kActive) return wrong_state("deactivate()", "active", state_);
  Outcome s = track(impl_->stop());
  if (state_ == LifecycleState::kActive) state_ = LifecycleState::kInactive;
  return s;
}

Outcome ManagedManipulator::cleanup() {
  if (state_ != LifecycleState::kInactive && state_ != LifecycleState::kFault) {
    return wrong_state("cleanup()", "inactive or fault", state_);
  }
  Outcome s = impl_->disconnect();
  state_ = LifecycleState::kUnconfigured;
  return s;
}

Outcome ManagedManipulator::recover() {
  if (state_ != LifecycleState::kFault) return wrong_state("recover()", "fault", state_);
  if (auto s = impl_->clear_fault(); !s) return s;
  state_ = LifecycleState::kInactive;
  return Ok{};
}

Outcome ManagedManipulator::connect() {
  return configure();
}

Outcome ManagedManipulator::disconnect() {
  return shut_down(*this);
}

Result<std::uint32_t> ManagedManipulator::hand_off(const DoorTask& task) {
  if (state_ != LifecycleState::kActive) return not_active("hand_off()", state_);
  auto r = impl_->hand_off(task);
  if (!r && arm_unhealthy(r.error().code)) state_ = LifecycleState::kFault;
  return r;
}

Outcome ManagedManipulator::stop() {
  return track(impl_->stop());
}

Outcome ManagedManipulator::clear_fault() {
  if (state_ == LifecycleState::kUnconfigured) return not_active("clear_fault()", state_);
  if (state_ == LifecycleState::kFault) return recover();
  return track(impl_->clear_fault());
}

ArmStatus ManagedManipulator::status() const {
  return impl_->status();
}

}  // namespace ajar::drivers
