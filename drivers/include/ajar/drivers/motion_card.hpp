// MotionCard: the narrow interface the control loop uses to drive the base's wheels. Implemented by
// the real GTS4 driver (vendor library loaded at run time), the simulator (the same driver over the
// card-simulator library), and the in-process mock. Not thread-safe: one thread (the control
// thread) owns a card. Calls never block longer than the implementation's configured call timeout.
//
// Units are the card's: positions in pulses (counts), velocity in pulses/ms, acceleration in
// pulses/ms^2. Axes count from 1.
#pragma once

#include <cstdint>
#include <span>

#include "ajar/core/result.hpp"

namespace ajar::drivers {

struct AxisStatus {
  bool enabled = false;            // servo on (GTS 0x200)
  bool moving = false;             // profile moving (GTS 0x400)
  bool in_position = false;        // GTS 0x800
  bool alarm = false;              // drive alarm (GTS 0x2)
  bool following_error = false;    // GTS 0x10
  bool positive_limit = false;     // GTS 0x20
  bool negative_limit = false;     // GTS 0x40
  bool smooth_stopped = false;     // GTS 0x80
  bool emergency_stopped = false;  // GTS 0x100
  std::int64_t profile_position_counts = 0;
  std::int64_t encoder_position_counts = 0;
  bool faulted() const { return alarm || following_error || positive_limit || negative_limit; }
};

// One axis of a coordinated trapezoidal relative move.
struct AxisMove {
  int axis = 1;
  std::int64_t distance_counts = 0;  // relative to the current profile position
};

struct TrapezoidProfile {
  double velocity_counts_per_ms = 10;
  double acceleration_counts_per_ms2 = 0.1;
  double deceleration_counts_per_ms2 = 0.1;
  double smooth_time_ms = 0;  // GTS smoothTime, 0..50
};

class MotionCard {
 public:
  virtual ~MotionCard() = default;

  // Opens the card and loads its configuration. Start-up only (may take long).
  virtual Status open() = 0;
  virtual Status close() = 0;
  virtual Status enable_axes(std::span<const int> axes) = 0;
  virtual Status disable_axes(std::span<const int> axes) = 0;
  virtual Status clear_faults(std::span<const int> axes) = 0;
  // Trapezoidal relative move; all axes start together (one GT_Update with the axis mask).
  virtual Status move_relative(std::span<const AxisMove> moves,
                               const TrapezoidProfile& profile) = 0;
  // Decelerates the axes to rest along the profile's deceleration.
  virtual Status smooth_stop(std::span<const int> axes) = 0;
  // Stops the axes at once (GTS emergency stop option).
  virtual Status emergency_stop(std::span<const int> axes) = 0;
  virtual Result<AxisStatus> axis_status(int axis) = 0;
};

}  // namespace ajar::drivers
