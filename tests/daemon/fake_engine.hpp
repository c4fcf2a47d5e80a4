// The one engine double of the daemon's tests. Two ways to use it, with the same hooks:
//   - FakeEngine{}: a scriptable engine of its own: acknowledges every command with the body the
//     wire format expects (or the reply the test set), emits the events the test queued from the
//     next poll(), settles saves when the test says, reports healthy until told otherwise;
//   - FakeEngine{inner}: in front of another engine (the real one, or a FakeEngine), forwarding
//     every virtual of daemon::Engine to it (they are all pure: one left out does not compile)
//     while it counts and records what reaches the engine (the interleaving proof's exactly-once
//     count, the watchdog's health checks), tells the test's hooks where a command or a
//     controller loss reaches it (the reply-order model), and can hold the engine's saves back
//     from the hub (gate_saves: the disk lands a save only when the test says).
// Thread-safe to inspect from the test while the I/O thread calls it.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ajar/daemon/engine.hpp"

namespace ajar::test {

class FakeEngine final : public daemon::Engine {
 public:
  FakeEngine() = default;
  explicit FakeEngine(daemon::Engine& inner) : inner_(&inner) {}
  // In front of another FakeEngine too (the copy constructor would win over the one above).
  static std::unique_ptr<FakeEngine> in_front_of(daemon::Engine& inner) {
    return std::make_unique<FakeEngine>(inner);
  }
  FakeEngine(const FakeEngine&) = delete;
  FakeEngine& operator=(const FakeEngine&) = delete;

  // ---- hooks (called on the caller's thread, no lock held) ----
  std::function<void(const protocol::Message&)> before_command;  // handle_command is entered
  // handle_command answered; `new_save`: the command began a save generation (a durable Ack).
  std::function<void(bool new_save)> after_command;
  std::function<void()> before_lost;  // runs before the engine hears of a controller loss

  // ---- what reached the engine ----
  std::vector<protocol::MessageType> commands() const {
    std::lock_guard lock(mutex_);
    return commands_;
  }
  std::size_t count(protocol::MessageType t) const {
    std::lock_guard lock(mutex_);
    return static_cast<std::size_t>(std::count(commands_.begin(), commands_.end(), t));
  }
  int executions() const { return executions_.load(); }  // handle_command calls
  protocol::Message last_reply() const {                 // of the last one
    std::lock_guard lock(mutex_);
    return last_reply_;
  }
  int heartbeats() const { return heartbeats_.load(); }
  int controller_lost_count() const { return controller_lost_.load(); }
  int polls() const { return polls_.load(); }
  int health_checks() const { return health_checks_.load(); }  // control_loop_healthy() calls

  // ---- the standalone fake's script ----
  // Durability: with persisting(true) every command creates a new save generation, which settles
  // only when the test says so (settle()).
  void persisting(bool on) {
    std::lock_guard lock(mutex_);
    persisting_ = on;
  }
  void settle() { settled_.store(accepted_.load()); }
  void set_healthy(bool healthy) { healthy_.store(healthy); }
  // The settled generation the hub is told never passes `up_to` (either way of use): a save has
  // landed, as the hub sees it, only once the test opened the gate that far. No gate by default.
  void gate_saves(std::uint64_t up_to) { gate_.store(up_to); }
  std::uint64_t settled_seen() const { return settled_seen_.load(); }  // the hub was last told
  // Queues an event to be emitted from the next poll() (on the I/O thread).
  void emit(const protocol::Event& event) {
    std::lock_guard lock(mutex_);
    pending_events_.push_back(event);
  }
  void reply_next_with(protocol::Message reply) {
    std::lock_guard lock(mutex_);
    next_reply_ = std::move(reply);
  }

