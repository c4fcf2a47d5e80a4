// SessionHub: the protocol's session rules above the byte streams (docs/operations.md, "Sessions").
//
// - Hello first: any other request before it gets ERROR HELLO_REQUIRED (the session stays open),
//   except Stop and EmergencyStop, which are executed from any session at any time (safety).
//   A second Hello gets ALREADY_GREETED. Hello with another major version: UNSUPPORTED_VERSION
//   (field "version_major"; the session stays open and un-greeted).
// - Versions: a session speaks protocol 1.m with m = min(Hello.version_minor, kVersionMinor);
//   every frame to it (replies, events, telemetry) has that minor's header and layout, and a type
//   newer than m is refused with UNKNOWN_MESSAGE_TYPE (field "header.type"). Before Hello: ours.
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
// - Commands (Measure*, SetContactPoint, AlignBase, Engage, Reset, Drive, Approach,
//   ResetLoopStatistics) need the controller role, else NOT_CONTROLLER. Stop, EmergencyStop,
//   GetStatus, GetRobotModel, Ping, Subscribe: any greeted session.
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
// - The reply before the events it causes (docs/protocol.md 6.6): before a command the engine
//   catches up (Engine::catch_up(): what happened before goes out first); the events the engine
//   emits while it handles the command (motion_started, state_changed, ...) are broadcast only
//   after the command's reply was sent or queued; on a session with a held reply (a durable Ack)
//   every later event queues behind it too, so it never overtakes that Ack. The same for a Hello
//   that takes control: its Welcome comes before the events of the old controller's stop.
// - Durable Acks: a command that changed the persisted state (Engine::accepted_generation() moved)
//   has its reply held until Engine::settled_generation() reaches that generation (the state
//   store's writer thread finished the save: on disk, or failed with a logged warning — the
//   command was executed, so it is acknowledged). Only that session waits: its later replies
//   queue behind the held one (replies stay in request order); every other session is served at
//   once. Stop and EmergencyStop are executed at once and their own Ack is never held for a save
//   (it only keeps its place behind an earlier held reply of the same session).
//   A reply is never held longer than kHeldReplyLimit: a disk that does not finish a save by then
//   (hung, failing) costs the durability of that Ack, never the session's later replies (a
//   Stop's Ack behind it). The journal says so, once per stall. tick() releases
//   what has settled; release_all() sends everything (shutdown).
// - The black box (1.2: ListRecordings, FetchRecording, SaveRecording): any greeted session,
//   NOT_SUPPORTED without a recorder (Options::recordings null). Handed to the Recordings, which
//   answers from another thread (never a disk access on the I/O thread); the reply takes its
//   place in the session's queue at once (a pending held reply): the session's later replies wait
//   behind it, every other session is served at once. A black box that has not answered within
//   kHeldReplyLimit gets its request answered DRIVER_ERROR ("the recorder did not answer") and its
//   late answer is dropped, so a slow disk never holds a Stop's Ack longer than a durable Ack
//   can be held. At most kMaxRecordingsPending per session (more: QUEUE_FULL, nothing done).
// - Shutdown (begin_shutdown(), SIGTERM): Stop and EmergencyStop are still executed and
//   acknowledged from any session; every other request (Hello and GetStatus included) gets ERROR
//   SHUTTING_DOWN; events, telemetry and held replies still go out until close_all().
// - Hello deadline: a session that has not been greeted `hello_timeout` after it opened gets
//   ERROR HELLO_REQUIRED ("no Hello within ...") and is closed (0 = no deadline).
// - Room for a newcomer (make_room()): when the table is full, the un-greeted session idle the
//   longest is closed (ERROR TOO_MANY_CLIENTS), else the observer idle the longest; never the
//   controller. A connection refused all the same is served by refusal_handler(): its Stop and
//   EmergencyStop are executed (and acknowledged), anything else gets TOO_MANY_CLIENTS.
//
// Threading: I/O thread only.
#pragma once

#include <chrono>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ajar/daemon/recordings.hpp"
#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/request_ledger.hpp"
#include "ajar/daemon/session.hpp"

namespace ajar::daemon {

class SessionHub final : public SessionHandler {
 public:
  using Clock = std::chrono::steady_clock;

  struct Options {
    RequestLedger::Limits ledger;
    Clock::duration hello_timeout{0};  // 0 = none
    Recordings* recordings = nullptr;  // the recorder (1.2); null: NOT_SUPPORTED. Outlives the hub
  };

  explicit SessionHub(Engine& engine) : SessionHub(engine, Options{}) {}
  SessionHub(Engine& engine, Options options);

  void on_open(SessionLink& link) override;
  void on_message(SessionLink& link, const protocol::Envelope& envelope) override;
  void on_decode_error(SessionLink& link, const protocol::DecodeError& error) override;
  // One read's frames are one engine batch: motion they start waits for the end of the read, so
  // a Stop later in the same read cancels it before any wheel turns (Engine::begin_read_batch).
  void on_read_begin(SessionLink&) override { engine_.begin_read_batch(); }
  void on_read_end(SessionLink&) override { engine_.end_read_batch(); }
  void on_closed(SessionLink& link, std::string_view reason) override;
  std::uint8_t frame_minor(const SessionLink& link) const override { return minor_of(link.id()); }

  // Engine events (wire this as the engine's EventSink).
  void on_event(const protocol::Event& event);
  // Sends due telemetry and settled held replies; closes sessions past the Hello deadline. Call
  // every poll period.
  void tick(Clock::time_point now);
  // From now on only Stop and EmergencyStop are executed; the rest gets SHUTTING_DOWN.
  void begin_shutdown() noexcept { shutting_down_ = true; }
  // Sends every held reply, settled or not (shutdown, after the engine flushed its state).
  void release_all();
  // Closes every session gracefully (daemon shutdown): queued frames are flushed first.
  void close_all(std::string_view reason);

