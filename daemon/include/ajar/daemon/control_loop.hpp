// ControlLoop: the fixed-rate control thread. It drives the wheels through the narrow
// drivers::MotionCard interface only (the vendor API is not thread-safe: between start_thread() and
// stop_thread() only the control thread touches the card). Lifecycle policy (configure, activate,
// deactivate, cleanup, with their waits) is not the loop's: the engine runs it at start-up and
// shut-down while the thread is not running.
//
// One ordered command path (the I/O thread is the single producer):
//   - moves, jog (Drive) commands and Reset's recover requests go through one bounded lock-free
//     SPSC queue, in order;
//   - stops never wait in that queue and can never be refused by it: request_stop(),
//     request_emergency_stop() and request_fault_stop() bump atomic generation counters (and a
//     fault stop queues its code in a second small queue, with a first-wins overflow slot), which
//     every cycle checks first. Each queued command is stamped with the generations current when it
//     was posted, so the loop discards every move posted before the latest stop (report
//     kMoveCancelled) and every recover posted before the latest emergency/fault stop (it is
//     answered with the fault that superseded it). A stop therefore acts within one period and is
//     never overtaken by anything queued before it, even when the queue is full.
//
// Every cycle (cycle(), noexcept, no allocation, no locks, no waiting, no logging), in this order:
//   1. axis status of both wheels (odometry; the wheels' measured velocity from the encoder
//      deltas; what supervision and a new move start from);
//   2. stops: emergency stop (card emergency stop in this cycle; re-sent every cycle until the
//      card takes it), a stall the loop supervisor latched (card emergency stop, latch
//      kLoopStalled), fault stops (smooth stop, latch the code: the first latched code is the one
//      reported and kept), smooth stop (also of a jog);
//   3. one step of a running recovery (Reset), a state machine advanced once per cycle: wait for
//      the wheels to rest, clear faults, enable the axes, then poll their status every cycle until
//      the servo is on without alarm, or fail at recovery_timeout_s. While it runs the command
//      queue waits (moves queued behind a Reset start after it); stops still act at once;
//   4. queued commands, in order (stops re-checked before each): a move or a jog start is refused
//      (kMoveRefused) while a fault is latched in the loop, a motion runs, or this cycle's axis
//      status could not be read; cancelled (kMoveCancelled) when a stop was posted after it. A jog
//      update sets the running jog's target velocity (dropped when that jog already ended or a
//      stop was posted after it). A recover starts the recovery (step 3). A move or jog call the
//      card answers with an error latches it and emergency-stops the wheels (the card may have
//      taken the command before it failed);
//   4b. a running jog: the target is the last Drive velocity while it is younger than
//      drive.command_timeout_s, else zero; the door guard (DoorGuard) lowers a forward target so
//      that the base stops at the door's standoff; the speed limiter (core::limit_velocity) clamps
//      speed and acceleration; the card gets the wheel velocities when they change. Once the card
//      has been told zero (the limited command zero) the jog has a deadline to come to rest; when
//      the Drive asks for nothing (zero, or timed out) and the wheels rest it ends
//      (kMotionFinished; command_timeout says whether the timeout ended it);
//   5. supervision: card not answering, alarm, following error, limits, deadman -> smooth stop +
//      latched fault; every motion's deadline (a move: its planned duration; a jog: coming to rest
//      once told zero; a stop: its deceleration) and a card that does not do what it was told (the
//      measured wheel velocity outside what the card was told for longer than
//      velocity_mismatch_s, or the wheels moving while no motion runs) -> emergency stop +
//      latched fault; completion (both axes at rest and in position); end of a stop (both at
//      rest). A stop the card refused is re-sent (as an emergency stop) every cycle;
//   6. the published snapshot (seqlock). The thread then records the cycle's timing (deadline,
//      wake-up, end) in statistics(): readable from any other thread. Around its sleep until the
//      next deadline a SCHED_OTHER thread publishes sleep_record() (its planned wake-up and its own
//      schedstat, one pread; "awake" when it wakes): the loop supervisor's exact wait for a CPU. A
//      realtime thread (SCHED_FIFO/RR at its start) publishes nothing: no wait of it is excused.
// Limits are computed from what the card is told: a move's trapezoid comes from its profile
// (move_profile(): the wheel limits, and the body's drive limits for anything but an exact turn in
// place); its deadline from that same trapezoid; a jog's velocities from the limiter and its ramp
// from jog_profile(); a stop's deadline from the running motion's deceleration and speed.
// Card errors on this path are ErrorCodes only; text is made on the I/O side.
//
// Odometry (read_axes, every cycle the card answers): the planar pose by dead reckoning from the
// encoder deltas (core::integrate_odometry), in the frame of the base at daemon start.
//
// Reports (motion finished/stopped, move refused/cancelled, fault, recovered) go back through a
// second bounded SPSC queue (the loop is the single producer); if it is full the report is dropped
// and counted in the snapshot, whose fault, motion and recover fields stay authoritative.
// Every move posted gets exactly one terminal report: kMotionFinished, kMotionStopped,
// kMoveRefused or kMoveCancelled. Every recover request gets exactly one kRecovered with its
// sequence number. kFault reports carry the sequence of the last recover the loop had taken when
// the fault latched, so the engine can tell a fault that a later Reset already cleared.
//
// The loop latches faults itself (no move starts until a recover), independent of the engine's
// own latch: belt and braces for races between a report and a new command.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include <boost/lockfree/spsc_queue.hpp>

