// The engine: procedure + control loop + arm + persistence, driven from the I/O thread.
// docs/procedure.md and docs/control-loop.md describe the behaviour; this file wires it up.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "ajar/core/geometry.hpp"
#include "ajar/daemon/config.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/procedure.hpp"
#include "ajar/daemon/realtime.hpp"
#include "ajar/daemon/state_store.hpp"
#include "ajar/daemon/wire_model.hpp"
#include "ajar/version.hpp"

namespace ajar::daemon {
namespace {

using protocol::EventKind;
using protocol::MessageType;
using protocol::ProcedureState;

core::CameraToBase camera_to_base_or_throw(const Config& config) {
  auto t = core::CameraToBase::from_matrix(config.camera_to_base_m);
  if (!t) {
    throw StartupError("camera_to_base_m: " + t.error().message + " (" + t.error().field + ")");
  }
  return *t;
}

ControlLoopSettings loop_settings(const Config& c) {
  ControlLoopSettings s;
  s.rate_hz = c.control.rate_hz;
  s.realtime = c.control.realtime;
  s.priority = c.control.priority;
  s.lock_memory = c.control.lock_memory;
  s.deadman_timeout_s = c.safety.deadman_timeout_s;
  s.motion_timeout_margin_s = c.control.motion_timeout_margin_s;
  s.recovery_timeout_s = std::max(0.1, c.drivers.card.poll_timeout_ms / 1000.0);
  s.base = c.base;
  s.drive = c.drive;
  return s;
}

// The words of the events that close a wheel motion.
const char* what_moves(bool jog, bool approach) {
  return jog ? "driving" : approach ? "approach" : "alignment";
}

protocol::DriverState to_wire(drivers::LifecycleState s) {
  switch (s) {
    case drivers::LifecycleState::kUnconfigured:
      return protocol::DriverState::kUnconfigured;
    case drivers::LifecycleState::kInactive:
      return protocol::DriverState::kInactive;
    case drivers::LifecycleState::kActive:
      return protocol::DriverState::kActive;
    case drivers::LifecycleState::kFault:
      return protocol::DriverState::kFault;
  }
  return protocol::DriverState::kFault;
}

protocol::ArmState to_wire(drivers::ArmPhase p) {
  switch (p) {
    case drivers::ArmPhase::kDisconnected:
      return protocol::ArmState::kDisconnected;
    case drivers::ArmPhase::kIdle:
      return protocol::ArmState::kIdle;
    case drivers::ArmPhase::kBusy:
      return protocol::ArmState::kBusy;
    case drivers::ArmPhase::kDone:
      return protocol::ArmState::kDone;
    case drivers::ArmPhase::kFault:
      return protocol::ArmState::kFault;
  }
  return protocol::ArmState::kFault;
}

enum class WheelKind : std::uint8_t { kAlign, kApproach, kJog };

std::string describe(const Error& e) {
  std::string s(to_string(e.code));
  if (!e.field.empty()) s += " (" + e.field + ")";
  if (!e.message.empty()) s += ": " + e.message;
  return s;
}

class EngineImpl final : public Engine {
 public:
  EngineImpl(const Config& config, drivers::DriverSet drivers, EngineOptions options)
      : config_(config),
        clock_(options.now_ns ? std::move(options.now_ns)
                              : std::function<std::int64_t()>([] { return monotonic_now_ns(); })),
        manual_loop_(options.manual_loop),
        keepalive_(std::move(drivers.keepalive)),
        procedure_(camera_to_base_or_throw(config), config.limits, config.base,
                   ProcedureLimits{config.control.aligned_tolerance_rad,
                                   config.drive.stale_travel_m, config.drive.stale_yaw_rad}),
        store_(config.state.directory,
               StateStore::Options{std::chrono::milliseconds(config.state.debug_write_delay_ms)}),
        start_ns_(clock_()) {
    if (!drivers.card || !drivers.arm) throw StartupError("drivers: card and arm are required");
    const int axes[2] = {config.base.left.card_axis, config.base.right.card_axis};
    card_ = std::make_unique<drivers::ManagedMotionCard>(std::move(drivers.card), axes, 5000,
                                                         config.drivers.card.poll_timeout_ms);
    loop_ = std::make_unique<ControlLoop>(*card_, loop_settings(config));
    arm_ = std::make_unique<drivers::ManagedManipulator>(std::move(drivers.arm));
  }

  ~EngineImpl() override { shutdown(); }

  void set_event_sink(EventSink sink) override { sink_ = std::move(sink); }

  void start() override {
    if (started_) return;
    store_.prepare();
    // Lifecycle policy (with its waits) runs here, before the control thread exists.
    Outcome card_up = card_->configure();
    if (card_up) card_up = card_->activate();
    if (!card_up) {
      bring_down_card();
      throw StartupError("motion card: " + describe(card_up.error()));
    }
    if (auto s = arm_->configure(); !s) {
      bring_down_card();
      throw StartupError("manipulator: " + describe(s.error()));
    }
    if (auto s = arm_->activate(); !s) {
      (void)arm_->cleanup();
      bring_down_card();
      throw StartupError("manipulator: " + describe(s.error()));
    }
    restore();
    store_.start();
    if (!manual_loop_) {
      for (auto& w : loop_->start_thread())
        startup_warnings_.push_back(std::move(w));
    }
    last_state_ = procedure_.state();
    started_ = true;
  }

