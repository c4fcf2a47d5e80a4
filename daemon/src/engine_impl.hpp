// Internal to the engine's sources: EngineImpl, the Engine behind make_engine(). It owns the
// procedure, the control loop, the state store and two collaborators: WheelMotions (the wheel
// motions handed to the loop, wheel_motions.hpp) and ArmTask (the arm, its task and the arm
// interlock, arm_task.hpp); it decides, latches faults and emits every event. Three files by job:
// lifecycle, sessions' views and the read batch (engine.cpp), the commands (engine_commands.cpp),
// the loop's reports, the arm's verdicts, faults, events and persistence (engine_reports.cpp).
// docs/procedure.md and docs/control-loop.md describe the behaviour.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "ajar/core/geometry.hpp"
#include "ajar/daemon/blackbox.hpp"
#include "ajar/daemon/config.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/loop_supervisor.hpp"
#include "ajar/daemon/procedure.hpp"
#include "ajar/daemon/realtime.hpp"
#include "ajar/daemon/state_store.hpp"
#include "ajar/daemon/wire_model.hpp"
#include "ajar/recorder/recorder.hpp"
#include "ajar/version.hpp"
#include "arm_task.hpp"
#include "driver_wire.hpp"
#include "wheel_motions.hpp"

namespace ajar::daemon::detail {

using protocol::EventKind;
using protocol::MessageType;
using protocol::ProcedureState;

inline core::CameraToBase camera_to_base_or_throw(const Config& config) {
  auto t = core::CameraToBase::from_matrix(config.camera_to_base_m);
  if (!t) {
    throw StartupError("camera_to_base_m: " + t.error().message + " (" + t.error().field + ")");
  }
  return *t;
}

inline ControlLoopSettings loop_settings(const Config& c) {
  ControlLoopSettings s;
  s.control = c.control;
  s.safety = c.safety;
  s.recovery_timeout_s = std::max(0.1, c.drivers.card.poll_timeout_ms / 1000.0);
  s.card_time_scale = c.drivers.kind == drivers::DriverKind::kReal ? 1.0 : c.drivers.sim_speedup;
  s.base = c.base;
  s.drive = c.drive;
  return s;
}

inline std::string describe(const Error& e) {
  std::string s(to_string(e.code));
  if (!e.field.empty()) s += " (" + e.field + ")";
  if (!e.message.empty()) s += ": " + e.message;
  return s;
}

class EngineImpl final : public Engine {
 public:
  EngineImpl(const Config& config, drivers::DriverSet drivers, EngineOptions options);

  ~EngineImpl() override { shutdown(); }

  void set_event_sink(EventSink sink) override { sink_ = std::move(sink); }

  void start() override;

  // The shutdown's steps (engine.hpp): begin_shutdown() stops the motion and refuses all but the
  // stops from then on; seal_state() persists the clean-shutdown mark; shutdown() joins the loop
  // and brings the drivers down (after doing the steps itself when nobody did, waiting bounded).
  void begin_shutdown() override;
  bool wheels_at_rest() override;
  void seal_state() override;
  void shutdown() noexcept override;
  bool wedged() const noexcept override { return wedged_; }

  protocol::Message handle_command(const protocol::Message& request) override;

  void controller_heartbeat() noexcept override { loop_->heartbeat(now_ns()); }

  void controller_lost() override;

  void begin_read_batch() override { wheels_.begin_read_batch(); }

  void end_read_batch() override;

  void poll() override;

  void catch_up() override {
    drain_reports();
    flush();
  }

  protocol::Status status() const override;

  protocol::Telemetry telemetry() const override;

  protocol::Welcome welcome_template() const override;

  protocol::RobotModel robot_model() const override { return robot_model_of(config_); }

  bool control_loop_healthy() const noexcept override {
    return manual_loop_ || loop_->healthy(monotonic_now_ns());
  }

  std::uint64_t daemon_time_ns() const noexcept override {
    return static_cast<std::uint64_t>(now_ns() - start_ns_);
  }