#include "ajar/core/driving.hpp"
#include "ajar/core/robot_model.hpp"
#include "ajar/daemon/card_recovery.hpp"
#include "ajar/daemon/config.hpp"
#include "ajar/daemon/loop_statistics.hpp"
#include "ajar/daemon/seqlock.hpp"
#include "ajar/daemon/thread_schedule.hpp"
#include "ajar/drivers/lifecycle.hpp"
#include "ajar/drivers/motion_card.hpp"

namespace ajar::recorder {
class Recorder;
}

namespace ajar::daemon {

struct ControlLoopSettings {
  ControlConfig control;  // rate_hz, realtime, priority, lock_memory, motion_timeout_margin_s
  SafetyConfig safety;    // deadman_timeout_s
  double recovery_timeout_s = 2.0;  // a recovery must see the servo on within this
  // A card that does not do what it was told: a wheel's measured velocity (encoder deltas) outside
  // what the card was told, by more than velocity_tolerance (a fraction of the wheel speed limit,
  // plus velocity_lag_s of the motion's acceleration and two encoder counts per cycle), for longer
  // than velocity_mismatch_s -> emergency stop, kVelocityMismatch.
  double velocity_tolerance = 0.1;
  double velocity_lag_s = 0.1;
  double velocity_mismatch_s = 0.2;
  // A simulated card (drivers.sim.speedup) runs this much faster than the loop's clock: the card's
  // velocities and durations (a move's planned time, a ramp) are in its time, converted here.
  double card_time_scale = 1.0;
  core::BaseGeometry base;
  core::DriveLimits drive;  // jog limits and command timeout; the straight move's speed
};

// A coordinated relative move of both wheels (counts include each axis' polarity, as from
// core::wheel_command). kTurn uses the wheel limits (base.max_wheel_*); kStraight (Approach) also
// keeps the body within drive.max_linear_speed_m_s / max_linear_accel_m_s2. The command reaches
// the loop whole (profile included): move_profile() makes the card's trapezoid from it.
enum class MoveProfile : std::uint8_t { kTurn = 0, kStraight = 1 };
struct MoveCommand {
  std::uint32_t motion_id = 0;
  std::int64_t left_counts = 0;
  std::int64_t right_counts = 0;
  MoveProfile profile = MoveProfile::kTurn;
};

// A jog (Drive) command. `start` opens a new jog motion `motion_id` (refused while another motion
// runs); otherwise it updates the running jog with that id. Valid from `stamp_ns` (the loop's
// clock) for drive.command_timeout_s.
struct DriveCommand {
  std::uint32_t motion_id = 0;
  bool start = false;
  core::BodyVelocity velocity;
  std::int64_t stamp_ns = 0;
};

// The forward jog's door guard (issue 23; docs/control-loop.md "Jog"), posted by the engine
// whenever the door it knows changes. kStandoff (a fresh door distance): a jog's forward speed is
// limited every cycle, from the loop's own odometry, so that the base origin can stop at
// `standoff_m` from the door (the card's jog ramp, a reaction time of three periods), and to zero
// there. kStale (the distance is no longer trusted): forward jog speed at most stale_speed_m_s.
// Backward and turning are never limited. A hard bound too: a base that goes on toward the door
// more than 3 mm past the standoff (a card that did not apply the limit or a stop) is
// emergency-stopped (kVelocityMismatch), in a jog, a move or a stop.
struct DoorGuard {
  enum class Mode : std::uint8_t { kNone = 0, kStandoff = 1, kStale = 2 };
  Mode mode = Mode::kNone;
  core::DoorLine line;  // kStandoff: the door in the odometry frame
  double standoff_m = 0;
  double stale_speed_m_s = 0;
  friend bool operator==(const DoorGuard&, const DoorGuard&) = default;
};

// kStandoff: how far the base origin may still travel along its heading before it is standoff_m
// from the door (<= 0: there or closer); +infinity when forward does not lead toward the door, or
// for any other mode.
double door_guard_room_m(const DoorGuard& guard, const core::PlanarPose& pose) noexcept;

enum class LoopReportKind : std::uint8_t {
  kMotionFinished = 0,  // both axes in position
  kMotionStopped = 1,   // a motion ended early (stop, fault, emergency stop); wheels at rest
  kMoveRefused = 2,     // a queued move did not start (code says why); the wheels did not turn
  kFault = 3,           // a fault latched in the loop (code; sequence = last recover taken)
  kRecovered = 4,       // recover `sequence` ended: kOk, or the code that made it fail
  kMoveCancelled = 5,   // a stop posted after this move cancelled it (code: the stop's reason);
                        // the wheels did not turn
};

struct LoopReport {
  LoopReportKind kind = LoopReportKind::kFault;
  ErrorCode code = ErrorCode::kOk;
  std::uint32_t motion_id = 0;
  int axis = 0;                  // the offending axis for axis faults, 0 otherwise
  std::uint32_t sequence = 0;    // kRecovered: its recover; kFault: the last recover taken
  bool command_timeout = false;  // kMotionFinished of a jog: no Drive came within the timeout
};

// What the loop publishes every cycle.
struct LoopSnapshot {
  std::uint64_t cycles = 0;
  std::int64_t time_ns = 0;                        // the clock of the cycle
  std::int64_t left_counts = 0, right_counts = 0;  // encoder counts as read
  double left_wheel_rad = 0, right_wheel_rad = 0;  // since start, wheel-forward positive
  double base_yaw_rad = 0;                         // since start, CCW positive
  core::PlanarPose pose;                           // odometry (yaw as base_yaw_rad)
  core::BodyVelocity commanded;                    // the jog's limited velocity; 0 otherwise
  // The door guard lowered a running jog's forward speed this cycle (to guard_limit_m_s).
  bool guard_limiting = false;
  double guard_limit_m_s = 0;
  bool moving = false;  // an axis reports profile motion
  // After a stop: until then the card may still be bringing the wheels to rest (its stop time from
  // the top speed it was told), whatever its status says (a status can lag). The engine hands the
  // arm no task before it (docs/procedure.md, "The arm interlock").
  std::int64_t rest_not_before_ns = 0;
  bool motion_active = false;          // a motion (or its stop) is being supervised
  bool jogging = false;                // that motion is a jog
  std::uint32_t last_motion_id = 0;    // the last motion that ended (any terminal report)
  ErrorCode fault = ErrorCode::kOk;    // latched in the loop
  std::uint32_t recover_sequence = 0;  // the last recover request taken from the queue
  bool recovering = false;             // that recovery is still running
  // The card as the loop sees it: kFault while the last status read failed or a card fault is
  // latched, kActive while both wheel axes report servo on, else kInactive.
  drivers::LifecycleState card_state = drivers::LifecycleState::kInactive;
  std::uint64_t reports_dropped = 0;
  // The wheels still turn (encoders) velocity_mismatch_s after an emergency stop the card took:
  // the loop switches their servos off every cycle (MotionCard::disable_axes) until they rest, and
  // a Reset is refused meanwhile. The robot's hardware emergency stop is the backstop.
  bool unstopped = false;
};

// Trapezoid profile for the wheels from the base's wheel speed/acceleration limits (rad/s,
// rad/s^2 at the wheel) converted to motor counts/ms and counts/ms^2.
drivers::TrapezoidProfile wheel_profile(const core::BaseGeometry& base) noexcept;
// The straight (Approach) profile: the wheel profile, slower where the body limits ask for it.
drivers::TrapezoidProfile straight_profile(const core::BaseGeometry& base,
                                           const core::DriveLimits& drive) noexcept;
// The trapezoid the card gets for `move`: straight_profile() for kStraight and for any move whose
// counts are not an exact turn in place (the wheels not exactly opposite, polarity removed), else
// wheel_profile().
drivers::TrapezoidProfile move_profile(const MoveCommand& move, const core::BaseGeometry& base,
                                       const core::DriveLimits& drive) noexcept;
// The jog's ramp at the card (acceleration = deceleration, counts/ms^2): the largest wheel
// acceleration the drive limits allow, (max_linear_accel + max_angular_accel * R_B) / R_W, and
// never above base.max_wheel_accel_rad_s2. The limiter's steps keep the body within the drive
// limits over every period; the card ramps each step (and a smooth stop) at this rate.
drivers::JogProfile jog_profile(const core::BaseGeometry& base,
                                const core::DriveLimits& drive) noexcept;
// Planned duration (s) of a trapezoidal (or triangular) move of `distance_counts`.
double planned_duration_s(std::int64_t distance_counts,
                          const drivers::TrapezoidProfile& profile) noexcept;

// The control loop's running jog (ControlLoop, step 4b), on the control thread (noexcept, no
// allocation). Every cycle step() takes the last Drive velocity while it is younger than
// drive.command_timeout_s (else zero), lowers a forward target to what the door guard allows from
// where the base is, clamps speed and acceleration (core::limit_velocity), and says whether the
// card gets new wheel velocities; the loop makes the card call and tells sent(). Also the card's
// ramp toward what it was told (the velocity check's band) and when the jog, told zero, starts
// coming to rest. After a late cycle (a starved thread) the limiter steps at most 10 periods'
// worth, while the card's ramp is followed over the whole time since the last step: the card ran
// on meanwhile.
class Jog {
 public:
  // `counts_per_wheel_rad`: motor counts per wheel radian; `card_scale`: card time per loop time.
  Jog(const ControlLoopSettings& settings, const drivers::JogProfile& profile,
      double counts_per_wheel_rad, double card_scale, std::int64_t period_ns) noexcept;