  // Stops the wheels and the arm, tells every session (motion_stopped with the reason) while the
  // sink is still connected, persists, then joins the loop and brings the drivers down.
  void shutdown() noexcept override {
    if (!started_ || stopped_) return;
    stopped_ = true;
    try {
      drain_reports();
      stop_reason_ = "the daemon is shutting down";
      cancel_held_move(ErrorCode::kOk);
      loop_->request_stop();
      (void)arm_->stop();
      loop_->set_arm_moving(false);
      if (procedure_.phase() == Phase::kAligning) procedure_.alignment_interrupted();
      if (procedure_.phase() == Phase::kEngaging) procedure_.engaging_interrupted();
      end_arm_motion(EventKind::kMotionStopped, "arm stopped: the daemon is shutting down");
      if (manual_loop_) loop_->cycle(now_ns());  // a hand-driven loop: the stop reaches the card
      // Let the wheels come to rest under the loop's supervision (bounded).
      const std::int64_t give_up = monotonic_now_ns() + 5'000'000'000;
      while (!manual_loop_ && wheel_motion_ != 0 && monotonic_now_ns() < give_up) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        drain_reports();
      }
      if (wheel_motion_ != 0) {
        wheel_motion_ = 0;
        emit(EventKind::kMotionStopped, ErrorCode::kShuttingDown,
             "wheels stopped: the daemon is shutting down");
      }
      persist();
      if (!store_.flush(std::chrono::seconds(5))) {
        warnings_.push_back("state not persisted: the state store did not finish within 5 s");
      }
      store_.stop();
    } catch (...) {  // shutting down: nothing sensible to do but carry on
    }
    loop_->stop_thread();
    bring_down_card();
    if (arm_->state() == drivers::LifecycleState::kActive) (void)arm_->deactivate();
    if (arm_->state() == drivers::LifecycleState::kInactive) (void)arm_->cleanup();
  }

  protocol::Message handle_command(const protocol::Message& request) override {
    drain_reports();
    protocol::Message reply = dispatch(request);
    flush();
    return reply;
  }

  void controller_heartbeat() noexcept override { loop_->heartbeat(now_ns()); }

  void controller_lost() override {
    drain_reports();
    const Phase phase = procedure_.phase();
    cancel_held_move(ErrorCode::kDeadman);
    if (phase == Phase::kAligning || phase == Phase::kEngaging || wheel_motion_ != 0) {
      if (wheel_motion_ != 0) wheel_stopping_ = true;
      loop_->request_fault_stop(ErrorCode::kDeadman);
      (void)arm_->stop();
      latch(ErrorCode::kDeadman, "the controller went away during motion: stopped");
    }
    flush();
  }

  void begin_read_batch() override { in_read_batch_ = true; }

  void end_read_batch() override {
    in_read_batch_ = false;
    if (held_move_) {
      const MoveCommand move = *held_move_;
      held_move_.reset();
      if (!loop_->post_move(move)) {
        close_unstarted_move(move.motion_id, ErrorCode::kQueueFull, false);
      }
    }
    if (held_drive_) {
      const DriveCommand drive = *held_drive_;
      held_drive_.reset();
      if (!loop_->post_drive(drive) && drive.start) {
        close_unstarted_move(drive.motion_id, ErrorCode::kQueueFull, false);
      }
    }
    flush();
  }

  void poll() override {
    drain_reports();
    supervise_arm();
    reconcile();
    flush();
  }

  protocol::Status status() const override {
    const LoopSnapshot snap = loop_->snapshot();
    protocol::Status s;
    s.state = procedure_.state();
    s.latched_fault = procedure_.fault();
    s.restored_from_disk = restored_;
    if (procedure_.width()) s.has_width = true, s.width = *procedure_.width();
    if (procedure_.handle()) s.has_handle = true, s.handle = *procedure_.handle();
    if (procedure_.plane()) s.has_plane = true, s.plane = *procedure_.plane();
    if (procedure_.contact()) s.has_contact = true, s.contact = *procedure_.contact();
    s.base_yaw_odometry_rad = snap.base_yaw_rad;
    fill_motion(snap, s);
    s.card = to_wire(snap.card_state);
    s.arm = to_wire(arm_->state());
    s.arm_state = to_wire(arm_->status().phase);
    s.loop = loop_->statistics().summary();
    s.timing = loop_->statistics().timing(monotonic_now_ns());
    s.realtime = to_wire(realtime_granted());
    return s;
  }

