#include "ajar/daemon/session_hub.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>

#include <spdlog/spdlog.h>

#include "ajar/daemon/blackbox.hpp"
#include "ajar/protocol/message_table.hpp"

namespace ajar::daemon {
namespace {

using protocol::MessageType;
// Who may send what, which requests are deduplicated and whose Ack is durable: the message table's
// policy columns (protocol/message_table.hpp).
using protocol::is_stop;
using protocol::needs_controller;
namespace rf = protocol::refusal_field;

}  // namespace

SharedFrame encode_frame(const protocol::Envelope& envelope, std::uint8_t minor) {
  std::array<std::uint8_t, protocol::kMaxFrameSize> buffer{};
  const std::size_t size = protocol::encode(envelope, buffer, minor);
  if (size == 0) {
    // Cannot happen for messages built by the daemon (every message fits kMaxFrameSize).
    spdlog::error("cannot encode {} frame",
                  protocol::to_string(protocol::type_of(envelope.message)));
    return nullptr;
  }
  return std::make_shared<const std::vector<std::uint8_t>>(
      buffer.begin(), buffer.begin() + static_cast<long>(size));
}

namespace {
std::string seconds_text(SessionHub::Clock::duration d) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g s", std::chrono::duration<double>(d).count());
  return text;
}
}  // namespace

SessionHub::SessionHub(Engine& engine, Options options)
    : engine_(engine), options_(options), ledger_(options.ledger) {}

void SessionHub::on_open(SessionLink& link) {
  SessionState state;
  state.link = &link;
  state.opened = Clock::now();
  state.last_activity = state.opened;
  sessions_[link.id()] = std::move(state);
  record_session(engine_.recorder(), engine_.daemon_time_ns(), link.id(), "open", link.peer(),
                 link.access().identity, "none", "");
  spdlog::info("session {} opened from {} as {} ({} sessions)", link.id(), link.peer(),
               link.access().identity, sessions_.size());
}

std::string SessionHub::describe(const SessionState& s) const {
  std::string text = "session " + std::to_string(s.link->id());
  if (!s.client_name.empty()) text += " (" + s.client_name + ")";
  return text;
}

void SessionHub::reply(SessionState& s, std::uint32_t request_id, protocol::Message message,
                       std::uint64_t generation) {
  if (!s.held.empty() || generation > engine_.settled_generation()) {
    s.held.push_back(HeldReply{request_id, std::move(message), generation, Clock::now()});
    return;
  }
  send_reply(s, request_id, std::move(message));
}

void SessionHub::handle_recordings(SessionState& s, const protocol::Envelope& envelope) {
  const MessageType type = protocol::type_of(envelope.message);
  if (options_.recordings == nullptr) {
    refuse(s, envelope, ErrorCode::kNotSupported, "",
           "the recorder is off on this daemon (recorder.enabled: false): no recordings");
    return;
  }
  const auto pending = static_cast<std::size_t>(std::count_if(
      s.held.begin(), s.held.end(), [](const HeldReply& h) { return h.ticket != 0; }));
  if (pending >= kMaxRecordingsPending) {
    refuse(s, envelope, ErrorCode::kQueueFull, "",
           std::to_string(kMaxRecordingsPending) +
               " black-box requests of this session are still being answered: retry once "
               "their replies came");
    return;
  }
  const std::uint64_t ticket = next_ticket_++;
  protocol::ErrorReply placeholder;  // replaced by the answer; its type names the request
  placeholder.offending_type = type;
  s.held.push_back(HeldReply{envelope.request_id, placeholder, 0, Clock::now(), ticket});
  spdlog::debug("{}: {} request {}", describe(s), protocol::to_string(type), envelope.request_id);
  options_.recordings->handle(envelope.message,
                              [this, alive = std::weak_ptr<int>(alive_), id = s.link->id(),
                               ticket](protocol::Message answer) {
                                if (alive.expired()) return;  // the hub is gone (shutdown)
                                recordings_answered(id, ticket, std::move(answer));
                              });
}