  void start(const DriveCommand& drive, std::int64_t now_ns) noexcept;  // from rest
  void update(const DriveCommand& drive) noexcept;  // a new target for the running jog
  void set_guard(const DoorGuard& guard) noexcept { guard_ = guard; }
  const DoorGuard& guard() const noexcept { return guard_; }
  const drivers::JogProfile& profile() const noexcept { return profile_; }

  // What this cycle's step found.
  struct Step {
    bool guard_limiting = false;  // the door guard lowered the forward speed (to guard_limit_m_s)
    double guard_limit_m_s = 0;
    bool send = false;  // the card gets `axes` now (MotionCard::jog with profile())
    drivers::AxisVelocity axes[2];
    bool told_zero = false;         // the limited command is zero
    bool released = false;          // the operator asks for nothing (zero Drive or timeout)
    bool changed = false;           // the limited command changed this cycle
    bool ended_by_timeout = false;  // released by the timeout while the last Drive moved
    double rest_s = -1;             // >= 0: told zero just now; the wheels rest within this
  };
  Step step(std::int64_t now_ns, const core::PlanarPose& pose) noexcept;
  // The card took `axes`: returns the slowest stop of this jog from what it was told (s, at the
  // card's ramp).
  double sent(const drivers::AxisVelocity (&axes)[2]) noexcept;