  protocol::Telemetry telemetry() const override {
    const LoopSnapshot snap = loop_->snapshot();
    protocol::Telemetry t;
    t.daemon_time_ns = daemon_time_ns();
    t.state = procedure_.state();
    t.moving = snap.moving || snap.motion_active || procedure_.phase() == Phase::kEngaging;
    t.left_wheel_rad = snap.left_wheel_rad;
    t.right_wheel_rad = snap.right_wheel_rad;
    t.left_counts = snap.left_counts;
    t.right_counts = snap.right_counts;
    t.base_yaw_odometry_rad = snap.base_yaw_rad;
    fill_motion(snap, t);
    t.arm_state = to_wire(arm_->status().phase);
    t.loop = loop_->statistics().summary();
    t.timing = loop_->statistics().timing(monotonic_now_ns());
    return t;
  }

  protocol::Welcome welcome_template() const override {
    protocol::Welcome w;
    w.daemon_version.assign(std::string("ajard ") + kVersion);
    w.loop_rate_hz = static_cast<float>(config_.control.rate_hz);
    w.deadman_timeout_s = static_cast<float>(config_.safety.deadman_timeout_s);
    w.min_door_width_m = static_cast<float>(config_.limits.min_door_width_m);
    w.max_door_width_m = static_cast<float>(config_.limits.max_door_width_m);
    w.min_handle_length_m = static_cast<float>(config_.limits.min_handle_length_m);
    w.max_handle_length_m = static_cast<float>(config_.limits.max_handle_length_m);
    w.max_yaw_correction_rad = static_cast<float>(config_.limits.max_yaw_correction_rad);
    w.driver_kind = wire_driver_kind(config_.drivers.kind);
    return w;
  }

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

  std::vector<std::string> take_warnings() override {
    std::vector<std::string> w;
    w.swap(warnings_);
    for (auto& e : store_.take_errors())
      w.push_back("state not persisted: " + e);
    return w;
  }

  std::uint64_t accepted_generation() const noexcept override { return store_.submitted(); }
  std::uint64_t settled_generation() const noexcept override { return store_.settled(); }

 private:
  // ---- commands --------------------------------------------------------------------------------

  protocol::Message dispatch(const protocol::Message& request) {
    const MessageType type = protocol::type_of(request);
    const bool measures_or_moves = std::holds_alternative<protocol::MeasureDoorWidth>(request) ||
                                   std::holds_alternative<protocol::MeasureHandle>(request) ||
                                   std::holds_alternative<protocol::MeasureDoorPlane>(request) ||
                                   std::holds_alternative<protocol::SetContactPoint>(request) ||
                                   std::holds_alternative<protocol::AlignBase>(request) ||
                                   std::holds_alternative<protocol::Engage>(request);
    if (measures_or_moves && procedure_.fault() == ErrorCode::kOk) {
      if (auto s = check_wheels_at_rest(); !s) return refuse(type, s.error());
    }
    if (const auto* m = std::get_if<protocol::MeasureDoorWidth>(&request)) {
      return answer(type, procedure_.measure_width(*m));
    }
    if (const auto* m = std::get_if<protocol::MeasureHandle>(&request)) {
      return answer(type, procedure_.measure_handle(*m));
    }
    if (const auto* m = std::get_if<protocol::MeasureDoorPlane>(&request)) {
      return answer(type, procedure_.measure_plane(*m));
    }
    if (const auto* m = std::get_if<protocol::SetContactPoint>(&request)) {
      return answer(type, procedure_.set_contact(*m));
    }
    if (std::holds_alternative<protocol::AlignBase>(request)) return align(type);
    if (std::holds_alternative<protocol::Engage>(request)) return engage(type);
    if (std::holds_alternative<protocol::Stop>(request)) return stop(type);
    if (std::holds_alternative<protocol::EmergencyStop>(request)) return emergency_stop(type);
    if (const auto* m = std::get_if<protocol::Reset>(&request)) return reset(type, *m);
    if (const auto* m = std::get_if<protocol::Drive>(&request)) return drive(type, *m);
    if (const auto* m = std::get_if<protocol::Approach>(&request)) return approach(type, *m);
    if (type == MessageType::kResetLoopStatistics) {
      loop_->statistics().reset(monotonic_now_ns());
      return ack(type, protocol::EmptyAck{});
    }
    return refuse(type, make_error(ErrorCode::kWrongState, "", "not a command for the procedure"));
  }

  template <typename T>
  protocol::Message answer(MessageType type, Result<T> result) {
    if (!result) return refuse(type, result.error());
    dirty_ = true;
    return ack(type, std::move(result).value());
  }

  protocol::Message ack(MessageType type, protocol::AckBody body) {
    protocol::Ack a;
    a.acknowledged = type;
    a.state = procedure_.state();
    a.body = std::move(body);
    return a;
  }

  static protocol::Message refuse(MessageType type, const Error& e) {
    protocol::ErrorReply r;
    r.code = e.code;
    r.offending_type = type;
    r.field.assign(e.field);
    r.message.assign(e.message.empty() ? std::string(to_string(e.code)) : e.message);
    return r;
  }

