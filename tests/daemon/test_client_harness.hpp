// In-process daemon for tests: a Server on 127.0.0.1 port 0 with its own I/O thread, over any
// Engine (FakeEngine below for session tests, the real engine on mock/sim drivers for e2e tests).
#pragma once

#include <utility>  // before Asio (asio issue 944)

#include <atomic>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>

#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/server.hpp"
#include "ajar/daemon/session_hub.hpp"

namespace ajar::test {

// Runs a Server on its own I/O thread, as ajard does: the server is built (installing the event
// sink), binds, engine.start(), listens and serves; stop() stops accepting, shuts the engine down
// and closes the sessions on the I/O thread, then joins it.
class ServerThread {
 public:
  ServerThread(daemon::Engine& engine, daemon::ServerOptions options) : engine_(engine) {
    options.bind_address = "127.0.0.1";
    options.port = 0;
    server_ = std::make_unique<daemon::Server>(io_, engine, std::move(options));
    port_ = server_->bind();
    engine_.start();
    server_->start();
    thread_ = std::thread([this] { io_.run(); });
  }
  ~ServerThread() { stop(); }

  void stop() {
    if (!thread_.joinable()) return;
    boost::asio::post(io_, [this] {  // the daemon's order (daemon.cpp)
      server_->stop_accepting();
      engine_.shutdown();
      server_->stop();
    });
    // Sessions linger at most SessionOptions::linger after the graceful close.
    thread_.join();
  }

  std::uint16_t port() const { return port_; }
  boost::asio::io_context& io() { return io_; }

  // Runs `f` on the I/O thread and returns its result (to inspect server state without races).
  template <typename F>
  auto call(F f) -> decltype(f()) {
    std::packaged_task<decltype(f())()> task(std::move(f));
    auto result = task.get_future();
    boost::asio::post(io_, [&task] { task(); });
    return result.get();
  }

  std::size_t session_count() {
    return call([this] { return server_->session_count(); });
  }

  // The server itself: use it only inside call() (the I/O thread), e.g.
  // call([&] { thread.server().reload_tls(tls); return 0; }).
  daemon::Server& server() { return *server_; }

 private:
  daemon::Engine& engine_;
  boost::asio::io_context io_{1};
  std::unique_ptr<daemon::Server> server_;
  std::uint16_t port_ = 0;
  std::thread thread_;
};

// A scriptable engine: acknowledges every command, counts calls. Thread-safe to inspect.
class FakeEngine final : public daemon::Engine {
 public:
  void start() override {}
  void shutdown() noexcept override {}

  protocol::Message handle_command(const protocol::Message& request) override {
    std::lock_guard lock(mutex_);
    commands_.push_back(protocol::type_of(request));
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
  void controller_heartbeat() noexcept override { ++heartbeats_; }
  void controller_lost() override { ++controller_lost_; }
  void poll() override {
    ++polls_;
    std::vector<protocol::Event> due;
    {
      std::lock_guard lock(mutex_);
      due.swap(pending_events_);
    }
    for (const auto& e : due) {
      if (sink_) sink_(e);
    }
  }
  protocol::Status status() const override {
    protocol::Status s;
    s.state = protocol::ProcedureState::kAwaitingWidth;
    return s;
  }
  protocol::Telemetry telemetry() const override {
    protocol::Telemetry t;
    t.daemon_time_ns = 42;
    return t;
  }
  protocol::Welcome welcome_template() const override {
    protocol::Welcome w;
    w.daemon_version = "fake";
    w.loop_rate_hz = 500;
    w.deadman_timeout_s = 0.5F;
    return w;
  }
  bool control_loop_healthy() const noexcept override { return healthy_.load(); }

  // Durability: with persisting(true) every command creates a new save generation, which
  // settles only when the test says so (settle()).
  std::uint64_t accepted_generation() const noexcept override { return accepted_.load(); }
  std::uint64_t settled_generation() const noexcept override { return settled_.load(); }
  void persisting(bool on) {
    std::lock_guard lock(mutex_);
    persisting_ = on;
  }
  void settle() { settled_.store(accepted_.load()); }
  void set_healthy(bool healthy) { healthy_.store(healthy); }

  void set_event_sink(EventSink sink) override { sink_ = std::move(sink); }
  // Queues an event to be emitted from the next poll() (on the I/O thread).
  void emit(const protocol::Event& event) {
    std::lock_guard lock(mutex_);
    pending_events_.push_back(event);
  }

  void reply_next_with(protocol::Message reply) {
    std::lock_guard lock(mutex_);
    next_reply_ = std::move(reply);
  }
  std::vector<protocol::MessageType> commands() const {
    std::lock_guard lock(mutex_);
    return commands_;
  }
  std::size_t count(protocol::MessageType t) const {
    std::lock_guard lock(mutex_);
    return static_cast<std::size_t>(std::count(commands_.begin(), commands_.end(), t));
  }
  int heartbeats() const { return heartbeats_.load(); }
  int controller_lost_count() const { return controller_lost_.load(); }
  int polls() const { return polls_.load(); }

 private:
  mutable std::mutex mutex_;
  std::vector<protocol::MessageType> commands_;
  std::optional<protocol::Message> next_reply_;
  std::vector<protocol::Event> pending_events_;
  EventSink sink_;
  std::atomic<int> heartbeats_{0};
  std::atomic<int> controller_lost_{0};
  std::atomic<int> polls_{0};
  std::atomic<bool> healthy_{true};
  bool persisting_ = false;
  std::atomic<std::uint64_t> accepted_{0};
  std::atomic<std::uint64_t> settled_{0};
};

// Polls `condition` until true or the deadline; never asserts timing, only eventual truth.
template <typename F>
bool eventually(F condition, std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return condition();
}

}  // namespace ajar::test
