// End to end over mutual TLS (issue 13): the real engine on mock and simulated drivers behind the
// server, driven by ajar_client with a CA, a certificate and a key (ajarctl's --ca/--cert/--key):
// a controller certificate completes the whole procedure; an observer certificate's
// EmergencyStop stops a running alignment; revoking the controller mid-alignment stops it too.
#include <utility>  // before Asio (asio issue 944)

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "e2e_fixture.hpp"
#include "tls_support.hpp"

namespace ajar::test {
namespace {

using client::Client;
using protocol::EventKind;
using protocol::ProcedureState;
using protocol::Role;

// What an observer saw: events and whether the wheels were moving at the last telemetry.
class Watcher {
 public:
  explicit Watcher(Client& c) {
    c.on_event([this](const protocol::Event& e) {
      std::lock_guard lock(mutex_);
      events_.push_back(e);
    });
    c.on_telemetry([this](const protocol::Telemetry& t) {
      moving_.store(t.moving);
      telemetry_.fetch_add(1);
    });
  }
  std::optional<protocol::Event> event(EventKind kind) const {
    std::lock_guard lock(mutex_);
    for (const auto& e : events_) {
      if (e.kind == kind) return e;
    }
    return std::nullopt;
  }
  bool wait_event(EventKind kind) const {
    return eventually([&] { return event(kind).has_value(); }, 60s);
  }
  // True once a telemetry sample newer than now says the wheels stand still.
  bool wait_at_rest() const {
    return eventually(
        [&, after = telemetry_.load()] { return telemetry_.load() > after + 1 && !moving_.load(); },
        60s);
  }