void SessionHub::recordings_answered(std::uint64_t session_id, std::uint64_t ticket,
                                     protocol::Message answer) {
  const auto it = sessions_.find(session_id);
  if (it == sessions_.end()) return;  // the session closed meanwhile
  SessionState& s = it->second;
  const auto held = std::find_if(s.held.begin(), s.held.end(),
                                 [ticket](const HeldReply& h) { return h.ticket == ticket; });
  if (held == s.held.end()) return;  // answered DRIVER_ERROR already: too late
  held->message = std::move(answer);
  held->ticket = 0;
  release_settled(s, engine_.settled_generation(), Clock::now());
}

void SessionHub::release_settled(SessionState& s, std::uint64_t settled, Clock::time_point now) {
  while (!s.held.empty()) {
    if (s.held.front().ticket != 0) {  // a black-box reply still being made
      if (now - s.held.front().since < kHeldReplyLimit) break;
      HeldReply r = std::move(s.held.front());
      s.held.pop_front();
      const bool shutdown = now == Clock::time_point::max();
      spdlog::warn("{}: the recorder did not answer request {} within {} s{}", describe(s),
                   r.request_id, kHeldReplyLimit.count(),
                   shutdown ? " (shutdown)" : ": refused, its later replies are not held");
      auto error = std::get<protocol::ErrorReply>(std::move(r.message));
      error.code = shutdown ? ErrorCode::kShuttingDown : ErrorCode::kDriverError;
      error.message = shutdown ? "the daemon is shutting down: the recorder did not answer"
                               : "the recorder did not answer within 2 s (a slow disk?): ask again";
      send_reply(s, r.request_id, std::move(error));
      continue;
    }
    const bool saved = s.held.front().generation <= settled;
    if (!saved && now - s.held.front().since < kHeldReplyLimit) break;
    if (!saved) {
      spdlog::warn(
          "{}: the state was not saved within {} s: reply to request {} sent without "
          "waiting for the disk (later replies, a Stop's too, are not held behind it)",
          describe(s), kHeldReplyLimit.count(), s.held.front().request_id);
    }
    HeldReply r = std::move(s.held.front());
    s.held.pop_front();
    send_reply(s, r.request_id, std::move(r.message));
  }
}

void SessionHub::send_reply(SessionState& s, std::uint32_t request_id, protocol::Message message) {
  const MessageType type = protocol::type_of(message);
  auto frame = encode_frame(protocol::Envelope{request_id, 0, std::move(message)}, s.minor);
  if (!frame) {  // a bug (e.g. an Ack body that does not match): the client still gets an answer
    protocol::ErrorReply error;
    error.code = ErrorCode::kInternal;
    error.offending_type = type;
    error.message = "the daemon could not encode its reply";
    frame = encode_frame(protocol::Envelope{request_id, 0, error}, s.minor);
  }
  if (frame) s.link->send(std::move(frame));
}

void SessionHub::refuse(SessionState& s, const protocol::Envelope& envelope, ErrorCode code,
                        std::string_view field, std::string_view message) {
  protocol::ErrorReply error;
  error.code = code;
  error.offending_type = protocol::type_of(envelope.message);
  error.field = field;
  error.message = message;
  spdlog::debug("session {}: {} refused: {} {} ({})", s.link->id(),
                protocol::to_string(error.offending_type), to_string(code), field, message);
  reply(s, envelope.request_id, error);
}

void SessionHub::broadcast(const protocol::Message& message) {
  std::array<SharedFrame, protocol::kVersionMinor + 1> frames;  // encoded once per minor in use
  for (auto& [id, s] : sessions_) {
    if (!s.greeted) continue;
    if (!s.held.empty()) {  // never ahead of a held reply (a durable Ack) of this session
      s.held.push_back(HeldReply{0, message, 0, Clock::now()});
      continue;
    }
    SharedFrame& frame = frames[s.minor];
    if (!frame) frame = encode_frame(protocol::Envelope{0, 0, message}, s.minor);
    if (frame) s.link->send(frame);
  }
}

void SessionHub::announce_controller(std::string_view detail) {
  protocol::Event event;
  event.kind = protocol::EventKind::kControlChanged;
  const protocol::Status status = engine_.status();
  event.state = status.state;
  event.base_motion = status.base_motion;
  event.daemon_time_ns = engine_.daemon_time_ns();  // one clock: since the daemon started
  event.detail = detail;
  spdlog::info("control changed: {}", detail);
  record_event(engine_.recorder(), event);
  broadcast(event);
}