  // The limited velocity last computed (0 once stopped).
  const core::BodyVelocity& command() const noexcept { return command_; }
  void zero_command() noexcept { command_ = {}; }
  void stopping() noexcept {  // a stop takes over: no command, no resting deadline of the jog's
    command_ = {};
    resting_ = false;
  }
  bool resting() const noexcept { return resting_; }  // told zero: the loop's deadline to rest runs

  // The velocity check's band for wheel `i` (counts/ms): between what the card was told and its
  // ramp toward it (in the card's time, up to the last step()).
  double band_low(int i) const noexcept {
    return std::min(told_counts_per_ms_[i], expected_counts_per_ms_[i]);
  }
  double band_high(int i) const noexcept {
    return std::max(told_counts_per_ms_[i], expected_counts_per_ms_[i]);
  }

  // The forward speed the door guard allows at `pose` (infinity: no limit).
  double guard_forward_limit_m_s(const core::PlanarPose& pose) const noexcept;

 private:
  ControlLoopSettings settings_;
  drivers::JogProfile profile_;
  double counts_per_wheel_rad_;
  double card_scale_;
  std::int64_t period_ns_;
  std::int64_t timeout_ns_;  // drive.command_timeout_s
  double guard_accel_m_s2_;  // the door guard's braking: the limiter's and the card's ramp
  double guard_reaction_s_;  // the door guard's reaction time (three periods)
  int axes_[2];