  // The table is full: closes the idlest un-greeted session, else the idlest observer (never the
  // controller), and forgets it at once. False when there is none (only the controller is left).
  bool make_room();
  // The handler of connections refused while the table is full (Session::refuse()).
  SessionHandler& refusal_handler() noexcept { return refusal_; }

  std::size_t session_count() const noexcept { return sessions_.size(); }
  // The protocol minor spoken with session `id` (ours before its Hello, or when unknown).
  std::uint8_t minor_of(std::uint64_t id) const noexcept {
    const auto it = sessions_.find(id);
    return it == sessions_.end() ? protocol::kVersionMinor : it->second.minor;
  }
  std::optional<std::uint64_t> controller() const noexcept { return controller_; }
  const RequestLedger& ledger() const noexcept { return ledger_; }

 public:
  static constexpr std::chrono::seconds kHeldReplyLimit{2};
  static constexpr std::size_t kMaxRecordingsPending = 16;

 private:
  struct HeldReply {
    std::uint32_t request_id = 0;
    protocol::Message message;
    std::uint64_t generation = 0;  // released once the engine's settled generation reaches it
    Clock::time_point since{};     // ... or once held for kHeldReplyLimit
    std::uint64_t ticket = 0;      // a black-box reply not there yet (0: `message` is the reply)
  };
  struct SessionState {
    SessionLink* link = nullptr;
    Clock::time_point opened{};
    Clock::time_point last_activity{};  // last frame received
    bool closing = false;               // past the Hello deadline: being closed
    // Replies waiting for durability (and the events behind them), in order. A list: nothing
    // allocated while empty (a std::deque allocates a node at construction, one ~1 KiB
    // HeldReply, for every session: 257 sessions kept 0.26 MiB for nothing).
    std::list<HeldReply> held;
    bool greeted = false;
    protocol::Role role = protocol::Role::kObserver;
    std::uint64_t client_instance_id = 0;
    std::string client_name;
    std::uint8_t minor = protocol::kVersionMinor;  // protocol 1.minor spoken with this session
    Clock::duration telemetry_period{0};           // 0 = not subscribed
    Clock::time_point next_telemetry{};
  };

  // UNKNOWN_MESSAGE_TYPE for a type the session may not send (a daemon-to-host type, or one newer
  // than its Hello's minor); whether it refused.
  bool refuse_unknown_type(SessionState& s, const protocol::Envelope& envelope);
  void handle_hello(SessionState& s, const protocol::Envelope& envelope);
  // Stop and EmergencyStop: from any session, greeted or not, unless its TLS identity may not stop.
  void handle_stop(SessionLink& link, SessionState& s, const protocol::Envelope& envelope);
  // Answers what any greeted session may ask (Ping, GetStatus, Subscribe, GetRobotModel, the
  // black box); false for any other request.
  bool handle_any_session_request(SessionState& s, const protocol::Envelope& envelope);
  void handle_subscribe(SessionState& s, const protocol::Envelope& envelope);
  void handle_command(SessionState& s, const protocol::Envelope& envelope);
  void handle_recordings(SessionState& s, const protocol::Envelope& envelope);
  void recordings_answered(std::uint64_t session_id, std::uint64_t ticket, protocol::Message reply);
  protocol::Message call_engine(const protocol::Message& request);
  // Sends at once unless `generation` is not settled yet or earlier replies are held.
  void reply(SessionState& s, std::uint32_t request_id, protocol::Message message,
             std::uint64_t generation = 0);
  void send_reply(SessionState& s, std::uint32_t request_id, protocol::Message message);
  void release_settled(SessionState& s, std::uint64_t settled,
                       Clock::time_point now = Clock::time_point::min());
  void refuse(SessionState& s, const protocol::Envelope& envelope, ErrorCode code,
              std::string_view field, std::string_view message);
  void broadcast(const protocol::Message& message);
  // Holds the engine's events while a request is handled (RAII; nests); the last one to end
  // broadcasts them, after the request's reply was sent or queued.
  class EventDeferral {
   public:
    explicit EventDeferral(SessionHub& hub) : hub_(hub) { ++hub_.deferring_; }
    ~EventDeferral();
    EventDeferral(const EventDeferral&) = delete;
    EventDeferral& operator=(const EventDeferral&) = delete;

   private:
    SessionHub& hub_;
  };
  void announce_controller(std::string_view detail);
  std::string describe(const SessionState& s) const;

  // Connections refused while the table is full: stops are executed, the rest refused.
  class RefusalHandler final : public SessionHandler {
   public:
    explicit RefusalHandler(SessionHub& hub) : hub_(hub) {}
    void on_open(SessionLink&) override {}
    void on_message(SessionLink& link, const protocol::Envelope& envelope) override;
    void on_decode_error(SessionLink&, const protocol::DecodeError&) override {}
    void on_closed(SessionLink&, std::string_view) override {}

   private:
    SessionHub& hub_;
  };

  Engine& engine_;
  Options options_;
  RequestLedger ledger_;
  RefusalHandler refusal_{*this};
  std::map<std::uint64_t, SessionState> sessions_;
  std::optional<std::uint64_t> controller_;
  bool shutting_down_ = false;
  std::uint64_t next_ticket_ = 1;
  // Black-box answers check it (on the I/O thread) so that none reaches a destroyed hub.
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);
  int deferring_ = 0;                      // EventDeferrals alive
  std::vector<protocol::Event> deferred_;  // events emitted meanwhile, in order
};

}  // namespace ajar::daemon
