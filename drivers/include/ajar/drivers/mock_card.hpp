// MockMotionCard: the in-process MotionCard double for daemon tests and rehearsals. It behaves like
// the GTS driver over the card simulator (same checks, same error codes, see gts_card.hpp) and
// simulates trapezoidal motion analytically against the steady clock (scaled by time_scale), so a
// control loop polling axis_status() sees moves complete after their simulated duration.
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

#include <chrono>
#include <cstdint>
#include <vector>

#include "ajar/drivers/motion_card.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

class MockMotionCard final : public MotionCard {
 public:
  explicit MockMotionCard(MockFault fault = MockFault::kOff, int slow_ms = 50,
                          double time_scale = 1.0, int axis_count = 4);

  void set_fault(MockFault fault) noexcept { fault_ = fault; }
  MockFault fault() const noexcept { return fault_; }
  // Latch hardware faults like the card would (cleared by clear_faults()). Stop motion at once.
  void inject_alarm(int axis);  // also drops the servo
  void inject_following_error(int axis);
  void inject_limit(int axis, bool positive);
  // Calls made so far (all of them).
  std::uint64_t calls() const noexcept { return calls_; }

  Status open() override;
  Status close() override;
  // Realtime calls (motion_card.hpp): the servo comes on at once in enable_axes().
  ErrorCode enable_axes(std::span<const int> axes) noexcept override;
  ErrorCode disable_axes(std::span<const int> axes) noexcept override;
  ErrorCode clear_faults(std::span<const int> axes) noexcept override;
  ErrorCode move_relative(std::span<const AxisMove> moves,
                          const TrapezoidProfile& profile) noexcept override;
  ErrorCode smooth_stop(std::span<const int> axes) noexcept override;
  ErrorCode emergency_stop(std::span<const int> axes) noexcept override;
  ErrorCode axis_status(int axis, AxisStatus& out) noexcept override;
  CardFailure last_failure() const noexcept override { return last_; }

 private:
  // One trapezoidal segment: from p0 at t0 with speed v0, towards p0 + dir * distance.
  struct Segment {
    double t0_ms = 0, p0 = 0, v0 = 0, vpeak = 0, acc = 1, dec = 1, distance = 0;
    double t_acc = 0, t_cruise = 0, t_dec = 0;
    int dir = 1;
  };
  struct Axis {
    bool enabled = false, alarm = false, following_error = false;
    bool positive_limit = false, negative_limit = false;
    bool smooth_stopped = false, emergency_stopped = false;
    bool moving = false, stuck = false;
    double rest_position = 0;
    Segment segment;
  };

  double now_ms() const noexcept;
  // Samples the segment at now; finishes motion that has ended. Returns position, sets speed.
  double sample(Axis& a, double* speed) noexcept;
  void halt(Axis& a) noexcept;
  // Counts the call, applies kSlow, and (realtime calls) kErrorCode / kIntermittent.
  ErrorCode enter(const char* call, bool realtime) noexcept;
  ErrorCode check_open(const char* call) noexcept;
  ErrorCode check_axes(std::span<const int> axes, const char* call) noexcept;
  Axis& axis(int n) noexcept { return axes_[static_cast<std::size_t>(n - 1)]; }
  static Segment plan(double t0_ms, double p0, double v0, double vmax, double acc, double dec,
                      double distance, int dir) noexcept;

  MockFault fault_;
  int slow_ms_;
  double time_scale_;
  int axis_count_;
  std::chrono::steady_clock::time_point epoch_ = std::chrono::steady_clock::now();
  bool open_ = false;
  std::uint64_t calls_ = 0;
  std::uint64_t fault_calls_ = 0;
  std::uint64_t garbage_state_ = 0x9E3779B97F4A7C15ULL;
  std::vector<Axis> axes_;
  CardFailure last_;
};

}  // namespace ajar::drivers
