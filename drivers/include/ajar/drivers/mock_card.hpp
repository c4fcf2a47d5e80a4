// MockMotionCard: the in-process MotionCard double for the daemon in mock mode, its tests and
// rehearsals. It behaves like the GTS driver over the card simulator (same checks, same error
// codes, see gts_card.hpp) and computes trapezoidal moves and jogs in closed form
// (motion_profile.hpp, the simulator's model) against its clock (mock_clock.hpp: the steady clock
// unless one is injected; scaled by time_scale) or a manual test clock, so a control loop polling
// axis_status() sees moves complete after their simulated duration.
//
// Fault menu (MockFault, settings.hpp):
//   kNone         normal behaviour
//   kStuck        moves are accepted but never progress: the axes report moving forever
//   kSlow         every call sleeps slow_ms (real time) before it runs
//   kErrorCode    every realtime call (all but open()/close()) fails with kDriverError
//   kIntermittent every third realtime call (counting all but open()/close()) fails with
//                 kCardCommunication; the others work
//   kGarbage      axis_status() returns implausible data (contradictory flags, jumping
//                 positions); commands work
//
// Test configuration (the engine, loop and interleaving tests; the defaults are the card above):
//   motion model  kConstantSpeed: a move runs at its profile's velocity from the first instant to
//                 its goal, a jog takes its velocity at once, a smooth stop rests stop_delay_ns
//                 later (0: at once): simple, exactly predictable motion on a test clock
//   call log      record_calls(): every commanding call (all but open/close/axis_status) that
//                 reached the card, with its arguments and its index; calls(CardCall) counts
//                 every call by kind (always on)
//   one-shot      fail_next_calls(n): the next n realtime calls fail with kCardCommunication and
//                 reach nothing (emergency_stop excepted: it always acts, so that a test sees the
//                 loop issue it); refuse_next_move(code); stick_next_move() (accepted, never
//                 progresses, stops still work)
//   behaviour     set_stops_never_rest() (a smooth stop never comes to rest until cleared),
//                 set_enable_delay_reads(n) (the servo shows on after n axis_status() reads of the
//                 axis), set_alarm_persists() (clear_faults() leaves a drive alarm latched)
//   hanging call  block_calls(kind, count, block_ms): the next `count` calls of `kind` hang
//                 inside the card (as a vendor call blocked in the driver: the lock is released
//                 meanwhile) for block_ms of real time, or until release_blocked_calls();
//                 blocked_calls() counts the calls hanging now. set_block_status(true/false) =
//                 every axis_status() hangs until released (block_calls(kAxisStatus, -1)) /
//                 release_blocked_calls(): a stalled control loop
//   card faults   (a card that misbehaves, for the control loop's supervision)
//                 drop_next_calls(kind, n): the next n calls of `kind` (move, jog, smooth stop,
//                 and — a card that does not apply its stops at all — emergency stop and
//                 disable_axes) answer kOk and change nothing (accepted, not applied);
//                 fail_after_next_call(kind): the next call of `kind` is applied, then answers
//                 kCardCommunication; set_stale_status_reads(n): the next n axis_status() reads of
//                 each axis repeat that axis' last answer; stop_answering_for_ns(ns): every
//                 realtime call (emergency_stop too) fails with kCardCommunication until the card's
//                 clock has advanced by ns, while the motion it runs goes on
//   observation   peek(axis): the axis as axis_status() would report it, without a call;
//                 velocity(axis): the simulated wheel's velocity now (counts/ms, signed);
//                 jogging(axis): it moves in velocity mode; motion_call(axis): the log index of
//                 the call that started its current motion
//
// emergency_stop_out_of_band(): halts the axes at once and latches their emergency-stop flag, like
// emergency_stop(), from any thread, also while another call hangs in block_calls() (which waits
// with the lock released); the fault menu and one-shot failures do not apply to it (counted as
// CardCall::kEmergencyStopOutOfBand, logged when recording).
//
// Threading: every call takes one internal lock, so a test thread may configure and observe the
// card while the control thread drives it (uncontended in the daemon's mock mode).
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

#include "ajar/drivers/mock_clock.hpp"
#include "ajar/drivers/motion_card.hpp"
#include "ajar/drivers/motion_profile.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

enum class CardCall : std::uint8_t {
  kOpen,
  kClose,
  kEnableAxes,
  kDisableAxes,
  kClearFaults,
  kMoveRelative,
  kJog,
  kSmoothStop,
  kEmergencyStop,
  kAxisStatus,
  kEmergencyStopOutOfBand,
};
inline constexpr std::size_t kCardCallKinds = 11;