  core::BodyVelocity target_;
  std::int64_t stamp_ns_ = 0;
  core::BodyVelocity command_;  // limited, last sent to the card
  std::int64_t last_ns_ = 0;    // the cycle that computed command_
  bool sent_ = false;           // the card has been given command_
  bool resting_ = false;        // told zero: the loop's motion deadline is its deadline to rest
  DoorGuard guard_;             // the last posted door guard
  double told_counts_per_ms_[2] = {0, 0};      // the jog velocities the card accepted last
  double expected_counts_per_ms_[2] = {0, 0};  // the card's ramp toward them (profile_)
};

class ControlLoop {
 public:
  static constexpr std::size_t kCommandQueueCapacity = 32;
  static constexpr std::size_t kFaultQueueCapacity = 16;
  static constexpr std::size_t kReportQueueCapacity = 256;

  // `card` must outlive the loop and be active (brought up by the caller).
  ControlLoop(drivers::MotionCard& card, const ControlLoopSettings& settings);
  ~ControlLoop();  // stop_thread()
  ControlLoop(const ControlLoop&) = delete;
  ControlLoop& operator=(const ControlLoop&) = delete;

  // ---- start-up / shut-down (I/O thread) ----
  // Starts the control thread; returns the realtime warnings (refused SCHED_FIFO / mlockall).
  std::vector<std::string> start_thread();
  void stop_thread() noexcept;  // asks the thread to exit and joins it. Idempotent.
  // The same, waiting at most `limit_ns` for the thread to end (a cycle stuck in a card call that
  // never returns): false when it did not; it is then not joined (and the loop must never be
  // destroyed: the process exits).
  bool stop_thread(std::int64_t limit_ns) noexcept;

  // ---- I/O thread (the single producer) ----
  bool post_move(const MoveCommand& move) noexcept;     // false: queue full (nothing queued)
  bool post_drive(const DriveCommand& drive) noexcept;  // false: queue full (nothing queued)
  // The door guard for jogs from the next command on (in order with moves and jogs).
  bool post_door_guard(const DoorGuard& guard) noexcept;  // false: queue full (nothing queued)
  // Starts a recovery (Reset): clears the loop's latch, recovers the card. Answered by exactly
  // one kRecovered report carrying `sequence`. false: queue full (nothing queued).
  bool request_recover(std::uint32_t sequence) noexcept;
  void request_stop() noexcept;                      // never refused
  void request_emergency_stop() noexcept;            // never refused; latches kEmergencyStopped
  void request_fault_stop(ErrorCode code) noexcept;  // never refused; stop, latch `code`
  void set_arm_moving(bool moving) noexcept;         // the deadman also watches the arm
  // The arm interlock's second line (the engine's checks are the first): while set, no move or jog
  // starts (kMoveRefused with kDriveNotAllowed). The engine sets it while the arm may be at the
  // door (docs/procedure.md, "The arm interlock"). Off for a loop without an engine.
  void set_arm_at_door(bool at_door) noexcept;
  bool pop_report(LoopReport& report) noexcept;