void SessionHub::on_message(SessionLink& link, const protocol::Envelope& envelope) {
  auto it = sessions_.find(link.id());
  if (it == sessions_.end()) return;
  SessionState& s = it->second;
  if (controller_ == link.id()) engine_.controller_heartbeat();
  s.last_activity = Clock::now();

  const MessageType type = protocol::type_of(envelope.message);
  if (refuse_unknown_type(s, envelope)) return;
  if (shutting_down_ && !is_stop(type)) {
    refuse(s, envelope, ErrorCode::kShuttingDown, "",
           "the daemon is shutting down: only Stop and EmergencyStop are executed; reconnect "
           "once it has restarted");
    return;
  }
  if (type == MessageType::kHello) {
    handle_hello(s, envelope);
    return;
  }
  if (is_stop(type)) {  // from any session, greeted or not, unless its certificate may not stop
    handle_stop(link, s, envelope);
    return;
  }
  if (!s.greeted) {
    refuse(s, envelope, ErrorCode::kHelloRequired, "", "send Hello first");
    return;
  }
  if (handle_any_session_request(s, envelope)) return;
  if (needs_controller(type)) {
    handle_command(s, envelope);
    return;
  }
  refuse(s, envelope, ErrorCode::kUnknownMessageType, rf::kHeaderType,
         std::string(protocol::to_string(type)) + " is not handled by this daemon");
}

bool SessionHub::refuse_unknown_type(SessionState& s, const protocol::Envelope& envelope) {
  const MessageType type = protocol::type_of(envelope.message);
  if (!protocol::is_request(type)) {
    refuse(s, envelope, ErrorCode::kUnknownMessageType, rf::kHeaderType,
           std::string(protocol::to_string(type)) +
               " is a daemon-to-host message: the daemon does not accept it");
    return true;
  }
  if (protocol::minor_of(type) > s.minor) {
    refuse(s, envelope, ErrorCode::kUnknownMessageType, rf::kHeaderType,
           std::string(protocol::to_string(type)) + " is defined from protocol 1." +
               std::to_string(protocol::minor_of(type)) + "; this session's Hello said 1." +
               std::to_string(s.minor));
    return true;
  }
  return false;
}

void SessionHub::handle_stop(SessionLink& link, SessionState& s,
                             const protocol::Envelope& envelope) {
  if (!link.access().may_stop) {
    refuse(s, envelope, ErrorCode::kNotController, "",
           "identity " + link.access().identity +
               " may not stop the robot (network.tls.identities: may_stop false)");
    return;
  }
  spdlog::info("{}: {}", describe(s), protocol::to_string(protocol::type_of(envelope.message)));
  engine_.catch_up();
  const EventDeferral after_reply(*this);
  reply(s, envelope.request_id, call_engine(envelope.message));
}

bool SessionHub::handle_any_session_request(SessionState& s, const protocol::Envelope& envelope) {
  switch (protocol::type_of(envelope.message)) {
    case MessageType::kPing: {
      const auto& ping = std::get<protocol::Ping>(envelope.message);
      reply(s, envelope.request_id, protocol::Pong{ping.client_time_ns, engine_.daemon_time_ns()});
      return true;
    }
    case MessageType::kGetStatus: {
      protocol::Status status = engine_.status();
      status.controller_connected = controller_.has_value();
      status.session_count = static_cast<std::uint16_t>(
          std::min<std::size_t>(sessions_.size(), std::numeric_limits<std::uint16_t>::max()));
      reply(s, envelope.request_id, status);
      return true;
    }
    case MessageType::kSubscribe:
      handle_subscribe(s, envelope);
      return true;
    case MessageType::kGetRobotModel:
      reply(s, envelope.request_id, engine_.robot_model());
      return true;
    case MessageType::kListRecordings:
    case MessageType::kFetchRecording:
    case MessageType::kSaveRecording:
      handle_recordings(s, envelope);
      return true;
    default:
      return false;
  }
}