  void run_loop_cycle() noexcept override {
    if (manual_loop_) loop_->cycle(now_ns());
  }

  std::vector<std::string> startup_warnings() const override { return startup_warnings_; }

  std::vector<std::string> take_warnings() override;
  recorder::Recorder* recorder() noexcept override { return recorder_.get(); }

  std::uint64_t accepted_generation() const noexcept override { return store_.submitted(); }
  std::uint64_t settled_generation() const noexcept override { return store_.settled(); }

 private:
  // ---- commands --------------------------------------------------------------------------------

  protocol::Message dispatch(const protocol::Message& request);

  template <typename T>
  protocol::Message answer(MessageType type, Result<T> result) {
    if (!result) return refuse(type, result.error());
    dirty_ = true;
    return ack(type, std::move(result).value());
  }

  protocol::Message ack(MessageType type, protocol::AckBody body);

  static protocol::Message refuse(MessageType type, const Error& e);

  protocol::Message align(MessageType type);

  // Drive (jog): a start opens a jog motion, later ones update its velocity (docs/procedure.md).
  protocol::Message drive(MessageType type, const protocol::Drive& m);

  // Approach: one straight trapezoidal move to `standoff_m` from the door plane.
  protocol::Message approach(MessageType type, const protocol::Approach& m);

  static Error queue_full();

  // Whether Drive (jog = true) or Approach may move the base now.
  Outcome check_base_may_drive(bool jog);
  // The forward jog's door guard (docs/procedure.md, "Driving"): what the door the procedure
  // knows asks of the loop now; posted to it when it changed (false: the queue is full); the
  // refusal of a straight-forward Drive at the standoff; the sentence of motion_started.
  DoorGuard door_guard() const;
  bool sync_door_guard() { return wheels_.sync_door_guard(door_guard()); }
  Outcome check_door_guard(const protocol::Drive& m) const;
  std::string door_guard_clause() const;

  template <typename Message>
  void fill_motion(const LoopSnapshot& snap, Message& m) const {
    m.odometry_x_m = snap.pose.x_m;
    m.odometry_y_m = snap.pose.y_m;
    m.door = procedure_.door(snap.pose);
    m.staleness = procedure_.staleness(snap.pose);
    m.commanded_linear_m_s = snap.commanded.linear_m_s;
    m.commanded_angular_rad_s = snap.commanded.angular_rad_s;
  }

  protocol::Message engage(MessageType type);

  void stop_motion();

  protocol::Message stop(MessageType type);

  protocol::Message emergency_stop(MessageType type);

  // With a fault latched: recovers the arm here and the card in the loop (recover request with a
  // fresh sequence number; the loop answers exactly that sequence), then clears the fault.
  protocol::Message reset(MessageType type, const protocol::Reset& r);

  // ---- reports and the arm ---------------------------------------------------------------------

  // Every wheel motion the engine announced (motion_started) is closed by exactly one event, from
  // the loop's terminal report for that motion id.
  void drain_reports();

  // A wheel motion that never turned a wheel (refused or cancelled): the plane still holds.
  void close_unstarted_move(std::uint32_t motion_id, ErrorCode code, bool cancelled);

  // A move held for the end of this read is dropped: no wheel has turned.
  void cancel_held_move(ErrorCode code);

  std::string reason(ErrorCode code) const;

  // The arm (ArmTask::supervise_stop, supervise_task): its task done, or a fault to latch.
  void supervise_arm();

  // Closes the open arm task with `kind` (an event), if one is open.
  void end_arm_motion(EventKind kind, const std::string& detail);

  // Tells the arm to stop (ArmTask::stop: a confirmation is awaited unless a fault is latched).
  void stop_arm() { arm_.stop(now_ns(), procedure_.fault() != ErrorCode::kOk); }

  // Backstop when reports were dropped (report queue full): the snapshot is authoritative.
  void reconcile();