  // ---- any thread ----
  void heartbeat(std::int64_t now_ns) noexcept;  // the controller is alive
  LoopSnapshot snapshot() const noexcept { return published_.load(); }
  // The loop's timing (wake-up latency, execution time, period); see loop_statistics.hpp.
  LoopStatisticsRecorder& statistics() noexcept { return statistics_; }
  const LoopStatisticsRecorder& statistics() const noexcept { return statistics_; }
  // True while the thread completes cycles: the last one ended within max(10 periods, 20 ms).
  bool healthy(std::int64_t now_ns) const noexcept;
  // What the loop supervisor (loop_supervisor.hpp) watches: the thread runs (between
  // start_thread() and stop_thread()), and when its last cycle ended (CLOCK_MONOTONIC ns).
  bool thread_running() const noexcept { return thread_running_.load(std::memory_order_acquire); }
  std::int64_t last_cycle_end_ns() const noexcept {
    return last_cycle_end_ns_.load(std::memory_order_acquire);
  }
  // The control thread's kernel thread id (0 before start_thread()): the supervisor reads the
  // thread's scheduling statistics by it.
  int thread_tid() const noexcept { return thread_tid_.load(std::memory_order_acquire); }
  // What the control thread published of its sleep between cycles (thread_schedule.hpp): before
  // it sleeps, its planned wake-up and its own schedstat; awake as soon as it wakes (always, for a
  // thread that was realtime when it started: it publishes nothing). One attempt
  // at the seqlock: a read that overlaps the thread's store says awake (it was on a CPU then).
  LoopSleep sleep_record() const noexcept {
    LoopSleep sleep;
    return sleep_.try_load(sleep) ? sleep : LoopSleep{};
  }
  // The loop supervisor found the loop stalled (and stopped the card out of band). Never
  // refused, any thread: like a fault stop, it cancels what was posted before it and latches
  // kLoopStalled; the loop acts on it as soon as its stalled call returns: an in-band emergency
  // stop in the next handle_stops, and any fault the returning call reports before that is
  // latched as kLoopStalled (the root cause).
  void latch_stalled() noexcept;

  // ---- control thread (or a test driving the loop by hand, without start_thread()) ----
  void cycle(std::int64_t now_ns) noexcept;

  // The black box (recorder.hpp): set before start_thread() (nullptr: none). After each cycle the
  // thread hands it every loop_decimation-th cycle (commanded and measured wheels, motion, stop
  // generation, timing) through its lock-free ring: no allocation, lock or system call.
  void set_recorder(recorder::Recorder* recorder) noexcept { recorder_ = recorder; }

 private:
  enum class Motion : std::uint8_t { kIdle, kMoving, kJogging, kStopping };
  enum class CommandKind : std::uint8_t { kMove, kRecover, kDriveStart, kDriveUpdate, kDoorGuard };
  // A queued command: the posted MoveCommand or DriveCommand whole (nothing copied field by
  // field), or a recover sequence.
  struct Command {
    CommandKind kind = CommandKind::kMove;
    MoveCommand move;               // kMove
    DriveCommand drive;             // kDrive*
    DoorGuard guard;                // kDoorGuard
    std::uint32_t sequence = 0;     // kRecover
    std::uint32_t stop_stamp = 0;   // stop generation when posted
    std::uint32_t latch_stamp = 0;  // emergency/fault stop generation when posted
    std::uint32_t id() const noexcept {
      return kind == CommandKind::kMove      ? move.motion_id
             : kind == CommandKind::kRecover ? sequence
                                             : drive.motion_id;
    }
  };