// One commanding call as the card got it (MockMotionCard::record_calls).
struct CardCallRecord {
  CardCall kind = CardCall::kOpen;
  std::int64_t at_ns = 0;                // the mock's simulated time
  ErrorCode result = ErrorCode::kOk;     // what the card answered
  std::vector<int> axes;                 // enable/disable/clear/stop calls
  std::vector<AxisMove> moves;           // move_relative
  TrapezoidProfile profile;              // move_relative
  std::vector<AxisVelocity> velocities;  // jog
  JogProfile jog_profile;                // jog
  bool applied = true;                   // false: accepted but not applied (drop_next_calls)

  // The distance (move) or velocity (jog) this call gave `axis`; 0 when it did not name it.
  std::int64_t distance_counts(int axis) const noexcept;
  double velocity_counts_per_ms(int axis) const noexcept;
  // A jog that sets some axis moving (a non-zero velocity).
  bool jogs() const noexcept;
};

enum class MockMotionModel : std::uint8_t { kProfile, kConstantSpeed };

class MockMotionCard final : public MotionCard {
 public:
  // Simulated time = clock x time_scale from construction on (clock: mock_clock.hpp).
  explicit MockMotionCard(MockFault fault = MockFault::kNone, int slow_ms = 50,
                          double time_scale = 1.0, int axis_count = 4, MockClock clock = {});

  void set_fault(MockFault fault) noexcept { fault_ = fault; }
  MockFault fault() const noexcept { return fault_; }
  // Latch hardware faults like the card would (cleared by clear_faults()). Stop motion at once.
  void inject_alarm(int axis);  // also drops the servo
  void inject_following_error(int axis);
  void inject_limit(int axis, bool positive);
  // open() fails with kCardOpenFailed while set (no card on the bus).
  void set_open_fails(bool fails) noexcept { set_locked(open_fails_, fails); }
  // Calls made so far (all of them), and of one kind.
  std::uint64_t calls() const noexcept;
  std::uint64_t calls(CardCall kind) const noexcept;
  // Test clock: manual = simulated time stands still except through advance_clock_ns();
  // otherwise the clock x time_scale (continuing from the current simulated time).
  void set_manual_clock(bool manual) noexcept;
  void advance_clock_ns(std::int64_t ns) noexcept;

  // Test configuration (see the top of this file).
  void set_motion_model(MockMotionModel model, std::int64_t stop_delay_ns = 0) noexcept;
  void record_calls(bool on) noexcept { set_locked(recording_, on); }
  void fail_next_calls(int n) noexcept { set_locked(fail_calls_, n < 0 ? 0 : n); }
  void refuse_next_move(ErrorCode code = ErrorCode::kCardBusy) noexcept {
    set_locked(refuse_move_, code);
  }
  void stick_next_move() noexcept { set_locked(stick_move_, true); }
  void set_stops_never_rest(bool never) noexcept { set_locked(stops_never_rest_, never); }
  void set_enable_delay_reads(int reads) noexcept {
    set_locked(enable_delay_reads_, reads < 0 ? 0 : reads);
  }
  void set_alarm_persists(bool persists) noexcept { set_locked(alarm_persists_, persists); }
  // A call that hangs (see the top of this file): count < 0 = every call of `kind` until
  // released; block_ms < 0 = until release_blocked_calls(). Replaces the previous rule.
  void block_calls(CardCall kind, int count = 1, int block_ms = -1);
  void release_blocked_calls();  // ends every hanging call and clears the rule
  std::size_t blocked_calls() const noexcept;
  void set_block_status(bool block);
  // Card faults (see the top of this file).
  void drop_next_calls(CardCall kind, int n = 1) noexcept;
  void fail_after_next_call(CardCall kind) noexcept;
  void set_stale_status_reads(int n) noexcept;
  void stop_answering_for_ns(std::int64_t ns) noexcept;
  bool answering() const noexcept;  // false while stop_answering_for_ns() lasts
  // Some card fault above is still pending (a drop, an error after a call, stale reads, silence).
  bool misbehaving() const noexcept;
  // Observation (see the top of this file). log_size() is the index the next logged call gets.
  AxisStatus peek(int axis) noexcept;
  double velocity(int axis) noexcept;
  bool any_moving() noexcept;
  bool jogging(int axis) noexcept;
  std::size_t motion_call(int axis) const noexcept;
  std::size_t log_size() const;
  std::vector<CardCallRecord> log_from(std::size_t index) const;

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
  CardFailure last_failure() const noexcept override;
  ErrorCode emergency_stop_out_of_band(std::span<const int> axes) noexcept override;