 private:
  mutable std::mutex mutex_;
  std::vector<protocol::Event> events_;
  std::atomic<bool> moving_{false};
  std::atomic<int> telemetry_{0};
};

ProcedureState state_of(const client::Response& r) {
  const auto* ack = r.get<protocol::Ack>();
  if (ack == nullptr) {
    ADD_FAILURE() << "not acknowledged: " << client::to_string(r.outcome) << " "
                  << r.error.message.view() << r.transport_error;
    return ProcedureState::kFault;
  }
  return ack->state;
}

// Polls GetStatus until `state` (a fault latched on the way fails the test).
protocol::Status wait_for_state(Client& c, ProcedureState state) {
  protocol::Status status;
  eventually(
      [&] {
        const auto r = c.request(protocol::GetStatus{});
        if (const auto* s = r.get<protocol::Status>()) status = *s;
        return status.state == state ||
               (status.state == ProcedureState::kFault && state != ProcedureState::kFault);
      },
      60s);
  EXPECT_EQ(status.state, state) << "latched fault: " << to_string(status.latched_fault);
  return status;
}

class TlsEndToEnd : public EndToEndTest {
 protected:
  daemon::Config tls_config(double speedup) {
    daemon::Config c = config(speedup);
    c.network.tls = pki_.server_config();
    return c;
  }
  std::unique_ptr<Client> greeted(InProcessDaemon& d, const std::string& name, Role role) {
    auto c = std::make_unique<Client>(options_with(pki_.client_tls(name), name));
    EXPECT_TRUE(c->connect({"127.0.0.1", d.port()}).ok());
    const auto hello = c->hello(role);
    EXPECT_TRUE(hello.ok()) << hello.error.message.view() << hello.transport_error;
    return c;
  }
  // Width, handle, plane (yawed), AlignBase: returns once the base is turning.
  void start_alignment(Client& controller, double yaw_rad) {
    ASSERT_EQ(state_of(controller.request(good_width())), ProcedureState::kAwaitingHandle);
    ASSERT_EQ(state_of(controller.request(good_handle())), ProcedureState::kAwaitingPlane);
    ASSERT_EQ(state_of(controller.request(plane_at_yaw(yaw_rad))), ProcedureState::kReadyToAlign);
    ASSERT_EQ(state_of(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  }
  // ajard over TLS at real speed, alice (controller, heartbeat every 100 ms) turning the base
  // toward a door yawed 0.6 rad, bob (observer) watching telemetry at 100 Hz: set once the motion
  // started.
  void start_aligning() {
    daemon_ = std::make_unique<InProcessDaemon>(tls_config(1.0));
    controller_ = greeted(*daemon_, "alice", Role::kController);
    controller_->set_heartbeat(100ms);
    observer_ = greeted(*daemon_, "bob", Role::kObserver);
    watched_ = std::make_unique<Watcher>(*observer_);
    ASSERT_TRUE(observer_->request(protocol::Subscribe{100}).ok());
    start_alignment(*controller_, 0.6);
    ASSERT_TRUE(watched_->wait_event(EventKind::kMotionStarted));
  }

  LogCapture log_;
  Pki pki_;
  // start_aligning()'s daemon and clients (destroyed in reverse: the watcher first).
  std::unique_ptr<InProcessDaemon> daemon_;
  std::unique_ptr<Client> controller_;
  std::unique_ptr<Client> observer_;
  std::unique_ptr<Watcher> watched_;
};

TEST_P(TlsEndToEnd, AControllerCertificateCompletesTheWholeProcedure) {
  InProcessDaemon d(tls_config(10.0));
  auto observer = greeted(d, "bob", Role::kObserver);
  Watcher watched(*observer);
  ASSERT_TRUE(observer->request(protocol::Subscribe{50}).ok());
  auto controller = greeted(d, "alice", Role::kController);
  controller->set_heartbeat(100ms);

  start_alignment(*controller, 0.1);
  wait_for_state(*controller, ProcedureState::kAligned);
  ASSERT_EQ(state_of(controller->request(good_contact())), ProcedureState::kReadyToEngage);
  ASSERT_EQ(state_of(controller->request(protocol::Engage{})), ProcedureState::kEngaging);
  const auto status = wait_for_state(*controller, ProcedureState::kEngaged);
  EXPECT_TRUE(status.has_width && status.has_handle && status.has_plane && status.has_contact);
  EXPECT_NEAR(status.width.length_m, 0.85, 1e-6);

  EXPECT_TRUE(watched.wait_event(EventKind::kMotionStarted));
  EXPECT_TRUE(watched.wait_event(EventKind::kMotionFinished));
  EXPECT_TRUE(log_.contains("authenticated as cn:alice", "controller"));
  // The observer certificate commands nothing.
  EXPECT_EQ(observer->request(protocol::Reset{}).error.code, ErrorCode::kNotController);
}

TEST_P(TlsEndToEnd, EmergencyStopFromAnObserverCertificateStopsARunningAlignment) {
  ASSERT_NO_FATAL_FAILURE(start_aligning());

  EXPECT_TRUE(observer_->request(protocol::EmergencyStop{}).ok());
  ASSERT_TRUE(watched_->wait_event(EventKind::kFaultLatched));
  EXPECT_EQ(watched_->event(EventKind::kFaultLatched)->fault, ErrorCode::kEmergencyStopped);
  EXPECT_EQ(wait_for_state(*controller_, ProcedureState::kFault).latched_fault,
            ErrorCode::kEmergencyStopped);
  EXPECT_TRUE(watched_->wait_at_rest());
  EXPECT_EQ(controller_->request(protocol::AlignBase{}).error.code, ErrorCode::kFaultLatched);
}

TEST_P(TlsEndToEnd, RevokingTheControllerMidAlignmentClosesItAndTheDeadmanStopsTheBase) {
  ASSERT_NO_FATAL_FAILURE(start_aligning());

  pki_.run("revoke alice");
  reload(daemon_->server(), pki_.server_config());
  EXPECT_TRUE(controller_->wait_closed(10s));
  ASSERT_TRUE(watched_->wait_event(EventKind::kFaultLatched));
  EXPECT_EQ(watched_->event(EventKind::kFaultLatched)->fault, ErrorCode::kDeadman);
  EXPECT_TRUE(watched_->wait_at_rest());
  EXPECT_TRUE(log_.contains("TLS: closing session", "certificate revoked"));
}

INSTANTIATE_TEST_SUITE_P(Drivers, TlsEndToEnd, kE2eDriverKinds, driver_name);

}  // namespace
}  // namespace ajar::test