  // Stamps `c` with the stop and latch generations current now and queues it (I/O thread).
  bool post(Command c) noexcept;
  void thread_main(std::int64_t first_deadline_ns) noexcept;
  // The cycle that just ran, for the recorder (control thread; reads loop-private state).
  void record_sample(std::int64_t deadline_ns, std::int64_t wake_ns, std::int64_t end_ns) noexcept;
  void handle_stops(std::int64_t now_ns) noexcept;
  void execute(const Command& command, std::int64_t now_ns) noexcept;
  void start_move(const Command& move, std::int64_t now_ns) noexcept;
  void start_jog(const Command& drive, std::int64_t now_ns) noexcept;
  ErrorCode check_can_start() noexcept;  // kOk, or why no motion may start in this cycle
  void advance_jog(std::int64_t now_ns) noexcept;
  // The door guard's hard bound: the base origin more than kDoorStandoffToleranceM past the
  // standoff and the wheels still driving it toward the door (whatever the motion).
  bool past_door_standoff() const noexcept;
  static constexpr double kDoorStandoffToleranceM = 0.003;
  void advance_recovery(std::int64_t now_ns) noexcept;
  void end_recovery(ErrorCode code) noexcept;
  // A smooth stop (an emergency stop when the card refuses it; the refusal latches).
  void begin_stop(std::int64_t now_ns) noexcept;
  // The card did not do what it was told (or answered an error to a command it may have taken):
  // latch `code`, emergency stop, supervise the wheels to rest.
  void emergency_fault(ErrorCode code, int axis, std::int64_t now_ns) noexcept;
  // The card's emergency stop; true when the card took it. From then on the wheels must come to
  // rest (their encoders) within velocity_mismatch_s, else check_stopped_wheels() switches their
  // servos off.
  bool send_emergency_stop(std::int64_t now_ns) noexcept;
  // Every cycle: wheels that still turn velocity_mismatch_s after an emergency stop the card took
  // (a card that accepts GT_Stop and does not apply it) get their servos switched off, every cycle
  // until they rest, and kVelocityMismatch latches.
  void check_stopped_wheels(std::int64_t now_ns) noexcept;
  // The wheels' measured velocity (encoders) is within the idle tolerance (unknown: false).
  bool encoders_at_rest() const noexcept;
  void enter_stopping(std::int64_t now_ns) noexcept;
  // kOk, or the axis whose measured velocity has been outside what the card was told for longer
  // than velocity_mismatch_s (or that moves while no motion runs).
  int check_velocity(std::int64_t now_ns) noexcept;
  void latch(ErrorCode code, int axis) noexcept;
  void finish(LoopReportKind kind, ErrorCode code, bool command_timeout = false) noexcept;
  bool moving() const noexcept { return motion_ == Motion::kMoving || motion_ == Motion::kJogging; }
  void report(const LoopReport& r) noexcept;
  void read_axes(std::int64_t now_ns) noexcept;
  void supervise(std::int64_t now_ns) noexcept;  // supervise_motion(), check_stopped_wheels()
  // The running motion's checks this cycle, by what runs (`silent`: no heartbeat for deadman_s).
  void supervise_motion(std::int64_t now_ns) noexcept;
  // A move or a jog: faults and the controller's silence stop it smoothly; deadlines and a card
  // that does not do what it was told, by an emergency stop; a move at rest where it was sent ends.
  void supervise_running(std::int64_t now_ns, bool silent) noexcept;
  // kOk, or why a running motion stops now: the card did not answer, an axis reports an alarm,
  // a following error or a limit (`axis`: which), or the controller is silent.
  ErrorCode running_fault(bool silent, int& axis) const noexcept;
  // What a card that did not answer this cycle's status read latches: its read error, or
  // CARD_COMMUNICATION.
  ErrorCode read_fault() const noexcept;
  // A move whose wheels rest in position (having moved, or at its target) is finished.
  void finish_move_at_rest() noexcept;
  // A stop: sent again until the card takes it, ended when the wheels rest or at its deadline;
  // a card that does not answer meanwhile, or a drive fault, latches (latch_card_fault()).
  void supervise_stopping(std::int64_t now_ns) noexcept;
  // Nothing runs: wheels that move anyway, a card that does not answer (read_fault()), an arm
  // moving while the controller is silent, drive alarms and following errors. (A recovery
  // watches the card itself.)
  void supervise_idle(std::int64_t now_ns, bool silent) noexcept;
  // What the card's lifecycle wrapper latches too, refusing every move until a Reset recovers
  // it, latched when it happens rather than at the next move: a status read that failed
  // (read_fault()), else the first axis reporting a drive alarm or a following error, with that
  // axis. Nothing during a recovery (it watches the card itself).
  void latch_card_fault() noexcept;
  drivers::LifecycleState card_state() const noexcept;

  drivers::MotionCard& card_;
  ControlLoopSettings settings_;
  int axes_[2];
  double counts_per_wheel_rad_;
  double max_wheel_counts_per_ms_;  // base.max_wheel_speed_rad_s at the card
  double card_scale_;               // card time per loop time (card_time_scale)
  std::int64_t period_ns_;
  std::int64_t deadman_ns_;
  std::int64_t margin_ns_;  // control.motion_timeout_margin_s
  std::int64_t mismatch_ns_;

