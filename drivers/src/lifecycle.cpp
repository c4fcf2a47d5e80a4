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

}  // namespace

const char* to_string(LifecycleState s) noexcept {
  switch (s) {
    case LifecycleState::kUnconfigured:
      return "unconfigured";
    case LifecycleState::kInactive:
      return "inactive";
    case LifecycleState::kActive:
      return "active";
    case LifecycleState::kFault:
      return "fault";
  }
  return "unknown";
}

// --- ManagedMotionCard ------------------------------------------------------------------------

ManagedMotionCard::ManagedMotionCard(std::unique_ptr<MotionCard> impl, std::span<const int> axes,
                                     int stop_timeout_ms)
    : impl_(std::move(impl)), stop_timeout_ms_(stop_timeout_ms) {
  if (!impl_) throw std::invalid_argument("ManagedMotionCard: no card");
  if (axes.size() > std::size(axes_)) throw std::invalid_argument("ManagedMotionCard: > 8 axes");
  for (const int axis : axes)
    axes_[axis_count_++] = axis;
}

Status ManagedMotionCard::track(Status s) {
  if (!s && state_ != LifecycleState::kUnconfigured && card_unhealthy(s.error().code)) {
    state_ = LifecycleState::kFault;
  }
  return s;
}

Status ManagedMotionCard::configure() {
  if (state_ != LifecycleState::kUnconfigured) {
    return wrong_state("configure()", "unconfigured", state_);
  }
  if (auto s = impl_->open(); !s) return s;
  state_ = LifecycleState::kInactive;
  return Ok{};
}

Status ManagedMotionCard::activate() {
  if (state_ != LifecycleState::kInactive) return wrong_state("activate()", "inactive", state_);
  if (auto s = track(impl_->clear_faults(axes())); !s) return s;
  if (auto s = track(impl_->enable_axes(axes())); !s) return s;
  state_ = LifecycleState::kActive;
  return Ok{};
}