  protocol::Message align(MessageType type) {
    auto wheels = procedure_.check_align();
    if (!wheels) return refuse(type, wheels.error());
    if (wheel_motion_ != 0) {
      return refuse(type, make_error(ErrorCode::kMotionInProgress, "",
                                     "the wheels are still stopping: wait for them to rest"));
    }
    if (wheels->left_counts == 0 && wheels->right_counts == 0) {  // already square to the door
      procedure_.alignment_started();
      procedure_.alignment_finished();
      dirty_ = true;
      return ack(type, protocol::EmptyAck{});
    }
    loop_->heartbeat(now_ns());  // the controller just spoke
    const MoveCommand move{++motion_id_, wheels->left_counts, wheels->right_counts};
    if (!hand_over(move)) return refuse(type, queue_full());
    procedure_.alignment_started();
    begin_wheel_motion(move.motion_id, WheelKind::kAlign);
    emit(EventKind::kMotionStarted, ErrorCode::kOk,
         "aligning: left " + std::to_string(move.left_counts) + " counts, right " +
             std::to_string(move.right_counts) + " counts");
    dirty_ = true;
    return ack(type, protocol::EmptyAck{});
  }

  // Drive (jog): a start opens a jog motion, later ones update its velocity (docs/procedure.md).
  protocol::Message drive(MessageType type, const protocol::Drive& m) {
    if (auto s = check_base_may_drive(true); !s) return refuse(type, s.error());
    loop_->heartbeat(now_ns());
    const core::BodyVelocity velocity{m.linear_m_s, m.angular_rad_s};
    const std::int64_t stamp = now_ns();
    if (wheel_motion_ != 0) {  // a running jog: update it
      if (held_drive_ && held_drive_->motion_id == wheel_motion_) {
        held_drive_->velocity = velocity;
        held_drive_->stamp_ns = stamp;
      } else {
        if (!hand_over(DriveCommand{wheel_motion_, false, velocity, stamp})) {
          return refuse(type, queue_full());
        }
      }
      return ack(type, protocol::EmptyAck{});
    }
    if (velocity.linear_m_s == 0 && velocity.angular_rad_s == 0) {
      return ack(type, protocol::EmptyAck{});  // at rest already: nothing to do
    }
    const DriveCommand start{motion_id_ + 1, true, velocity, stamp};
    if (!hand_over(start)) return refuse(type, queue_full());
    ++motion_id_;
    begin_wheel_motion(start.motion_id, WheelKind::kJog);
    emit(EventKind::kMotionStarted, ErrorCode::kOk,
         fmt::format("driving: {:.3f} m/s, {:.3f} rad/s asked (limits {:.3f} m/s, {:.3f} rad/s)",
                     m.linear_m_s, m.angular_rad_s, config_.drive.max_linear_speed_m_s,
                     config_.drive.max_angular_speed_rad_s));
    return ack(type, protocol::EmptyAck{});
  }

  // Approach: one straight trapezoidal move to `standoff_m` from the door plane.
  protocol::Message approach(MessageType type, const protocol::Approach& m) {
    if (auto s = check_base_may_drive(false); !s) return refuse(type, s.error());
    const core::DriveLimits& limits = config_.drive;
    if (!(m.standoff_m >= limits.approach_min_standoff_m)) {
      return refuse(
          type,
          make_error(
              ErrorCode::kStandoffOutOfRange, "standoff_m",
              fmt::format("standoff {:.3f} m is below drive.approach_min_standoff_m ({:.3f} m)",
                          m.standoff_m, limits.approach_min_standoff_m)));
    }
    const core::PlanarPose pose = loop_->snapshot().pose;
    if (procedure_.plane()) {
      if (auto s = procedure_.plane_fresh(); !s) return refuse(type, s.error());
    }
    const protocol::DoorRelation door = procedure_.door(pose);
    if (!door.has_distance) {
      return refuse(type, make_error(ErrorCode::kNoDoorDistance, "",
                                     "no distance to the door is known: measure the door width "
                                     "(or the door plane) first"));
    }
    if (std::abs(door.yaw_rad) > limits.approach_square_tolerance_rad) {
      return refuse(
          type, make_error(ErrorCode::kNotSquareToDoor, "door.yaw_rad",
                           fmt::format("the base is {:.3f} rad off square to the door (tolerance "
                                       "{:.3f} rad): align or jog square first",
                                       door.yaw_rad, limits.approach_square_tolerance_rad)));
    }
    protocol::ApproachAck body;
    body.start_distance_m = door.distance_m;
    body.travel_m = door.distance_m - m.standoff_m;
    if (std::abs(body.travel_m) > limits.approach_max_travel_m) {
      return refuse(
          type, make_error(ErrorCode::kApproachTooFar, "standoff_m",
                           fmt::format("the approach would travel {:.3f} m, more than "
                                       "drive.approach_max_travel_m ({:.3f} m): jog closer first",
                                       body.travel_m, limits.approach_max_travel_m)));
    }
    const core::StraightCommand wheels = core::straight_command(body.travel_m, config_.base);
    body.left_counts = wheels.left_counts;
    body.right_counts = wheels.right_counts;
    if (wheels.left_counts == 0 && wheels.right_counts == 0) return ack(type, body);  // there
    loop_->heartbeat(now_ns());
    const MoveCommand move{motion_id_ + 1, wheels.left_counts, wheels.right_counts,
                           MoveProfile::kStraight};
    if (!hand_over(move)) return refuse(type, queue_full());
    ++motion_id_;
    begin_wheel_motion(move.motion_id, WheelKind::kApproach);
    emit(EventKind::kMotionStarted, ErrorCode::kOk,
         fmt::format("approaching: {:.3f} m to {:.3f} m from the door (left {} counts, right {} "
                     "counts)",
                     body.travel_m, m.standoff_m, move.left_counts, move.right_counts));
    return ack(type, body);
  }

