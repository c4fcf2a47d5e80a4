// The engine: procedure + control loop + arm + persistence, driven from the I/O thread. This file:
// start-up and shutdown, the read batch, and what sessions read (status, telemetry, welcome).
#include "engine_impl.hpp"

namespace ajar::daemon::detail {

namespace {
std::unique_ptr<drivers::ManagedMotionCard> managed_card(const Config& config,
                                                         drivers::DriverSet& drivers) {
  if (!drivers.card || !drivers.arm) throw StartupError("drivers: card and arm are required");
  const int axes[2] = {config.base.left.card_axis, config.base.right.card_axis};
  return std::make_unique<drivers::ManagedMotionCard>(std::move(drivers.card), axes, 5000,
                                                      config.drivers.card.poll_timeout_ms);
}
}  // namespace

EngineImpl::EngineImpl(const Config& config, drivers::DriverSet drivers, EngineOptions options)
    : config_(config),
      loop_on_engine_clock_(options.manual_loop || !options.now_ns),
      clock_(options.now_ns ? std::move(options.now_ns)
                            : std::function<std::int64_t()>([] { return monotonic_now_ns(); })),
      manual_loop_(options.manual_loop),
      keepalive_(std::move(drivers.keepalive)),
      card_(managed_card(config, drivers)),
      loop_(std::make_unique<ControlLoop>(*card_, loop_settings(config))),
      arm_(std::make_unique<drivers::ManagedManipulator>(std::move(drivers.arm)), *loop_,
           ArmTask::Settings{config.safety.arm_task_timeout_s, config.safety.arm_stop_timeout_s}),
      procedure_(camera_to_base_or_throw(config), config.limits, config.base,
                 ProcedureLimits{config.control.aligned_tolerance_rad, config.drive.stale_travel_m,
                                 config.drive.stale_yaw_rad}),
      store_(config.state.directory,
             StateStore::Options{std::chrono::milliseconds(config.state.debug_write_delay_ms)}),
      start_ns_(clock_()),
      wheels_(*loop_) {
  const int axes[2] = {config.base.left.card_axis, config.base.right.card_axis};
  recorder_ = std::make_unique<recorder::Recorder>(recorder_settings(config, start_ns_),
                                                   [w = recorder_warnings_](std::string_view text) {
                                                     std::lock_guard lock(w->first);
                                                     w->second.emplace_back(text);
                                                   });
  supervisor_ = std::make_unique<LoopSupervisor>(
      SupervisedLoop{
          [this] { return loop_->thread_running(); }, [this] { return loop_->last_cycle_end_ns(); },
          [this] { loop_->latch_stalled(); }, [this] { return thread_cpu(loop_->thread_tid()); },
          [this] { return loop_->sleep_record(); }},
      *card_, axes, config.control);
}

void EngineImpl::start() {
  if (started_) return;
  store_.prepare();
  // Lifecycle policy (with its waits) runs here, before the control thread exists.
  Outcome card_up = card_->configure();
  if (card_up) card_up = card_->activate();
  if (!card_up) {
    bring_down_card();
    throw StartupError("motion card: " + describe(card_up.error()));
  }
  if (auto s = arm_.bring_up(); !s) {
    bring_down_card();
    throw StartupError("manipulator: " + describe(s.error()));
  }
  restore();
  // The run is on disk (with what restore() latched) before anything is served: an end other
  // than a clean shutdown from now on is seen by the next start.
  if (auto s = store_.save(StateRecord{procedure_.record(), false}); !s) {
    arm_.bring_down();
    bring_down_card();
    throw StartupError(
        "state.directory: cannot record the start (an unclean end would go "
        "unnoticed): " +
        s.error().message);
  }
  store_.start();
  recorder_->start();  // a directory it cannot use: a warning, and the daemon runs on
  loop_->set_recorder(recorder_.get());
  record_config(recorder_.get(), daemon_time_ns(), "start", config_, {});
  if (const ErrorCode latched = procedure_.fault(); latched != ErrorCode::kOk) {
    record_fault(recorder_.get(), daemon_time_ns(), true, latched, "latched at start");
  }
  if (!manual_loop_) {
    for (auto& w : loop_->start_thread())
      startup_warnings_.push_back(std::move(w));
    for (auto& w : supervisor_->start_thread())
      startup_warnings_.push_back(std::move(w));
  }
  last_state_ = procedure_.state();
  started_ = true;
}

namespace {
constexpr std::int64_t kWheelsRestLimitNs = 5'000'000'000;  // shutdown(): the wheels' smooth stop
constexpr auto kStateFlushLimit = std::chrono::seconds(5);  // shutdown(): the last save
constexpr int kManualShutdownCycles = 100;
constexpr std::int64_t kLoopEndLimitNs = 1'000'000'000;  // shutdown(): the control thread ends //
                                                         // ... with EngineOptions::manual_loop
}  // namespace

void EngineImpl::begin_shutdown() {
  if (!started_ || shutting_down_) return;
  shutting_down_ = true;
  drain_reports();
  stop_reason_ = "the daemon is shutting down";
  stop_motion();
  if (manual_loop_) loop_->cycle(now_ns());  // a hand-driven loop: the stop reaches the card
  flush();
}

bool EngineImpl::wheels_at_rest() {
  drain_reports();
  return wheels_.current() == 0;
}

void EngineImpl::seal_state() {
  if (!started_ || sealed_) return;
  begin_shutdown();
  drain_reports();
  if (wheels_.current() != 0) {
    // The smooth stop did not end in time (the loop's own stop deadline should have caught it).
    loop_->request_emergency_stop();
    latch(ErrorCode::kMotionTimeout,
          "the wheels were not at rest when the daemon stopped: emergency stop");
    wheels_.forget();
    emit(EventKind::kMotionStopped, ErrorCode::kShuttingDown,
         "wheels emergency-stopped: the daemon is shutting down");
  }
  flush();
  sealed_ = true;
  persist();  // the clean-shutdown mark, with everything accepted until now
}

void EngineImpl::shutdown() noexcept {
  if (!started_ || stopped_) return;
  try {
    if (!sealed_) {  // nobody did the steps: do them here, waiting (bounded)
      begin_shutdown();
      const std::int64_t give_up = monotonic_now_ns() + kWheelsRestLimitNs;
      for (int cycles = 0; !wheels_at_rest() && monotonic_now_ns() < give_up; ++cycles) {
        if (!manual_loop_) {
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
        } else if (cycles < kManualShutdownCycles) {
          loop_->cycle(now_ns());  // a hand-driven loop: its clock may stand still
        } else {
          break;
        }
      }
      seal_state();
      if (!store_.flush(kStateFlushLimit)) {
        warnings_.push_back(
            "state not persisted: the state store did not finish within 5 s; the next start "
            "treats this end as unclean");
      }
    }
  } catch (...) {  // shutting down: nothing sensible to do but carry on
  }
  stopped_ = true;
  if (!store_.stop(std::chrono::milliseconds(100))) {
    warnings_.push_back("state writer abandoned: a save has not returned (a hung disk?)");
  }
  if (!loop_->stop_thread(kLoopEndLimitNs)) {
    // A cycle stuck in a card call that does not return: the supervisor stopped the base out of
    // band (LOOP_STALLED, persisted above). The vendor library is wedged: bringing the card down
    // would hang too, and so would anything that waits for the loop. The arm goes to rest; the
    // process must exit (wedged()).
    wedged_ = true;
    warnings_.push_back(
        "the control thread did not end within 1 s (a motion-card call has not returned): the "
        "base stays as the out-of-band emergency stop left it; the card is not brought down");
    recorder_->stop();
    arm_.bring_down();
    return;
  }
  recorder_->stop();  // after the loop: its last samples are in the file, which gets its footer
  supervisor_->stop_thread();  // before the card goes down: no out-of-band call into a closing card
  bring_down_card();
  arm_.bring_down();
}

protocol::Message EngineImpl::handle_command(const protocol::Message& request) {
  drain_reports();
  const bool stop = std::holds_alternative<protocol::Stop>(request) ||
                    std::holds_alternative<protocol::EmergencyStop>(request);
  protocol::Message reply =
      shutting_down_ && !stop
          ? refuse(protocol::type_of(request),
                   make_error(ErrorCode::kShuttingDown, "",
                              "the daemon is shutting down: only Stop and EmergencyStop are "
                              "executed; reconnect once it has restarted"))
          : dispatch(request);
  flush();
  return reply;
}

void EngineImpl::controller_lost() {
  drain_reports();
  const Phase phase = procedure_.phase();
  cancel_held_move(ErrorCode::kDeadman);
  if (phase == Phase::kAligning || phase == Phase::kEngaging || wheels_.current() != 0) {
    wheels_.stopping_asked();
    loop_->request_fault_stop(ErrorCode::kDeadman);
    arm_.send_stop();
    latch(ErrorCode::kDeadman, "the controller went away during motion: stopped");
  }
  flush();
}

void EngineImpl::end_read_batch() {
  wheels_.end_read_batch([this](std::uint32_t motion_id) {
    close_unstarted_move(motion_id, ErrorCode::kQueueFull, false);
  });
  flush();
}

void EngineImpl::poll() {
  drain_reports();
  (void)sync_door_guard();  // a stale plane, a new measurement: the loop's jog guard follows
  supervise_arm();
  reconcile();
  flush();
}

protocol::Status EngineImpl::status() const {
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
  // A stalled loop publishes nothing: its last snapshot would still show the card active.
  s.card = to_wire(supervisor_->stalled() ? drivers::LifecycleState::kFault : snap.card_state);
  s.arm = to_wire(arm_.state());
  s.arm_state = to_wire(arm_.status().phase);
  s.loop = loop_->statistics().summary();
  s.timing = loop_->statistics().timing(monotonic_now_ns());
  s.realtime = to_wire(realtime_granted());
  s.base_motion = base_motion();
  s.recorder = recorder_state(recorder_.get());
  return s;
}

protocol::BaseMotion EngineImpl::base_motion() const {
  if (wheels_.current() == 0) return protocol::BaseMotion::kNone;
  if (wheels_.stopping()) return protocol::BaseMotion::kStopping;
  switch (wheels_.kind()) {
    case WheelKind::kAlign:
      return protocol::BaseMotion::kAligning;
    case WheelKind::kApproach:
      return protocol::BaseMotion::kApproaching;
    case WheelKind::kJog:
      return protocol::BaseMotion::kJogging;
  }
  return protocol::BaseMotion::kNone;
}

protocol::Telemetry EngineImpl::telemetry() const {
  const LoopSnapshot snap = loop_->snapshot();
  protocol::Telemetry t;
  // When the loop sampled the wheels (the cycle of this snapshot), not when the frame was built.
  t.daemon_time_ns = loop_on_engine_clock_ && snap.cycles > 0 && snap.time_ns >= start_ns_
                         ? static_cast<std::uint64_t>(snap.time_ns - start_ns_)
                         : daemon_time_ns();
  t.state = procedure_.state();
  t.moving = snap.moving || snap.motion_active || procedure_.phase() == Phase::kEngaging;
  t.left_wheel_rad = snap.left_wheel_rad;
  t.right_wheel_rad = snap.right_wheel_rad;
  t.left_counts = snap.left_counts;
  t.right_counts = snap.right_counts;
  t.base_yaw_odometry_rad = snap.base_yaw_rad;
  fill_motion(snap, t);
  t.arm_state = to_wire(arm_.status().phase);
  t.loop = loop_->statistics().summary();
  t.timing = loop_->statistics().timing(monotonic_now_ns());
  t.base_motion = base_motion();
  return t;
}

protocol::Welcome EngineImpl::welcome_template() const {
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

std::vector<std::string> EngineImpl::take_warnings() {
  std::vector<std::string> w;
  w.swap(warnings_);
  {
    std::lock_guard lock(recorder_warnings_->first);
    for (auto& e : recorder_warnings_->second)
      w.push_back(std::move(e));
    recorder_warnings_->second.clear();
  }
  for (auto& e : store_.take_errors())
    w.push_back("state not persisted: " + e);
  return w;
}

void EngineImpl::bring_down_card() noexcept {
  if (card_->state() == drivers::LifecycleState::kActive) (void)card_->deactivate();
  if (card_->state() == drivers::LifecycleState::kInactive ||
      card_->state() == drivers::LifecycleState::kFault) {
    (void)card_->cleanup();
  }
}

}  // namespace ajar::daemon::detail

namespace ajar::daemon {

std::unique_ptr<Engine> make_engine(const Config& config, drivers::DriverSet drivers,
                                    EngineOptions options) {
  return std::make_unique<detail::EngineImpl>(config, std::move(drivers), std::move(options));
}

}  // namespace ajar::daemon