  // ---- daemon::Engine: every virtual ----
  void set_event_sink(EventSink sink) override {
    if (inner_) return inner_->set_event_sink(std::move(sink));
    sink_ = std::move(sink);
  }
  void start() override {
    if (inner_) inner_->start();
  }
  void begin_shutdown() override {
    if (inner_) inner_->begin_shutdown();
  }
  bool wheels_at_rest() override { return inner_ ? inner_->wheels_at_rest() : true; }
  void seal_state() override {
    if (inner_) inner_->seal_state();
  }
  void shutdown() noexcept override {
    if (inner_) inner_->shutdown();
  }
  bool wedged() const noexcept override { return inner_ ? inner_->wedged() : false; }
  protocol::Message handle_command(const protocol::Message& request) override {
    ++executions_;
    if (before_command) before_command(request);
    const std::uint64_t generation_before = accepted_generation();
    protocol::Message reply = inner_ ? inner_->handle_command(request) : scripted_reply(request);
    if (after_command) after_command(accepted_generation() > generation_before);
    std::lock_guard lock(mutex_);
    commands_.push_back(protocol::type_of(request));
    last_reply_ = reply;
    return reply;
  }
  void controller_heartbeat() noexcept override {
    ++heartbeats_;
    if (inner_) inner_->controller_heartbeat();
  }
  void controller_lost() override {
    ++controller_lost_;
    if (before_lost) before_lost();
    if (inner_) inner_->controller_lost();
  }
  void begin_read_batch() override {
    if (inner_) inner_->begin_read_batch();
  }
  void end_read_batch() override {
    if (inner_) inner_->end_read_batch();
  }
  void poll() override {
    ++polls_;
    if (inner_) return inner_->poll();
    std::vector<protocol::Event> due;
    {
      std::lock_guard lock(mutex_);
      due.swap(pending_events_);
    }
    for (const auto& e : due) {
      if (sink_) sink_(e);
    }
  }
  void catch_up() override {
    if (inner_) inner_->catch_up();
  }
  std::uint64_t accepted_generation() const noexcept override {
    return inner_ ? inner_->accepted_generation() : accepted_.load();
  }
  std::uint64_t settled_generation() const noexcept override {
    const std::uint64_t settled = inner_ ? inner_->settled_generation() : settled_.load();
    const std::uint64_t seen = std::min(settled, gate_.load());
    settled_seen_.store(seen);
    return seen;
  }
  protocol::Status status() const override {
    if (inner_) return inner_->status();
    protocol::Status s;
    s.state = protocol::ProcedureState::kAwaitingWidth;
    return s;
  }
  protocol::Telemetry telemetry() const override {
    if (inner_) return inner_->telemetry();
    protocol::Telemetry t;
    t.daemon_time_ns = 42;
    return t;
  }
  protocol::Welcome welcome_template() const override {
    if (inner_) return inner_->welcome_template();
    protocol::Welcome w;
    w.daemon_version = "fake";
    w.loop_rate_hz = 500;
    w.deadman_timeout_s = 0.5F;
    return w;
  }
  protocol::RobotModel robot_model() const override {
    return inner_ ? inner_->robot_model() : protocol::RobotModel{};
  }
  bool control_loop_healthy() const noexcept override {
    ++health_checks_;
    return inner_ ? inner_->control_loop_healthy() : healthy_.load();
  }
  std::uint64_t daemon_time_ns() const noexcept override {
    return inner_ ? inner_->daemon_time_ns() : 42;
  }
  recorder::Recorder* recorder() noexcept override { return inner_ ? inner_->recorder() : nullptr; }
  void run_loop_cycle() noexcept override {
    if (inner_) inner_->run_loop_cycle();
  }
  std::vector<std::string> startup_warnings() const override {
    return inner_ ? inner_->startup_warnings() : std::vector<std::string>{};
  }
  std::vector<std::string> take_warnings() override {
    return inner_ ? inner_->take_warnings() : std::vector<std::string>{};
  }

 private:
  protocol::Message scripted_reply(const protocol::Message& request) {
    std::lock_guard lock(mutex_);
    if (persisting_) ++accepted_;
    if (next_reply_) {
      auto reply = *next_reply_;
      next_reply_.reset();
      return reply;
    }
    protocol::Ack ack;
    ack.acknowledged = protocol::type_of(request);
    ack.state = protocol::ProcedureState::kAwaitingHandle;
    switch (ack.acknowledged) {  // the body the wire format expects for each request
      case protocol::MessageType::kMeasureDoorWidth:
      case protocol::MessageType::kMeasureHandle:
        ack.body = protocol::SpanAck{};
        break;
      case protocol::MessageType::kMeasureDoorPlane:
        ack.body = protocol::PlaneAck{};
        break;
      case protocol::MessageType::kSetContactPoint:
        ack.body = protocol::ContactAck{};
        break;
      case protocol::MessageType::kApproach:
        ack.body = protocol::ApproachAck{};
        break;
      default:
        ack.body = protocol::EmptyAck{};
    }
    return ack;
  }

  daemon::Engine* inner_ = nullptr;
  mutable std::mutex mutex_;
  std::vector<protocol::MessageType> commands_;
  protocol::Message last_reply_;
  std::optional<protocol::Message> next_reply_;
  std::vector<protocol::Event> pending_events_;
  EventSink sink_;
  std::atomic<int> executions_{0};
  std::atomic<int> heartbeats_{0};
  std::atomic<int> controller_lost_{0};
  std::atomic<int> polls_{0};
  mutable std::atomic<int> health_checks_{0};
  std::atomic<bool> healthy_{true};
  bool persisting_ = false;
  std::atomic<std::uint64_t> accepted_{0};
  std::atomic<std::uint64_t> settled_{0};
  std::atomic<std::uint64_t> gate_{std::numeric_limits<std::uint64_t>::max()};
  mutable std::atomic<std::uint64_t> settled_seen_{0};
};

}  // namespace ajar::test
