// MotionCard: the narrow interface the control loop uses to drive the base's wheels. Implemented by
// the real GTS4 driver (vendor library loaded at run time), the simulator (the same driver over the
// card-simulator library), and the in-process mock. Not thread-safe: one thread (the control
// thread) owns a card; the one exception is emergency_stop_out_of_band() (below), the loop
// supervisor's stop from another thread.
//
// Two kinds of call:
// - start-up / shut-down (open(), close()): may take long, return an Outcome with a message.
// - realtime (everything else): noexcept, never allocate, never sleep or poll; each returns as
//   soon as the card calls it makes return. kOk on success, else the ErrorCode. What failed
//   (the vendor call, the axis, the vendor's raw return code, a static reason) is kept as numbers
//   and static strings in last_failure(), for the I/O side to turn into text (describe()).
//
// Units are the card's: positions in pulses (counts), velocity in pulses/ms, acceleration in
// pulses/ms^2. Axes count from 1.
#pragma once

#include <cstdint>
#include <span>
#include <string>

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
  bool faulted() const noexcept {
    return alarm || following_error || positive_limit || negative_limit;
  }
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

// One axis of a velocity-mode (jog) command.
struct AxisVelocity {
  int axis = 1;
  double velocity_counts_per_ms = 0;  // signed: the sign is the direction; 0 = come to rest
};

struct JogProfile {
  double acceleration_counts_per_ms2 = 0.1;  // while speeding up
  double deceleration_counts_per_ms2 = 0.1;  // while slowing down (also towards 0 on a reversal)
  double smooth = 0;                         // GTS jog smoothing coefficient, 0 <= smooth < 1
};

// The detail of a failed realtime call, without text. `call` and `what` point to string literals
// (static storage: safe to copy into a report and read on another thread).
struct CardFailure {
  ErrorCode code = ErrorCode::kOk;
  int axis = 0;           // the axis concerned; 0 = not about one axis
  int vendor_code = 0;    // the vendor call's raw return code; 0 = not a vendor-call failure
  const char* call = "";  // the vendor call (e.g. "GT_GetSts") or the card call that refused
  const char* what =
      "";  // why, when not a vendor code (e.g. "servo is off: enable the axis first")
};

// Text for an operator, e.g. "GT_GetSts(axis 2) failed: vendor code -7 (no response)" or
// "move_relative: axis 1: drive alarm". Allocates: I/O side only.
std::string describe(const CardFailure& failure);
// The meaning of a GTS vendor return code ("no response", ...; "unknown vendor code").
const char* gts_code_meaning(int vendor_code) noexcept;

class MotionCard {
 public:
  virtual ~MotionCard() = default;

  // ---- start-up / shut-down ----
  // Opens the card and loads its configuration (may take long).
  virtual Outcome open() = 0;
  virtual Outcome close() = 0;

  // ---- realtime: noexcept, no allocation, no waiting ----
  // Issues servo-on for the axes and returns (kAxisAlarm if a drive alarm is latched). The servo
  // comes on later: poll axis_status().enabled (the card takes a few ms).
  virtual ErrorCode enable_axes(std::span<const int> axes) noexcept = 0;
  virtual ErrorCode disable_axes(std::span<const int> axes) noexcept = 0;
  // Clears the latched status bits (alarm, following error, limits, stops) of the axes.
  virtual ErrorCode clear_faults(std::span<const int> axes) noexcept = 0;
  // Trapezoidal relative move; all axes start together (one GT_Update with the axis mask).
  virtual ErrorCode move_relative(std::span<const AxisMove> moves,
                                  const TrapezoidProfile& profile) noexcept = 0;
  // Velocity mode (jog): each axis ramps from its current velocity to its target velocity
  // (speeding up at the acceleration, slowing down at the deceleration, through rest on a
  // reversal) and holds it until the next jog() or a stop; a velocity of 0 decelerates to rest.
  // The axes are updated together (one GT_Update). Refused before anything is commanded like
  // move_relative (kCardBadParameter for bad input, kAxisAlarm, kFollowingError, kLimitHit into
  // an active limit, kEmergencyStopped, kDriverError servo off), and with kDriverError while an
  // axis runs a trapezoidal move (stop it first); move_relative likewise refuses a jogging axis.
  virtual ErrorCode jog(std::span<const AxisVelocity> axes, const JogProfile& profile) noexcept = 0;
  // Decelerates the axes to rest along the deceleration of their motion (trap or jog).
  virtual ErrorCode smooth_stop(std::span<const int> axes) noexcept = 0;
  // Stops the axes at once (GTS emergency stop option).
  virtual ErrorCode emergency_stop(std::span<const int> axes) noexcept = 0;
  // Fills `out` on kOk; leaves it unchanged otherwise.
  virtual ErrorCode axis_status(int axis, AxisStatus& out) noexcept = 0;

  // The detail of the last realtime call that did not return kOk (code kOk if none failed yet).
  // Implementations that keep no detail return {code} of nothing: CardFailure{}.
  virtual CardFailure last_failure() const noexcept { return {}; }

  // ---- any thread: the loop supervisor's stop (docs/drivers.md, "Stopping a stalled loop") ----
  // Stops the axes at once by a path that does not go through the owner thread: safe to call from
  // another thread while the owner thread is inside any other call of this card, also one that
  // never returns. noexcept, no allocation, never waits for that other call; it changes nothing
  // the owner thread's calls read or write in the implementation (last_failure() stays as it
  // was). kOk: the card took the stop (the axes latch their emergency-stop state, as after
  // emergency_stop(), so a command issued by the stalled call after it is refused by the card);
  // otherwise why not, e.g. kCardBusy when the vendor library refuses a second thread while the
  // blocked call holds it. Only while the card is open (else kDriverError).
  virtual ErrorCode emergency_stop_out_of_band(std::span<const int> axes) noexcept = 0;
};

}  // namespace ajar::drivers
