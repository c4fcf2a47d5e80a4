// MockMotionCard: the in-process MotionCard double for daemon tests and rehearsals. It behaves like
// the GTS driver over the card simulator (same checks, same error codes, see gts_card.hpp) and
// computes trapezoidal moves and jogs in closed form (motion_profile.hpp, the simulator's model)
// against its clock (mock_clock.hpp: the steady clock unless one is injected; scaled by
// time_scale) or a manual test clock, so a control loop polling axis_status() sees moves complete
// after their simulated duration.
//
// Fault menu (MockFault, settings.hpp):
//   kOff          normal behaviour
//   kStuck        moves are accepted but never progress: the axes report moving forever
//   kSlow         every call sleeps slow_ms (real time) before it runs
//   kErrorCode    every realtime call (all but open()/close()) fails with kDriverError
//   kIntermittent every third realtime call (counting all but open()/close()) fails with
//                 kCardCommunication; the others work
//   kGarbage      axis_status() returns implausible data (contradictory flags, jumping
//                 positions); commands work
//
// Threading: like the real card, one thread only (no locks).
#pragma once

#include <cstdint>
#include <vector>

#include "ajar/drivers/mock_clock.hpp"
#include "ajar/drivers/motion_card.hpp"
#include "ajar/drivers/motion_profile.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

class MockMotionCard final : public MotionCard {
 public:
  // Simulated time = clock x time_scale from construction on (clock: mock_clock.hpp).
  explicit MockMotionCard(MockFault fault = MockFault::kOff, int slow_ms = 50,
                          double time_scale = 1.0, int axis_count = 4, MockClock clock = {});

  void set_fault(MockFault fault) noexcept { fault_ = fault; }
  MockFault fault() const noexcept { return fault_; }
  // Latch hardware faults like the card would (cleared by clear_faults()). Stop motion at once.
  void inject_alarm(int axis);  // also drops the servo
  void inject_following_error(int axis);
  void inject_limit(int axis, bool positive);
  // open() fails with kCardOpenFailed while set (no card on the bus).
  void set_open_fails(bool fails) noexcept { open_fails_ = fails; }
  // Calls made so far (all of them).
  std::uint64_t calls() const noexcept { return calls_; }
  // Test clock: manual = simulated time stands still except through advance_clock_ns();
  // otherwise the clock x time_scale (continuing from the current simulated time).
  void set_manual_clock(bool manual) noexcept;
  void advance_clock_ns(std::int64_t ns) noexcept;

  Outcome open() override;
  Outcome close() override;
  // Realtime calls (motion_card.hpp): the servo comes on at once in enable_axes().
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

 private:
  struct Axis {
    bool enabled = false, alarm = false, following_error = false;
    bool positive_limit = false, negative_limit = false;
    bool smooth_stopped = false, emergency_stopped = false;
    bool moving = false, stuck = false;
    bool jogging = false;      // the current motion is a jog (velocity mode)
    double stop_dec = 0.1;     // the deceleration of the current motion (smooth stop)
    double direction = 1;      // of the current (or last) motion, for limits
    double rest_position = 0;  // while not moving
    profile::Motion motion;
  };

  std::int64_t now_ns() const noexcept;
  // Samples the motion at now; finishes motion that has ended. Returns position, sets velocity.
  double sample(Axis& a, double* velocity) noexcept;
  void halt(Axis& a) noexcept;
  // The state check before a move or jog of axis n in `direction` (sign).
  ErrorCode check_can_move(int n, double direction, const char* call) noexcept;
  // Counts the call, applies kSlow, and (realtime calls) kErrorCode / kIntermittent.
  ErrorCode enter(const char* call, bool realtime) noexcept;
  ErrorCode check_open(const char* call) noexcept;
  ErrorCode check_axes(std::span<const int> axes, const char* call) noexcept;
  Axis& axis(int n) noexcept { return axes_[static_cast<std::size_t>(n - 1)]; }

  MockFault fault_;
  int slow_ms_;
  double time_scale_;
  int axis_count_;
  MockClock clock_;
  std::int64_t epoch_ns_;     // clock_() when simulated time was base_ns_
  std::int64_t base_ns_ = 0;  // simulated time at epoch_ns_
  bool manual_clock_ = false;
  std::int64_t manual_ns_ = 0;
  bool open_ = false;
  bool open_fails_ = false;
  std::uint64_t calls_ = 0;
  std::uint64_t fault_calls_ = 0;
  std::uint64_t garbage_state_ = 0x9E3779B97F4A7C15ULL;
  std::vector<Axis> axes_;
  CardFailure last_;
};

}  // namespace ajar::drivers