 private:
  struct Axis {
    bool enabled = false, alarm = false, following_error = false;
    bool positive_limit = false, negative_limit = false;
    bool smooth_stopped = false, emergency_stopped = false;
    bool moving = false, stuck = false;
    bool stop_held = false;    // stuck by set_stops_never_rest(): rests once that is cleared
    bool jogging = false;      // the current motion is a jog (velocity mode)
    double stop_dec = 0.1;     // the deceleration of the current motion (smooth stop)
    double direction = 1;      // of the current (or last) motion, for limits
    double rest_position = 0;  // while not moving
    int enable_pending = 0;    // status reads until the servo shows on
    std::size_t motion_call = 0;
    profile::Motion motion;
    int stale_reads = 0;  // axis_status() repeats last_status this many more times
    bool has_last_status = false;
    AxisStatus last_status;
  };
  using Lock = std::unique_lock<std::mutex>;

  std::int64_t now_ns() const noexcept;
  // Samples the motion at now; finishes motion that has ended. Returns position, sets velocity.
  double sample(Axis& a, double* velocity) noexcept;
  void halt(Axis& a) noexcept;
  static AxisStatus flags_of(const Axis& a) noexcept;  // the latched flags, no motion sampled
  AxisStatus status_of(Axis& a) noexcept;
  // The state check before a move or jog of axis n in `direction` (sign).
  ErrorCode check_can_move(int n, double direction, const char* call) noexcept;
  // check_can_move, and no change between a move and a jog while the axis moves.
  ErrorCode check_can_start(int n, double direction, bool jog, const char* call) noexcept;
  // Sets the axis moving on `motion` (planned from `here`), started by the call being logged.
  void start(Axis& a, bool jog, bool stuck, double direction, double here, double stop_dec,
             const profile::Motion& motion) noexcept;
  // Takes the lock (after kSlow's sleep), counts the call, hangs it when block_calls() says so,
  // and (realtime calls) applies kErrorCode / kIntermittent / fail_next_calls.
  ErrorCode enter(Lock& lock, CardCall kind, const char* call, bool realtime) noexcept;
  void hang_if_blocked(Lock& lock, CardCall kind) noexcept;
  ErrorCode check_open(const char* call) noexcept;
  ErrorCode check_axes(std::span<const int> axes, const char* call) noexcept;
  // A realtime call on `axes`: enter(), `body` under the lock, logged.
  template <typename Body>
  ErrorCode axes_call(CardCall kind, const char* call, std::span<const int> axes,
                      Body body) noexcept {
    Lock lock;
    if (const ErrorCode e = enter(lock, kind, call, true); e != ErrorCode::kOk) return e;
    const ErrorCode result = body();
    return recording_ ? logged(record(kind, axes), result) : result;
  }
  // Card faults: whether this call of `kind` is dropped (accepted, not applied) / fails after it
  // was applied; each consumes one.
  bool take_drop(CardCall kind) noexcept;
  ErrorCode applied_result(CardCall kind, ErrorCode result, const char* call) noexcept;
  // Logs the call (when recording) and returns `result`.
  ErrorCode logged(CardCallRecord&& record, ErrorCode result) noexcept;
  CardCallRecord record(CardCall kind, std::span<const int> axes = {}) const;
  template <typename T, typename V>
  void set_locked(T& field, V value) noexcept {
    const Lock lock(mutex_);
    field = value;
  }
  bool valid(int n) const noexcept { return n >= 1 && n <= axis_count_; }
  Axis& axis(int n) noexcept { return axes_[static_cast<std::size_t>(n - 1)]; }

  mutable std::mutex mutex_;
  std::condition_variable unblocked_;
  std::atomic<MockFault> fault_;
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
  std::array<std::uint64_t, kCardCallKinds> calls_by_kind_{};
  std::uint64_t fault_calls_ = 0;
  std::uint64_t garbage_state_ = 0x9E3779B97F4A7C15ULL;
  MockMotionModel model_ = MockMotionModel::kProfile;
  std::int64_t stop_delay_ns_ = 0;
  bool recording_ = false;
  int fail_calls_ = 0;
  ErrorCode refuse_move_ = ErrorCode::kOk;
  bool stick_move_ = false;
  bool stops_never_rest_ = false;
  int enable_delay_reads_ = 0;
  bool alarm_persists_ = false;
  struct BlockRule {
    CardCall kind = CardCall::kAxisStatus;
    int remaining = 0;  // calls still to hang; < 0 = every call until released; 0 = no rule
    int block_ms = -1;  // < 0 = until released
  };
  BlockRule block_;
  std::uint64_t release_generation_ = 0;  // bumped by release_blocked_calls()
  std::size_t blocked_now_ = 0;
  std::array<int, kCardCallKinds> drop_calls_{};
  std::array<int, kCardCallKinds> fail_after_calls_{};
  bool call_applied_ = true;  // the call being logged was applied
  std::int64_t silent_until_ns_ = -1;
  std::vector<CardCallRecord> log_;
  std::vector<Axis> axes_;
  CardFailure last_;
};

}  // namespace ajar::drivers
