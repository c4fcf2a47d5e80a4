// ControlLoop: the fixed-rate control thread. It owns the motion card (the vendor API is not
// thread-safe: after start() only the control thread touches it) and supervises the wheels.
//
// Every cycle (cycle(), noexcept, no allocation, no locks, no logging), in this order:
//   1. stop requests (atomic flags, never lost, never refused): emergency stop, fault stop
//      (controller lost), smooth stop, recover (Reset). An emergency stop reaches the card in the
//      cycle that sees it, i.e. within one loop period.
//   2. queued commands (bounded lock-free SPSC queue; the I/O thread is the single producer):
//      moves. A move is refused (report kMoveRefused) while a fault is latched or a motion runs.
//   3. axis status of both wheels: odometry, supervision of a running motion (alarm, following
//      error, limits, card not answering, deadman, motion deadline -> smooth stop + latched fault;
//      completion = both axes at rest and in position), end of a stop (both at rest, or an
//      emergency stop when the stop itself overruns its deadline).
//   4. the published snapshot (seqlock). The thread then records the cycle's timing (deadline,
//      wake-up, end) in statistics(): readable from any other thread.
// Reports (motion finished/stopped, move refused, fault, recovered) go back through a second
// bounded SPSC queue (the loop is the single producer); if it is full the report is dropped and
// counted in the snapshot, whose `fault` and `motion_active` stay authoritative.
//
// The loop latches faults itself (no move starts until a recover request), independent of the
// engine's own latch: a belt and braces for races between a report and a new command.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <boost/lockfree/spsc_queue.hpp>

#include "ajar/core/robot_model.hpp"
#include "ajar/daemon/loop_statistics.hpp"
#include "ajar/daemon/seqlock.hpp"
#include "ajar/drivers/lifecycle.hpp"

namespace ajar::daemon {

struct ControlLoopSettings {
  double rate_hz = 500;
  bool realtime = false;
  int priority = 80;
  bool lock_memory = false;
  double deadman_timeout_s = 0.5;
  double motion_timeout_margin_s = 2.0;
  core::BaseGeometry base;
};

// A coordinated relative move of both wheels (counts include each axis' polarity, as from
// core::wheel_command).
struct MoveCommand {
  std::uint32_t motion_id = 0;
  std::int64_t left_counts = 0;
  std::int64_t right_counts = 0;
};

enum class LoopReportKind : std::uint8_t {
  kMotionFinished = 0,  // both axes in position
  kMotionStopped = 1,   // a motion ended early (stop, fault, emergency stop); wheels at rest
  kMoveRefused = 2,     // a queued move did not start (code says why)
  kFault = 3,           // a fault latched in the loop (code)
  kRecovered = 4,       // a recover request completed; kOk or the code that made it fail
};

struct LoopReport {
  LoopReportKind kind = LoopReportKind::kFault;
  ErrorCode code = ErrorCode::kOk;
  std::uint32_t motion_id = 0;
  int axis = 0;  // the offending axis for axis faults, 0 otherwise
};

// What the loop publishes every cycle.
struct LoopSnapshot {
  std::uint64_t cycles = 0;
  std::int64_t time_ns = 0;                        // CLOCK_MONOTONIC of the cycle
  std::int64_t left_counts = 0, right_counts = 0;  // encoder counts as read
  double left_wheel_rad = 0, right_wheel_rad = 0;  // since start, wheel-forward positive
  double base_yaw_rad = 0;                         // since start, CCW positive
  bool moving = false;                             // an axis reports profile motion
  bool motion_active = false;                      // a motion (or its stop) is being supervised
  ErrorCode fault = ErrorCode::kOk;                // latched in the loop
  drivers::LifecycleState card_state = drivers::LifecycleState::kUnconfigured;
  std::uint64_t reports_dropped = 0;
};

// Trapezoid profile for the wheels from the base's wheel speed/acceleration limits (rad/s,
// rad/s^2 at the wheel) converted to motor counts/ms and counts/ms^2.
drivers::TrapezoidProfile wheel_profile(const core::BaseGeometry& base) noexcept;
// Planned duration (s) of a trapezoidal (or triangular) move of `distance_counts`.
double planned_duration_s(std::int64_t distance_counts,
                          const drivers::TrapezoidProfile& profile) noexcept;

class ControlLoop {
 public:
  static constexpr std::size_t kCommandQueueCapacity = 32;
  static constexpr std::size_t kReportQueueCapacity = 256;

