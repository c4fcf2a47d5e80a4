// The lifecycle every driver goes through, enforced by a wrapper so that no implementation can be
// driven out of order (modelled on ros2_control's hardware_interface::System):
//
//   unconfigured --configure()--> inactive --activate()--> active --deactivate()--> inactive
//        ^------------------------cleanup()-----------------'
//   any state --(an error from the implementation)--> fault --recover()--> unconfigured/inactive
//
// Motion calls (move_relative, hand_off, ...) are refused with kDriverNotActive unless active.
// Stops (smooth_stop, emergency_stop, stop) are always passed through: stopping is never refused.
#pragma once

#include <cstdint>
#include <memory>
#include <span>

#include "ajar/drivers/manipulator.hpp"
#include "ajar/drivers/motion_card.hpp"

namespace ajar::drivers {

enum class LifecycleState : std::uint8_t { kUnconfigured = 0, kInactive = 1, kActive = 2, kFault = 3 };
const char* to_string(LifecycleState s) noexcept;

// Wraps a MotionCard; itself a MotionCard so the control loop depends on the interface only.
class ManagedMotionCard final : public MotionCard {
 public:
  // `axes` are the axes this card drives (the two wheels): activate() enables exactly those.
  ManagedMotionCard(std::unique_ptr<MotionCard> impl, std::span<const int> axes);

  Status configure();   // open(): unconfigured -> inactive
  Status activate();    // clear faults, enable axes: inactive -> active
  Status deactivate();  // smooth stop, disable axes: active -> inactive
  Status cleanup();     // close(): inactive -> unconfigured
  Status recover();     // fault -> inactive (clear faults) when the card answers again
  LifecycleState state() const noexcept { return state_; }

  Status open() override;
  Status close() override;
  Status enable_axes(std::span<const int> axes) override;
  Status disable_axes(std::span<const int> axes) override;
  Status clear_faults(std::span<const int> axes) override;
  Status move_relative(std::span<const AxisMove> moves, const TrapezoidProfile& profile) override;
  Status smooth_stop(std::span<const int> axes) override;
  Status emergency_stop(std::span<const int> axes) override;
  Result<AxisStatus> axis_status(int axis) override;

 private:
  std::unique_ptr<MotionCard> impl_;
  int axes_[8] = {};
  std::size_t axis_count_ = 0;
  LifecycleState state_ = LifecycleState::kUnconfigured;
};

class ManagedManipulator final : public Manipulator {
 public:
  explicit ManagedManipulator(std::unique_ptr<Manipulator> impl);

  Status configure();   // connect(): unconfigured -> inactive
  Status activate();    // inactive -> active
  Status deactivate();  // stop(): active -> inactive
  Status cleanup();     // disconnect(): inactive -> unconfigured
  Status recover();     // fault -> inactive (clear_fault)
  LifecycleState state() const noexcept { return state_; }

  Status connect() override;
  Status disconnect() override;
  Result<std::uint32_t> hand_off(const DoorTask& task) override;
  Status stop() override;
  Status clear_fault() override;
  ArmStatus status() const override;

 private:
  std::unique_ptr<Manipulator> impl_;
  LifecycleState state_ = LifecycleState::kUnconfigured;
};

}  // namespace ajar::drivers