void SessionHub::handle_hello(SessionState& s, const protocol::Envelope& envelope) {
  const auto& hello = std::get<protocol::Hello>(envelope.message);
  if (s.greeted) {
    refuse(s, envelope, ErrorCode::kAlreadyGreeted, "",
           "this session already said Hello; to change role, connect again");
    return;
  }
  if (hello.version_major != protocol::kVersionMajor) {
    refuse(s, envelope, ErrorCode::kUnsupportedVersion, rf::kVersionMajor,
           "this daemon speaks protocol version " + std::to_string(protocol::kVersionMajor) + ".x");
    return;
  }
  engine_.catch_up();  // what happened before this Hello goes out before it (not to this session)
  const EventDeferral after_welcome(*this);  // the old controller's stop: after the Welcome
  std::optional<std::uint64_t> demoted;
  if (hello.requested_role == protocol::Role::kController) {
    if (!s.link->access().may_control) {
      refuse(s, envelope, ErrorCode::kNotController, rf::kRequestedRole,
             "identity " + s.link->access().identity +
                 " may only observe (network.tls.identities); ask for the observer role");
      return;
    }
    if (controller_ && !hello.take_over) {
      refuse(s, envelope, ErrorCode::kControllerBusy, rf::kTakeOver,
             describe(sessions_.at(*controller_)) +
                 " is the controller; send Hello with take_over=true to take control, or ask "
                 "for the observer role");
      return;
    }
    demoted = controller_;
    controller_ = s.link->id();
  }
  s.greeted = true;
  s.minor = std::min(hello.version_minor, protocol::kVersionMinor);
  s.role = hello.requested_role;
  s.client_instance_id = hello.client_instance_id;
  s.client_name = std::string(hello.client_name.view());

  std::string old_name;
  if (demoted) {
    // Stop what the old controller set moving before anyone else commands (DEADMAN if moving).
    auto old = sessions_.find(*demoted);
    old_name = "session " + std::to_string(*demoted);
    if (old != sessions_.end()) {
      old->second.role = protocol::Role::kObserver;
      old_name = describe(old->second);
      record_session(engine_.recorder(), engine_.daemon_time_ns(), *demoted, "role",
                     old->second.link->peer(), old->second.link->access().identity, "observer",
                     "control taken over by session " + std::to_string(s.link->id()));
    }
    engine_.controller_lost();
  }

  protocol::Welcome welcome = engine_.welcome_template();
  welcome.granted_role = s.role;
  welcome.session_id = s.link->id();
  reply(s, envelope.request_id, welcome);
  record_session(engine_.recorder(), engine_.daemon_time_ns(), s.link->id(), "role", s.link->peer(),
                 s.link->access().identity, protocol::to_string(s.role), s.client_name);
  spdlog::info("{} greeted from {} as {} (client instance {:#x})", describe(s), s.link->peer(),
               protocol::to_string(s.role), s.client_instance_id);

  if (s.role != protocol::Role::kController) return;
  announce_controller(demoted ? describe(s) + " took control from " + old_name
                              : describe(s) + " is the controller");
}

void SessionHub::handle_subscribe(SessionState& s, const protocol::Envelope& envelope) {
  const auto& subscribe = std::get<protocol::Subscribe>(envelope.message);
  const double rate_hz = static_cast<double>(subscribe.telemetry_rate_hz);
  if (!std::isfinite(rate_hz) || rate_hz < 0) {
    refuse(s, envelope, ErrorCode::kRateLimited, rf::kTelemetryRate,
           "telemetry rate must be a finite number >= 0 (0 = off)");
    return;
  }
  const double loop_rate_hz = static_cast<double>(engine_.welcome_template().loop_rate_hz);
  const double effective_hz = loop_rate_hz > 0 ? std::min(rate_hz, loop_rate_hz) : rate_hz;
  if (effective_hz <= 0) {
    s.telemetry_period = Clock::duration::zero();
  } else {
    s.telemetry_period =
        std::max<Clock::duration>(std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(1.0 / effective_hz)),
                                  Clock::duration(1));
    s.next_telemetry = Clock::now();
  }
  protocol::Ack ack;
  ack.acknowledged = MessageType::kSubscribe;
  ack.state = engine_.status().state;
  reply(s, envelope.request_id, ack);
}

protocol::Message SessionHub::call_engine(const protocol::Message& request) {
  try {
    return engine_.handle_command(request);
  } catch (const std::exception& e) {
    spdlog::error("engine failed on {}: {}", protocol::to_string(protocol::type_of(request)),
                  e.what());
    protocol::ErrorReply error;
    error.code = ErrorCode::kInternal;
    error.offending_type = protocol::type_of(request);
    error.message.assign(std::string("internal error: ") + e.what());
    return error;
  }
}