  // Hands a motion to the loop: held for the end of this read while one is being handled (a stop
  // later in the same read cancels it before any wheel turns), else posted now. False: the loop's
  // command queue is full (nothing was queued).
  bool hand_over(const MoveCommand& move) {
    if (!in_read_batch_) return loop_->post_move(move);
    held_move_ = move;
    return true;
  }
  bool hand_over(const DriveCommand& drive) {
    if (!in_read_batch_) return loop_->post_drive(drive);
    held_drive_ = drive;
    return true;
  }
  static Error queue_full() {
    return make_error(ErrorCode::kQueueFull, "", "control loop command queue full: retry later");
  }

  // Whether Drive (jog = true) or Approach may move the base now.
  Outcome check_base_may_drive(bool jog) const {
    if (procedure_.fault() != ErrorCode::kOk) {
      return make_error(
          ErrorCode::kFaultLatched, "",
          "a fault is latched (" + std::string(to_string(procedure_.fault())) + "): Reset first");
    }
    const Phase phase = procedure_.phase();
    if (phase == Phase::kAligning) {
      return make_error(ErrorCode::kMotionInProgress, "",
                        "the base is aligning: wait for motion_finished, or Stop");
    }
    if (phase == Phase::kEngaging || phase == Phase::kEngaged ||
        arm_->status().phase == drivers::ArmPhase::kBusy) {
      return make_error(ErrorCode::kDriveNotAllowed, "",
                        "the arm is at the door (engaging or engaged): the base must not move; "
                        "re-measure or Reset first");
    }
    if (wheel_motion_ == 0) return Ok{};
    if (wheel_stopping_) {
      return make_error(ErrorCode::kDriveNotAllowed, "",
                        "the wheels are still stopping: wait for motion_stopped");
    }
    if (wheel_kind_ == WheelKind::kApproach) {
      return make_error(ErrorCode::kMotionInProgress, "",
                        "an approach is running: wait for motion_finished, or Stop");
    }
    if (jog) return Ok{};  // updates the running jog
    return make_error(ErrorCode::kMotionInProgress, "",
                      "the base is being driven: release the drive keys (or Stop) and wait for "
                      "motion_finished");
  }

  void begin_wheel_motion(std::uint32_t id, WheelKind kind) {
    wheel_motion_ = id;
    wheel_kind_ = kind;
    wheel_stopping_ = false;
  }

  // Measurements, AlignBase and Engage while a Drive or Approach moves the wheels.
  Outcome check_wheels_at_rest() const {
    if (wheel_motion_ == 0 || wheel_kind_ == WheelKind::kAlign) return Ok{};
    return make_error(
        ErrorCode::kMotionInProgress, "",
        std::string("the base is moving (") +
            what_moves(wheel_kind_ == WheelKind::kJog, wheel_kind_ == WheelKind::kApproach) +
            "): wait for it to come to rest (motion_finished), or Stop");
  }

  template <typename Message>
  void fill_motion(const LoopSnapshot& snap, Message& m) const {
    m.odometry_x_m = snap.pose.x_m;
    m.odometry_y_m = snap.pose.y_m;
    m.door = procedure_.door(snap.pose);
    m.staleness = procedure_.staleness(snap.pose);
    m.commanded_linear_m_s = snap.commanded.linear_m_s;
    m.commanded_angular_rad_s = snap.commanded.angular_rad_s;
  }

  protocol::Message engage(MessageType type) {
    auto task = procedure_.check_engage();
    if (!task) return refuse(type, task.error());
    if (wheel_motion_ != 0) {
      return refuse(type, make_error(ErrorCode::kMotionInProgress, "",
                                     "the wheels are still stopping: wait for them to rest"));
    }
    auto id = arm_->hand_off(*task);
    if (!id) {
      Error e = id.error();
      if (e.field.empty()) e.field = "arm";
      return refuse(type, e);
    }
    arm_task_id_ = *id;
    arm_motion_ = true;
    arm_seen_busy_ = false;
    arm_deadline_ns_ =
        now_ns() + static_cast<std::int64_t>(config_.safety.arm_task_timeout_s * 1e9);
    loop_->heartbeat(now_ns());
    loop_->set_arm_moving(true);
    procedure_.engaging_started();
    emit(EventKind::kMotionStarted, ErrorCode::kOk,
         "engaging: task " + std::to_string(arm_task_id_) + " handed to the arm");
    dirty_ = true;
    return ack(type, protocol::EmptyAck{});
  }