  // A stall the loop supervisor latched since the last call: LOOP_STALLED (first in
  // drain_reports(), so that it is the root cause of what the loop reports after it); what its
  // out-of-band stop answered goes to the journal (take_warnings()).
  void take_stall();

  // ---- faults, events, persistence -------------------------------------------------------------

  // A fault latches once (the first is the root cause): the procedure's motion phases end, the arm
  // is told to stop (an open arm task is closed), and the latch is announced once (fault_latched
  // event, and a warning for the journal through take_warnings()).
  void latch(ErrorCode code, const std::string& detail);

  void emit(EventKind kind, ErrorCode fault, const std::string& detail);
  // What moves the base now (Status, Telemetry, Event; protocol 1.2).
  protocol::BaseMotion base_motion() const;

  void flush();

  // Hands the record to the state store's writer thread (never waits on the disk). Failures come
  // back through take_warnings().
  void persist();

  // Before the writer thread starts. A file that cannot be read, decoded or validated is moved
  // aside (ajard.state.rejected-<time>) and the procedure starts without its measurements, but
  // never without a fault: the file's own latched fault if it could be decoded, else
  // STATE_REJECTED. A file without the clean-shutdown mark (the previous run crashed, or an older
  // ajard wrote it) latches UNCLEAN_SHUTDOWN. The first latched stays (root cause); each is a
  // startup warning. No file (a first start): nothing latches.
  void restore();

  void reject_state_file(std::string warning);

  // A fault found at start (nothing runs yet, nobody listens): latched, and said in the startup
  // warnings.
  void latch_at_start(ErrorCode code, const std::string& why);

  std::int64_t now_ns() const noexcept { return clock_(); }

  // Lifecycle policy for the card (waits allowed): only while the control thread is not running.
  void bring_down_card() noexcept;

  Config config_;
  // The control loop's cycles are stamped with clock_ (the daemon's clock, or a test's clock that
  // also drives the loop by hand): Telemetry can carry the time its wheels were sampled.
  bool loop_on_engine_clock_ = true;
  std::function<std::int64_t()> clock_;
  bool manual_loop_ = false;
  std::shared_ptr<void> keepalive_;                   // first: outlives the drivers
  std::unique_ptr<drivers::ManagedMotionCard> card_;  // outlives the loop that drives it
  std::unique_ptr<recorder::Recorder> recorder_;      // outlives the loop that feeds it
  std::unique_ptr<ControlLoop> loop_;
  std::unique_ptr<LoopSupervisor> supervisor_;  // runs while the loop's thread does
  std::uint32_t stalls_seen_ = 0;  // the supervisor's stalls() and stops() already taken
  std::uint32_t stall_stops_seen_ = 0;
  ArmTask arm_;  // after loop_: tells it whether the arm may be at the door
  Procedure procedure_;
  StateStore store_;
  std::int64_t start_ns_;
  EventSink sink_;
  WheelMotions wheels_;

  bool started_ = false;
  bool shutting_down_ = false;  // begin_shutdown(): only stops are executed
  bool sealed_ = false;         // seal_state(): records carry the clean-shutdown mark
  bool stopped_ = false;
  bool wedged_ = false;  // shutdown(): the control thread did not end (a card call hung)
  bool restored_ = false;
  bool dirty_ = false;
  bool unstopped_told_ = false;  // the loop's LoopSnapshot::unstopped, as last told the journal
  std::uint32_t recover_sequence_ = 0;  // the last recover request sent to the loop
  std::string stop_reason_;             // why every motion is stopping (shutdown), else empty
  ProcedureState last_state_ = ProcedureState::kAwaitingWidth;
  std::vector<std::string> startup_warnings_;
  std::vector<std::string> warnings_;
  // The recorder's warnings (from its thread), for take_warnings().
  std::shared_ptr<std::pair<std::mutex, std::vector<std::string>>> recorder_warnings_ =
      std::make_shared<std::pair<std::mutex, std::vector<std::string>>>();
};

}  // namespace ajar::daemon::detail