void SessionHub::handle_command(SessionState& s, const protocol::Envelope& envelope) {
  const MessageType type = protocol::type_of(envelope.message);
  if (controller_ != s.link->id()) {
    refuse(s, envelope, ErrorCode::kNotController, "",
           "this session is an observer; connect with Hello{requested_role=controller} "
           "(take_over=true to take control from the current controller)");
    return;
  }
  const protocol::MessagePolicy& policy = protocol::policy_of(type);
  const bool deduplicate =
      policy.deduplicated && s.client_instance_id != 0 && envelope.request_id != 0;
  if (deduplicate) {
    if (const protocol::Message* recorded =
            ledger_.find(s.client_instance_id, envelope.request_id, type)) {
      spdlog::info("{}: {} request {} is a repeat: original reply sent again, not executed",
                   describe(s), protocol::to_string(type), envelope.request_id);
      // The original may still be waiting for its save: the repeat waits as long.
      reply(s, envelope.request_id, *recorded, engine_.accepted_generation());
      return;
    }
  }
  spdlog::debug("{}: {} request {}", describe(s), protocol::to_string(type), envelope.request_id);
  engine_.catch_up();  // what happened before this command goes out before its reply
  const EventDeferral after_reply(*this);
  const std::uint64_t before = engine_.accepted_generation();
  protocol::Message answer = call_engine(envelope.message);
  const std::uint64_t after = engine_.accepted_generation();
  const auto* error = std::get_if<protocol::ErrorReply>(&answer);
  const bool executed_or_refused = error == nullptr || error->code != ErrorCode::kQueueFull;
  if (deduplicate && executed_or_refused) {
    ledger_.record(s.client_instance_id, envelope.request_id, type, answer);
  }
  reply(s, envelope.request_id, std::move(answer),
        policy.durable_ack && after > before ? after : 0);
}

void SessionHub::on_decode_error(SessionLink& link, const protocol::DecodeError& error) {
  auto it = sessions_.find(link.id());
  if (it == sessions_.end()) return;
  SessionState& s = it->second;
  if (controller_ == link.id()) engine_.controller_heartbeat();
  s.last_activity = Clock::now();
  protocol::ErrorReply reply_body;
  reply_body.code = error.code;
  reply_body.offending_type = static_cast<MessageType>(error.type);
  reply_body.field = std::string_view(error.field == nullptr ? "" : error.field);
  reply_body.message.assign(protocol::describe(error));
  spdlog::warn("session {} from {}: bad frame: {} field '{}' request {}{}", link.id(), link.peer(),
               to_string(error.code), reply_body.field.view(), error.request_id,
               error.framing_lost ? " (framing lost, closing)" : "");
  reply(s, error.request_id, reply_body);
  if (error.framing_lost) link.close_after_flush("framing lost");
}

void SessionHub::on_closed(SessionLink& link, std::string_view reason) {
  auto it = sessions_.find(link.id());
  if (it == sessions_.end()) return;
  const std::string name = describe(it->second);
  record_session(engine_.recorder(), engine_.daemon_time_ns(), link.id(), "close", link.peer(),
                 link.access().identity,
                 it->second.greeted ? protocol::to_string(it->second.role) : "none", reason);
  sessions_.erase(it);
  spdlog::info("{} closed: {} ({} sessions)", name, reason, sessions_.size());
  if (controller_ == link.id()) {
    controller_.reset();
    engine_.controller_lost();
    announce_controller(name + " (the controller) disconnected; no controller");
  }
}

void SessionHub::on_event(const protocol::Event& event) {
  record_event(engine_.recorder(), event);  // when it happened (its broadcast may be deferred)
  if (deferring_ > 0) {
    deferred_.push_back(event);
    return;
  }
  broadcast(event);
}

SessionHub::EventDeferral::~EventDeferral() {
  if (--hub_.deferring_ > 0) return;
  std::vector<protocol::Event> events = std::move(hub_.deferred_);
  hub_.deferred_.clear();
  for (const protocol::Event& e : events)
    hub_.broadcast(e);
}