  void stop_motion() {
    cancel_held_move(ErrorCode::kOk);
    if (wheel_motion_ != 0) wheel_stopping_ = true;
    loop_->request_stop();
    (void)arm_->stop();
    loop_->set_arm_moving(false);
    if (procedure_.phase() == Phase::kAligning) procedure_.alignment_interrupted();
    if (procedure_.phase() == Phase::kEngaging) procedure_.engaging_interrupted();
    end_arm_motion(EventKind::kMotionStopped, "arm stopped");
    dirty_ = true;
  }

  protocol::Message stop(MessageType type) {
    stop_motion();
    return ack(type, protocol::EmptyAck{});
  }

  protocol::Message emergency_stop(MessageType type) {
    cancel_held_move(ErrorCode::kEmergencyStopped);
    if (wheel_motion_ != 0) wheel_stopping_ = true;
    loop_->request_emergency_stop();
    (void)arm_->stop();
    latch(ErrorCode::kEmergencyStopped, "emergency stop: wheels and arm stopped");
    return ack(type, protocol::EmptyAck{});
  }

  // With a fault latched: recovers the arm here and the card in the loop (recover request with a
  // fresh sequence number; the loop answers exactly that sequence), then clears the fault.
  protocol::Message reset(MessageType type, const protocol::Reset& r) {
    if (procedure_.phase() == Phase::kAligning || procedure_.phase() == Phase::kEngaging ||
        (wheel_motion_ != 0 && !wheel_stopping_) || held_move_ || held_drive_) {
      stop_motion();  // also a jog or an approach
    }
    if (procedure_.fault() != ErrorCode::kOk) {
      if (auto s = recover_arm(); !s) {
        Error e = s.error();
        if (e.field.empty()) e.field = "arm";
        return refuse(type, e);
      }
      if (!loop_->request_recover(recover_sequence_ + 1)) return refuse(type, queue_full());
      ++recover_sequence_;
      const ErrorCode was = procedure_.fault();
      procedure_.clear_fault();
      emit(EventKind::kFaultCleared, ErrorCode::kOk,
           "reset: " + std::string(to_string(was)) + " cleared");
    }
    if (r.clear_parameters) procedure_.clear_parameters();
    dirty_ = true;
    return ack(type, protocol::EmptyAck{});
  }

  Outcome recover_arm() {
    if (arm_->state() == drivers::LifecycleState::kFault) {
      if (auto s = arm_->recover(); !s) return s;
    }
    if (arm_->state() == drivers::LifecycleState::kInactive) {
      if (auto s = arm_->activate(); !s) return s;
    }
    if (arm_->status().phase == drivers::ArmPhase::kFault) {
      if (auto s = arm_->clear_fault(); !s) return s;
    }
    return Ok{};
  }

  // ---- reports and the arm ---------------------------------------------------------------------

  // Every wheel motion the engine announced (motion_started) is closed by exactly one event, from
  // the loop's terminal report for that motion id.
  void drain_reports() {
    const LoopSnapshot snap = loop_->snapshot();
    if (procedure_.observe_pose(snap.pose)) dirty_ = true;
    LoopReport r;
    while (loop_->pop_report(r)) {
      switch (r.kind) {
        case LoopReportKind::kMotionFinished: {
          if (r.motion_id != wheel_motion_) break;
          wheel_motion_ = 0;
          if (procedure_.phase() == Phase::kAligning) {
            procedure_.alignment_finished();
            dirty_ = true;
          }
          std::string detail = "base aligned";
          if (wheel_kind_ == WheelKind::kApproach) {
            const auto door = procedure_.door(snap.pose);
            detail = fmt::format("approach finished: the door is {:.3f} m away", door.distance_m);
          } else if (wheel_kind_ == WheelKind::kJog) {
            detail = r.command_timeout
                         ? "driving ended: no Drive command within drive.command_timeout_s "
                           "(the base decelerated to rest)"
                         : "driving ended: the base is at rest";
          }
          emit(EventKind::kMotionFinished, ErrorCode::kOk, detail);
          break;
        }
        case LoopReportKind::kMotionStopped:
          if (r.motion_id != wheel_motion_) break;
          wheel_motion_ = 0;
          if (procedure_.phase() == Phase::kAligning) {  // stopped on its own (should not happen)
            procedure_.alignment_interrupted();
            dirty_ = true;
          }
          emit(EventKind::kMotionStopped, r.code, "wheels stopped" + reason(r.code));
          break;
        case LoopReportKind::kMoveRefused:
        case LoopReportKind::kMoveCancelled:
          close_unstarted_move(r.motion_id, r.code, r.kind == LoopReportKind::kMoveCancelled);
          break;
        case LoopReportKind::kFault:
          if (r.sequence != recover_sequence_) {
            // Latched before the loop took our last Reset's recovery, which clears it (and
            // fails, latching again, if the cause persists). Not lost: the journal has it.
            warnings_.push_back("control loop fault " + std::string(to_string(r.code)) +
                                " before the Reset's recovery ran: that recovery clears it");
            break;
          }
          latch(r.code,
                r.axis != 0 ? "axis " + std::to_string(r.axis) : std::string("control loop"));
          break;
        case LoopReportKind::kRecovered:
          if (r.sequence != recover_sequence_) break;  // an earlier Reset's recovery
          if (r.code != ErrorCode::kOk) latch(r.code, "the motion card did not recover");
          break;
      }
    }
  }