  ControlLoop(std::unique_ptr<drivers::ManagedMotionCard> card,
              const ControlLoopSettings& settings);
  ~ControlLoop();  // stop_thread()
  ControlLoop(const ControlLoop&) = delete;
  ControlLoop& operator=(const ControlLoop&) = delete;

  // ---- start-up / shut-down (I/O thread, while the loop thread is not running) ----
  Status bring_up();           // card: configure -> activate
  void bring_down() noexcept;  // card: smooth stop, deactivate -> cleanup
  // Starts the control thread; returns the realtime warnings (refused SCHED_FIFO / mlockall).
  std::vector<std::string> start_thread();
  void stop_thread() noexcept;  // asks the thread to exit and joins it. Idempotent.

  // ---- I/O thread ----
  bool post_move(const MoveCommand& move) noexcept;  // false: queue full (nothing queued)
  void request_stop() noexcept;
  void request_emergency_stop() noexcept;
  void request_fault_stop(ErrorCode code) noexcept;  // stop anything moving, latch `code`
  void request_recover() noexcept;                   // clear the loop's latch, recover the card
  void set_arm_moving(bool moving) noexcept;         // the deadman also watches the arm
  bool pop_report(LoopReport& report) noexcept;

  // ---- any thread ----
  void heartbeat(std::int64_t now_ns) noexcept;  // the controller is alive
  LoopSnapshot snapshot() const noexcept { return published_.load(); }
  // The loop's timing (wake-up latency, execution time, period); see loop_statistics.hpp.
  LoopStatisticsRecorder& statistics() noexcept { return statistics_; }
  const LoopStatisticsRecorder& statistics() const noexcept { return statistics_; }
  // True while the thread completes cycles: the last one ended within max(10 periods, 20 ms).
  bool healthy(std::int64_t now_ns) const noexcept;

  // ---- control thread (or a test driving the loop by hand, without start_thread()) ----
  void cycle(std::int64_t now_ns) noexcept;

 private:
  enum class Motion : std::uint8_t { kIdle, kMoving, kStopping };

  void thread_main(std::int64_t first_deadline_ns) noexcept;
  void handle_requests(std::int64_t now_ns) noexcept;
  void start_move(const MoveCommand& move, std::int64_t now_ns) noexcept;
  void begin_stop(std::int64_t now_ns) noexcept;
  void latch(ErrorCode code, int axis) noexcept;
  void finish(LoopReportKind kind, ErrorCode code) noexcept;
  void report(const LoopReport& r) noexcept;
  void read_axes() noexcept;
  void supervise(std::int64_t now_ns) noexcept;

  std::unique_ptr<drivers::ManagedMotionCard> card_;
  ControlLoopSettings settings_;
  int axes_[2];
  drivers::TrapezoidProfile profile_;
  std::int64_t period_ns_;
  std::int64_t deadman_ns_;
  std::int64_t stop_timeout_ns_;

  // I/O thread -> loop.
  boost::lockfree::spsc_queue<MoveCommand, boost::lockfree::capacity<kCommandQueueCapacity>>
      commands_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> emergency_stop_requested_{false};
  std::atomic<std::uint16_t> fault_stop_code_{0};
  std::atomic<bool> recover_requested_{false};
  std::atomic<bool> arm_moving_{false};
  std::atomic<std::int64_t> heartbeat_ns_{0};
  std::atomic<bool> exit_requested_{false};

  // Loop -> I/O thread.
  boost::lockfree::spsc_queue<LoopReport, boost::lockfree::capacity<kReportQueueCapacity>> reports_;
  SeqLock<LoopSnapshot> published_;
  std::atomic<std::int64_t> last_cycle_end_ns_{0};
  std::atomic<bool> thread_running_{false};

  // Loop-private state.
  Motion motion_ = Motion::kIdle;
  std::uint32_t motion_id_ = 0;
  std::int64_t motion_deadline_ns_ = 0;
  std::int64_t target_counts_[2] = {0, 0};
  std::int64_t snapshot_profile_counts_[2] = {0, 0};  // last profile positions read
  bool seen_moving_ = false;
  drivers::AxisStatus status_[2];  // read at the start of this cycle
  bool answered_ = false;
  ErrorCode read_error_ = ErrorCode::kOk;
  ErrorCode fault_ = ErrorCode::kOk;
  ErrorCode stop_reason_ = ErrorCode::kOk;
  bool have_origin_ = false;
  std::int64_t origin_counts_[2] = {0, 0};
  std::uint64_t reports_dropped_ = 0;
  LoopStatisticsRecorder statistics_;
  LoopSnapshot snapshot_;

  std::thread thread_;
};

}  // namespace ajar::daemon