void SessionHub::tick(Clock::time_point now) {
  const std::uint64_t settled = engine_.settled_generation();
  std::array<SharedFrame, protocol::kVersionMinor + 1> frames;  // encoded once per minor in use
  std::optional<protocol::Telemetry> telemetry;
  for (auto& [id, s] : sessions_) {
    release_settled(s, settled, now);
    if (!s.greeted && !s.closing && options_.hello_timeout > Clock::duration::zero() &&
        now - s.opened >= options_.hello_timeout) {
      const std::string why = "no Hello within " + seconds_text(options_.hello_timeout) +
                              " (network.hello_timeout_s): closing";
      protocol::ErrorReply error;
      error.code = ErrorCode::kHelloRequired;
      error.offending_type = MessageType::kHello;
      error.message.assign(why);
      send_reply(s, 0, error);
      s.closing = true;
      s.link->close_after_flush(why);
      continue;
    }
    if (s.telemetry_period == Clock::duration::zero() || now < s.next_telemetry) continue;
    if (!telemetry) {
      telemetry = engine_.telemetry();
      record_telemetry(engine_.recorder(), *telemetry);
    }
    SharedFrame& frame = frames[s.minor];
    if (!frame) frame = encode_frame(protocol::Envelope{0, 0, *telemetry}, s.minor);
    if (!frame) return;
    s.link->send(frame);
    s.next_telemetry += s.telemetry_period;
    if (s.next_telemetry < now)
      s.next_telemetry = now + s.telemetry_period;  // no bursts after a stall
  }
}

void SessionHub::release_all() {
  for (auto& [id, s] : sessions_)
    release_settled(s, std::numeric_limits<std::uint64_t>::max(), Clock::time_point::max());
}

bool SessionHub::make_room() {
  auto victim = sessions_.end();
  for (int pass = 0; pass < 2 && victim == sessions_.end(); ++pass) {
    for (auto it = sessions_.begin(); it != sessions_.end(); ++it) {
      const SessionState& s = it->second;
      if (s.closing || controller_ == it->first) continue;
      if (pass == 0 && s.greeted) continue;  // un-greeted sessions go first
      if (victim == sessions_.end() || s.last_activity < victim->second.last_activity) victim = it;
    }
  }
  if (victim == sessions_.end()) return false;
  SessionState& s = victim->second;
  const std::string why = std::string("the session table is full: closing this ") +
                          (s.greeted ? "observer" : "un-greeted session") +
                          " (idle the longest) to make room for a new connection";
  spdlog::warn("{} from {}: {}", describe(s), s.link->peer(), why);
  protocol::ErrorReply error;
  error.code = ErrorCode::kTooManyClients;
  error.offending_type = MessageType::kHello;
  error.message.assign(why);
  release_settled(s, std::numeric_limits<std::uint64_t>::max(), Clock::time_point::max());
  send_reply(s, 0, error);
  s.link->close_after_flush("evicted: session table full");
  sessions_.erase(victim);
  return true;
}

void SessionHub::RefusalHandler::on_message(SessionLink& link, const protocol::Envelope& envelope) {
  const MessageType type = protocol::type_of(envelope.message);
  protocol::Message answer;
  if (is_stop(type) && link.access().may_stop) {  // no table state may refuse a stop
    spdlog::warn("refused connection {} from {}: {} executed", link.id(), link.peer(),
                 protocol::to_string(type));
    hub_.engine_.catch_up();
    const EventDeferral after_reply(hub_);
    answer = hub_.call_engine(envelope.message);
    if (auto frame = encode_frame(protocol::Envelope{envelope.request_id, 0, std::move(answer)})) {
      link.send(std::move(frame));
    }
    return;
  } else {
    protocol::ErrorReply error;
    error.code = ErrorCode::kTooManyClients;
    error.offending_type = type;
    error.message.assign(
        "too many clients: only Stop and EmergencyStop are executed on this "
        "connection; it will be closed");
    answer = error;
  }
  if (auto frame = encode_frame(protocol::Envelope{envelope.request_id, 0, std::move(answer)})) {
    link.send(std::move(frame));
  }
}

void SessionHub::close_all(std::string_view reason) {
  for (auto& [id, s] : sessions_)
    s.link->close_after_flush(reason);
}

}  // namespace ajar::daemon