  // I/O thread -> loop.
  boost::lockfree::spsc_queue<Command, boost::lockfree::capacity<kCommandQueueCapacity>> commands_;
  boost::lockfree::spsc_queue<ErrorCode, boost::lockfree::capacity<kFaultQueueCapacity>>
      fault_codes_;
  std::atomic<std::uint16_t> fault_overflow_code_{0};  // first code that found the queue full
  std::atomic<std::uint32_t> stop_generation_{0};      // every stop, emergency and fault stop
  std::atomic<std::uint32_t> latch_generation_{0};     // emergency and fault stops
  std::atomic<std::uint32_t> emergency_generation_{0};
  std::atomic<bool> stall_pending_{false};  // latch_stalled() not yet handled by the loop
  std::atomic<bool> arm_moving_{false};
  std::atomic<bool> arm_at_door_{false};
  std::atomic<std::int64_t> heartbeat_ns_{0};
  std::atomic<bool> exit_requested_{false};

  // Loop -> I/O thread.
  boost::lockfree::spsc_queue<LoopReport, boost::lockfree::capacity<kReportQueueCapacity>> reports_;
  SeqLock<LoopSnapshot> published_;
  std::atomic<std::int64_t> last_cycle_end_ns_{0};
  std::atomic<int> thread_tid_{0};
  SeqLock<LoopSleep> sleep_;  // sleep_record(); written by the control thread only
  std::atomic<bool> thread_running_{false};
  std::atomic<bool> thread_ended_{false};  // thread_main() returned

  // Loop-private state.
  std::uint32_t handled_stop_ = 0, handled_latch_ = 0, handled_emergency_ = 0;
  bool estop_pending_ = false;  // the card did not take the last emergency stop: sent again
  Motion motion_ = Motion::kIdle;
  std::uint32_t motion_id_ = 0;
  std::int64_t motion_deadline_ns_ = 0;  // move, jog coming to rest, stop
  // What the card was told for the running motion: the move's trapezoid (its speed and
  // deceleration also bound a stop's deadline), or the jog's velocities.
  drivers::TrapezoidProfile move_profile_;
  double stop_time_s_ = 0;  // the running motion's time to rest from its top speed, at the card
  bool stop_sent_ = false;  // kStopping: the card accepted the stop (else re-sent every cycle)
  // kStopping by a smooth stop the card took: each wheel's speed must follow its deceleration
  // from where it was when the stop began (check_velocity), else emergency stop.
  bool smooth_stop_ = false;
  std::int64_t stop_begin_ns_ = 0;
  double stop_from_counts_per_ms_[2] = {0, 0};  // |measured velocity| when the stop began
  double stop_dec_counts_per_ms2_ = 0;          // the stopping motion's deceleration at the card
  std::int64_t estop_taken_ns_ = -1;  // the card took an emergency stop the wheels have not obeyed
  std::int64_t target_counts_[2] = {0, 0};
  std::int64_t snapshot_profile_counts_[2] = {0, 0};  // last profile positions read
  bool seen_moving_ = false;
  drivers::AxisStatus status_[2];  // read at the start of this cycle
  bool answered_ = false;
  int refused_axis_ = 0;  // the axis check_can_start() refused for (0: none)
  ErrorCode read_error_ = ErrorCode::kOk;
  ErrorCode fault_ = ErrorCode::kOk;
  ErrorCode stop_reason_ = ErrorCode::kOk;
  CardRecovery recovery_;  // step 3: the card's recovery after a Reset
  bool have_origin_ = false;
  std::int64_t origin_counts_[2] = {0, 0};
  // The wheels' measured velocity (counts/ms, encoder deltas between two answered cycles).
  bool measured_valid_ = false;
  double measured_counts_per_ms_[2] = {0, 0};
  std::int64_t last_read_ns_ = 0;
  std::int64_t last_encoder_counts_[2] = {0, 0};
  std::int64_t mismatch_since_ns_[2] = {-1, -1};  // -1: the axis agrees
  double last_wheel_rad_[2] = {0, 0};             // for the odometry deltas
  Jog jog_;                                       // step 4b: the running jog (and the door guard)
  std::uint64_t reports_dropped_ = 0;
  LoopStatisticsRecorder statistics_;
  LoopSnapshot snapshot_;
  recorder::Recorder* recorder_ = nullptr;
  std::int64_t sample_last_wake_ns_ = 0;  // record_sample(): the previous cycle's wake-up ...
  std::int64_t sample_last_counts_[2][2] = {{0, 0}, {0, 0}};  // ... profile, encoder counts

  std::thread thread_;
};

}  // namespace ajar::daemon