  // A wheel motion that never turned a wheel (refused or cancelled): the plane still holds.
  void close_unstarted_move(std::uint32_t motion_id, ErrorCode code, bool cancelled) {
    if (motion_id != wheel_motion_) return;
    wheel_motion_ = 0;
    if (wheel_kind_ == WheelKind::kAlign) {
      procedure_.alignment_not_started();  // also after a stop interrupted it: nothing turned
    }
    dirty_ = true;
    emit(EventKind::kMotionStopped, code,
         (cancelled ? "the move was cancelled before it started" : "the move did not start") +
             reason(code));
  }

  // A move held for the end of this read is dropped: no wheel has turned.
  void cancel_held_move(ErrorCode code) {
    if (held_drive_) {  // an update needs nothing more: the stop ends its jog
      const DriveCommand drive = *held_drive_;
      held_drive_.reset();
      if (drive.start) close_unstarted_move(drive.motion_id, code, true);
    }
    if (!held_move_) return;
    const std::uint32_t id = held_move_->motion_id;
    held_move_.reset();
    close_unstarted_move(id, code, true);
  }

  std::string reason(ErrorCode code) const {
    if (!stop_reason_.empty()) return ": " + stop_reason_;
    return code == ErrorCode::kOk ? std::string() : ": " + std::string(to_string(code));
  }

  // The arm task: done, fault, disconnect, a controller that dropped the task, or the deadline.
  void supervise_arm() {
    if (!arm_motion_) return;
    const drivers::ArmStatus st = arm_->status();
    if (st.phase == drivers::ArmPhase::kBusy && st.task_id == arm_task_id_) arm_seen_busy_ = true;
    if (st.phase == drivers::ArmPhase::kDone && st.task_id == arm_task_id_) {
      procedure_.engaging_finished();
      end_arm_motion(EventKind::kMotionFinished, "the arm finished the door task");
      dirty_ = true;
    } else if (st.phase == drivers::ArmPhase::kFault) {
      latch(st.last_error == ErrorCode::kOk ? ErrorCode::kArmRejected : st.last_error,
            "the arm reported a fault");
    } else if (st.phase == drivers::ArmPhase::kDisconnected) {
      latch(ErrorCode::kArmDisconnected, "the arm is disconnected");
    } else if (arm_->state() == drivers::LifecycleState::kFault) {
      latch(ErrorCode::kDriverError, "the arm driver failed");
    } else if (arm_seen_busy_ && st.phase != drivers::ArmPhase::kBusy) {
      latch(ErrorCode::kArmFault, "the arm controller dropped the task (reset mid-task?)");
    } else if (now_ns() > arm_deadline_ns_) {
      (void)arm_->stop();
      latch(ErrorCode::kArmTimeout, "the arm task did not finish within safety.arm_task_timeout_s");
    }
  }

  void end_arm_motion(EventKind kind, const std::string& detail) {
    if (!arm_motion_) return;
    arm_motion_ = false;
    loop_->set_arm_moving(false);
    emit(kind, ErrorCode::kOk, detail);
  }

  // Backstop when reports were dropped (report queue full): the snapshot is authoritative.
  void reconcile() {
    const LoopSnapshot snap = loop_->snapshot();
    if (snap.reports_dropped == 0) return;
    if (snap.recover_sequence == recover_sequence_ && !snap.recovering &&
        snap.fault != ErrorCode::kOk) {
      latch(snap.fault, "control loop");
    }
    if (wheel_motion_ != 0 && !snap.motion_active && snap.last_motion_id == wheel_motion_) {
      wheel_motion_ = 0;
      if (procedure_.phase() == Phase::kAligning) procedure_.alignment_interrupted();
      dirty_ = true;
      emit(EventKind::kMotionStopped, ErrorCode::kOk, "wheels at rest");
    }
  }

  // ---- faults, events, persistence -------------------------------------------------------------

  // A fault latches once (the first is the root cause): the procedure's motion phases end, the arm
  // is told to stop (an open arm task is closed), and the latch is announced once (fault_latched
  // event, and a warning for the journal through take_warnings()).
  void latch(ErrorCode code, const std::string& detail) {
    const bool was_clear = procedure_.fault() == ErrorCode::kOk;
    if (wheel_motion_ != 0) wheel_stopping_ = true;  // the loop stops the wheels for a fault
    procedure_.latch_fault(code);
    (void)arm_->stop();  // whatever latched, the arm does not go on
    if (arm_motion_) {
      end_arm_motion(EventKind::kMotionStopped,
                     "arm stopped: " + std::string(to_string(code)) + ": " + detail);
    }
    loop_->set_arm_moving(false);
    if (was_clear) {
      const std::string text = std::string(to_string(code)) + ": " + detail;
      emit(EventKind::kFaultLatched, code, text);
      warnings_.push_back("fault latched: " + text);
    }
    dirty_ = true;
  }