Status ManagedMotionCard::deactivate() {
  if (state_ != LifecycleState::kActive) return wrong_state("deactivate()", "active", state_);
  Status stopped = track(impl_->smooth_stop(axes()));
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(stop_timeout_ms_);
  bool resting = false;
  while (stopped && !resting) {
    resting = true;
    for (const int axis : axes()) {
      auto st = impl_->axis_status(axis);
      if (!st) {
        stopped = track(std::move(st).error());
        break;
      }
      resting = resting && !st->moving;
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
  Status disabled = track(impl_->disable_axes(axes()));
  if (state_ == LifecycleState::kActive) state_ = LifecycleState::kInactive;
  if (!stopped) return stopped;
  return disabled;
}

Status ManagedMotionCard::cleanup() {
  if (state_ != LifecycleState::kInactive && state_ != LifecycleState::kFault) {
    return wrong_state("cleanup()", "inactive or fault", state_);
  }
  Status s = impl_->close();
  state_ = LifecycleState::kUnconfigured;
  return s;
}

Status ManagedMotionCard::recover() {
  if (state_ != LifecycleState::kFault) return wrong_state("recover()", "fault", state_);
  if (auto s = impl_->clear_faults(axes()); !s) return s;
  for (const int axis : axes()) {
    auto st = impl_->axis_status(axis);
    if (!st) return std::move(st).error();
    if (st->alarm) {
      return make_error(ErrorCode::kAxisAlarm, "axis",
                        "axis " + std::to_string(axis) + ": drive alarm persists");
    }
    if (st->following_error) {
      return make_error(ErrorCode::kFollowingError, "axis",
                        "axis " + std::to_string(axis) + ": following error persists");
    }
  }
  state_ = LifecycleState::kInactive;
  return Ok{};
}

Status ManagedMotionCard::open() {
  return configure();
}

Status ManagedMotionCard::close() {
  if (state_ == LifecycleState::kUnconfigured) return Ok{};
  Status stopped = Ok{};
  if (state_ == LifecycleState::kActive) stopped = deactivate();
  Status closed = cleanup();
  if (!stopped) return stopped;
  return closed;
}

Status ManagedMotionCard::enable_axes(std::span<const int> axes) {
  if (state_ != LifecycleState::kInactive && state_ != LifecycleState::kActive) {
    return not_active("enable_axes()", state_);
  }
  if (auto s = track(impl_->enable_axes(axes)); !s) return s;
  state_ = LifecycleState::kActive;
  return Ok{};
}

Status ManagedMotionCard::disable_axes(std::span<const int> axes) {
  if (state_ == LifecycleState::kUnconfigured) return not_active("disable_axes()", state_);
  Status s = track(impl_->disable_axes(axes));
  if (s && state_ == LifecycleState::kActive) state_ = LifecycleState::kInactive;
  return s;
}

Status ManagedMotionCard::clear_faults(std::span<const int> axes) {
  if (state_ == LifecycleState::kUnconfigured) return not_active("clear_faults()", state_);
  if (state_ == LifecycleState::kFault) {
    if (auto s = impl_->clear_faults(axes); !s) return s;
    return recover();
  }
  return track(impl_->clear_faults(axes));
}

Status ManagedMotionCard::move_relative(std::span<const AxisMove> moves,
                                        const TrapezoidProfile& profile) {
  if (state_ != LifecycleState::kActive) return not_active("move_relative()", state_);
  return track(impl_->move_relative(moves, profile));
}

Status ManagedMotionCard::smooth_stop(std::span<const int> axes) {
  return track(impl_->smooth_stop(axes));
}

Status ManagedMotionCard::emergency_stop(std::span<const int> axes) {
  return track(impl_->emergency_stop(axes));
}

Result<AxisStatus> ManagedMotionCard::axis_status(int axis) {
  auto st = impl_->axis_status(axis);
  if (!st) {
    (void)track(st.error());
    return st;
  }
  if (state_ != LifecycleState::kUnconfigured && (st->alarm || st->following_error)) {
    state_ = LifecycleState::kFault;
  }
  return st;
}

// --- ManagedManipulator -----------------------------------------------------------------------

ManagedManipulator::ManagedManipulator(std::unique_ptr<Manipulator> impl) : impl_(std::move(impl)) {
  if (!impl_) throw std::invalid_argument("ManagedManipulator: no manipulator");
}

Status ManagedManipulator::track(Status s) {
  if (!s && state_ != LifecycleState::kUnconfigured && arm_unhealthy(s.error().code)) {
    state_ = LifecycleState::kFault;
  }
  return s;
}

Status ManagedManipulator::configure() {
  if (state_ != LifecycleState::kUnconfigured) {
    return wrong_state("configure()", "unconfigured", state_);
  }
  if (auto s = impl_->connect(); !s) return s;
  state_ = LifecycleState::kInactive;
  return Ok{};
}

Status ManagedManipulator::activate() {
  if (state_ != LifecycleState::kInactive) return wrong_state("activate()", "inactive", state_);
  state_ = LifecycleState::kActive;
  return Ok{};
}

Status ManagedManipulator::deactivate() {
  if (state_ != LifecycleState::kActive) return wrong_state("deactivate()", "active", state_);
  Status s = track(impl_->stop());
  if (state_ == LifecycleState::kActive) state_ = LifecycleState::kInactive;
  return s;
}

Status ManagedManipulator::cleanup() {
  if (state_ != LifecycleState::kInactive && state_ != LifecycleState::kFault) {
    return wrong_state("cleanup()", "inactive or fault", state_);
  }
  Status s = impl_->disconnect();
  state_ = LifecycleState::kUnconfigured;
  return s;
}

Status ManagedManipulator::recover() {
  if (state_ != LifecycleState::kFault) return wrong_state("recover()", "fault", state_);
  if (auto s = impl_->clear_fault(); !s) return s;
  state_ = LifecycleState::kInactive;
  return Ok{};
}

Status ManagedManipulator::connect() {
  return configure();
}

Status ManagedManipulator::disconnect() {
  if (state_ == LifecycleState::kUnconfigured) return Ok{};
  Status stopped = Ok{};
  if (state_ == LifecycleState::kActive) stopped = deactivate();
  Status closed = cleanup();
  if (!stopped) return stopped;
  return closed;
}

Result<std::uint32_t> ManagedManipulator::hand_off(const DoorTask& task) {
  if (state_ != LifecycleState::kActive) return not_active("hand_off()", state_);
  auto r = impl_->hand_off(task);
  if (!r && arm_unhealthy(r.error().code)) state_ = LifecycleState::kFault;
  return r;
}

Status ManagedManipulator::stop() {
  return track(impl_->stop());
}

Status ManagedManipulator::clear_fault() {
  if (state_ == LifecycleState::kUnconfigured) return not_active("clear_fault()", state_);
  if (state_ == LifecycleState::kFault) return recover();
  return track(impl_->clear_fault());
}

ArmStatus ManagedManipulator::status() const {
  return impl_->status();
}

}  // namespace ajar::drivers
