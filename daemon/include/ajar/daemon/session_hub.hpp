// SessionHub: the protocol's session rules above the byte streams (docs/operations.md, "Sessions").
//
// - Hello first: any other request before it gets ERROR HELLO_REQUIRED (the session stays open),
//   except Stop and EmergencyStop, which are executed from any session at any time (safety).
//   A second Hello gets ALREADY_GREETED. Hello with another major version: UNSUPPORTED_VERSION.
// - Roles: one controller, any number of observers. Hello{requested_role=controller}:
//     no controller yet              -> granted controller;
//     a controller exists, take_over -> granted controller; the previous controller is demoted to
//                                       observer, engine.controller_lost() stops any motion
//                                       (DEADMAN latches if something moved);
//     a controller exists, no take_over -> ERROR CONTROLLER_BUSY (field "take_over"); the session
//                                       stays un-greeted and may send another Hello.
//   Every change of controller (grant, take-over, controller gone) is an Event CONTROL_CHANGED to
//   every greeted session.
// - Certificates (TLS, session.hpp PeerAccess): an identity without the controller grant asking
//   for control gets NOT_CONTROLLER naming the identity (field requested_role); one without
//   may_stop gets NOT_CONTROLLER for Stop/EmergencyStop. Plaintext sessions may do everything.
// - Commands (Measure*, SetContactPoint, AlignBase, Engage, Reset) need the controller role, else
//   NOT_CONTROLLER. Stop, EmergencyStop, GetStatus, Ping, Subscribe: any greeted session.
// - Any frame from the controller (also an undecodable one) is a heartbeat for the deadman.
//   Controller disconnect -> engine.controller_lost().
// - Exactly-once: commands from a session whose Hello carried a non-zero client_instance_id, with
//   a non-zero request id, go through the RequestLedger: a repeat gets the recorded reply and does
//   not reach the engine. Stop/EmergencyStop always reach the engine (harmless twice, never to be
//   swallowed); QUEUE_FULL replies are not recorded (nothing executed; the retry may execute).
// - Decode errors: ERROR with the code, offending type, field and request id; framing lost
//   (bad magic, oversize) -> that session is closed after the reply; nobody else notices.
// - Events from the engine go to every greeted session; Subscribe{rate} sends Telemetry at that
//   rate (capped at the control loop rate; 0 = off; negative or non-finite: RATE_LIMITED).
//
// Threading: I/O thread only.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/request_ledger.hpp"
#include "ajar/daemon/session.hpp"

namespace ajar::daemon {

class SessionHub final : public SessionHandler {
 public:
  using Clock = std::chrono::steady_clock;

  explicit SessionHub(Engine& engine, RequestLedger::Limits ledger_limits = {});

  void on_open(SessionLink& link) override;
  void on_message(SessionLink& link, const protocol::Envelope& envelope) override;
  void on_decode_error(SessionLink& link, const protocol::DecodeError& error) override;
  void on_closed(SessionLink& link, std::string_view reason) override;

  // Engine events (wire this as the engine's EventSink).
  void on_event(const protocol::Event& event);
  // Sends due telemetry. Call every poll period.
  void tick(Clock::time_point now);
  // Closes every session gracefully (daemon shutdown).
  void close_all(std::string_view reason);

  std::size_t session_count() const noexcept { return sessions_.size(); }
  std::optional<std::uint64_t> controller() const noexcept { return controller_; }
  const RequestLedger& ledger() const noexcept { return ledger_; }

 private:
  struct SessionState {
    SessionLink* link = nullptr;
    bool greeted = false;
    protocol::Role role = protocol::Role::kObserver;
    std::uint64_t client_instance_id = 0;
    std::string client_name;
    Clock::duration telemetry_period{0};  // 0 = not subscribed
    Clock::time_point next_telemetry{};
  };

  void handle_hello(SessionState& s, const protocol::Envelope& envelope);
  void handle_subscribe(SessionState& s, const protocol::Envelope& envelope);
  void handle_command(SessionState& s, const protocol::Envelope& envelope);
  protocol::Message call_engine(const protocol::Message& request);
  void reply(SessionState& s, std::uint32_t request_id, protocol::Message message);
  void refuse(SessionState& s, const protocol::Envelope& envelope, ErrorCode code,
              std::string_view field, std::string_view message);
  void broadcast(const protocol::Message& message);
  void announce_controller(std::string_view detail);
  std::string describe(const SessionState& s) const;

  Engine& engine_;
  RequestLedger ledger_;
  std::map<std::uint64_t, SessionState> sessions_;
  std::optional<std::uint64_t> controller_;
};

}  // namespace ajar::daemon