  void emit(EventKind kind, ErrorCode fault, const std::string& detail) {
    protocol::Event e;
    e.kind = kind;
    e.state = procedure_.state();
    e.fault = kind == EventKind::kFaultLatched ? fault : ErrorCode::kOk;
    e.daemon_time_ns = daemon_time_ns();
    e.detail.assign(detail);
    if (sink_) sink_(e);
  }

  void flush() {
    if (dirty_) {
      dirty_ = false;
      persist();
    }
    const ProcedureState now = procedure_.state();
    if (now != last_state_) {
      last_state_ = now;
      emit(EventKind::kStateChanged, procedure_.fault(), std::string(protocol::to_string(now)));
    }
  }

  // Hands the record to the state store's writer thread (never waits on the disk). Failures come
  // back through take_warnings().
  void persist() {
    if (!started_) return;
    store_.submit(procedure_.record());
  }

  // Before the writer thread starts. A file that cannot be read, decoded or validated is moved
  // aside (ajard.state.rejected-<time>) and the procedure starts clean; both are startup warnings.
  void restore() {
    auto loaded = store_.load();
    if (!loaded) {
      reject_state_file("state file rejected, starting with a clean procedure: " +
                        loaded.error().message);
      return;
    }
    if (!loaded->found) return;
    if (auto s = procedure_.restore(loaded->record); !s) {
      reject_state_file("state file " + store_.path() +
                        " rejected: it no longer validates with this config, starting with a "
                        "clean procedure: " +
                        describe(s.error()));
      return;
    }
    restored_ = true;
    // The normalised record (aligning -> ready to align, ...), written before anything is served.
    if (auto s = store_.save(procedure_.record()); !s) {
      startup_warnings_.push_back("state not persisted: " + s.error().message);
    }
  }

  void reject_state_file(std::string warning) {
    startup_warnings_.push_back(std::move(warning));
    if (!std::filesystem::exists(store_.path())) return;
    auto kept = store_.reject_current_file();
    startup_warnings_.push_back(kept ? "kept the rejected state file as " + *kept
                                     : "could not keep the rejected state file: " +
                                           kept.error().message);
  }

  std::int64_t now_ns() const noexcept { return clock_(); }

  // Lifecycle policy for the card (waits allowed): only while the control thread is not running.
  void bring_down_card() noexcept {
    if (card_->state() == drivers::LifecycleState::kActive) (void)card_->deactivate();
    if (card_->state() == drivers::LifecycleState::kInactive ||
        card_->state() == drivers::LifecycleState::kFault) {
      (void)card_->cleanup();
    }
  }

  Config config_;
  std::function<std::int64_t()> clock_;
  bool manual_loop_ = false;
  std::shared_ptr<void> keepalive_;                   // first: outlives the drivers
  std::unique_ptr<drivers::ManagedMotionCard> card_;  // outlives the loop that drives it
  std::unique_ptr<ControlLoop> loop_;
  std::unique_ptr<drivers::ManagedManipulator> arm_;
  Procedure procedure_;
  StateStore store_;
  std::int64_t start_ns_;
  EventSink sink_;

  bool started_ = false;
  bool stopped_ = false;
  bool restored_ = false;
  bool dirty_ = false;
  std::uint32_t motion_id_ = 0;
  std::uint32_t wheel_motion_ = 0;  // the announced wheel motion the loop has not ended (0: none)
  bool in_read_batch_ = false;
  std::optional<MoveCommand> held_move_;      // accepted in this read, not yet handed to the loop
  std::optional<DriveCommand> held_drive_;    // likewise (the last Drive of this read)
  WheelKind wheel_kind_ = WheelKind::kAlign;  // what wheel_motion_ is
  bool wheel_stopping_ = false;               // a stop was asked for wheel_motion_
  std::uint32_t arm_task_id_ = 0;
  bool arm_motion_ = false;  // an announced arm task not yet ended
  bool arm_seen_busy_ = false;
  std::int64_t arm_deadline_ns_ = 0;
  std::uint32_t recover_sequence_ = 0;  // the last recover request sent to the loop
  std::string stop_reason_;             // why every motion is stopping (shutdown), else empty
  ProcedureState last_state_ = ProcedureState::kAwaitingWidth;
  std::vector<std::string> startup_warnings_;
  std::vector<std::string> warnings_;
};

}  // namespace

std::unique_ptr<Engine> make_engine(const Config& config, drivers::DriverSet drivers,
                                    EngineOptions options) {
  return std::make_unique<EngineImpl>(config, std::move(drivers), std::move(options));
}

}  // namespace ajar::daemon
