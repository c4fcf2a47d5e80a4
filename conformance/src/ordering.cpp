// Order on the wire and sessions' edges (docs/protocol.md 5.7, 6.2, 6.6): a reply comes before
// the events it causes, a zero-count motion is still opened and closed by events, the new
// controller gets its Welcome and then control_changed, an observer's take_over changes nothing.
#include "suite.hpp"

#include <condition_variable>

namespace ajar::conformance {
namespace {

constexpr auto kEvent = static_cast<std::uint16_t>(MessageType::kEvent);

// The events a client saw, in order; shared with its callback (which may outlive a check).
struct EventLog {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<protocol::EventKind> kinds;
};

std::shared_ptr<EventLog> watch_events(Client& c) {
  auto log = std::make_shared<EventLog>();
  c.on_event([log](const protocol::Event& e) {
    std::lock_guard lock(log->mutex);
    log->kinds.push_back(e.kind);
    log->changed.notify_all();
  });
  return log;
}

// Index of the first header at or after `from` that is a reply (not Event/Telemetry) to `id`.
std::optional<std::size_t> reply_index(const std::vector<protocol::FrameHeader>& headers,
                                       std::uint32_t id, std::size_t from = 0) {
  for (std::size_t i = from; i < headers.size(); ++i) {
    const auto t = static_cast<MessageType>(headers[i].type);
    if (headers[i].request_id == id && t != MessageType::kEvent && t != MessageType::kTelemetry)
      return i;
  }
  return std::nullopt;
}

// Waits (bounded) until the log holds every one of `kinds`; false when it does not by then.
bool wait_for_events(EventLog& log, std::initializer_list<protocol::EventKind> kinds,
                     Milliseconds timeout) {
  std::unique_lock lock(log.mutex);
  return log.changed.wait_for(lock, timeout, [&] {
    return std::all_of(kinds.begin(), kinds.end(), [&](protocol::EventKind k) {
      return std::find(log.kinds.begin(), log.kinds.end(), k) != log.kinds.end();
    });
  });
}

// A command of the procedure and the state its Ack must say.
struct Step {
  std::string name;
  protocol::Message message;
  ProcedureState state;
};

// The procedure up to a zero-count alignment: the base already square to the door.
std::vector<Step> steps_to_zero_count_alignment() {
  return {
      {"MeasureDoorWidth",
       protocol::MeasureDoorWidth{base_point(1.0, 0.45, 0.3), base_point(1.0, -0.45, 0.3)},
       ProcedureState::kAwaitingHandle},
      {"MeasureHandle",
       protocol::MeasureHandle{base_point(0.95, -0.35, 0.3), base_point(0.95, -0.23, 0.3)},
       ProcedureState::kAwaitingPlane},
      {"MeasureDoorPlane", door_plane(0.0), ProcedureState::kReadyToAlign},
      {"AlignBase (square already: zero counts)", protocol::AlignBase{}, ProcedureState::kAligned}};
}

// "" when, in the recorded `headers`, each step's reply (ids: its command, then the Ping after
// it) has no Event between it and the previous step's Pong, and at least one before its own Pong.
std::string events_after_replies(const std::vector<protocol::FrameHeader>& headers,
                                 const std::vector<Step>& steps,
                                 const std::vector<std::pair<std::uint32_t, std::uint32_t>>& ids) {
  std::size_t after_previous = 0;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto reply = reply_index(headers, ids[i].first, after_previous);
    const auto pong = reply ? reply_index(headers, ids[i].second, *reply) : std::nullopt;
    if (!reply || !pong) return steps[i].name + ": reply or Pong not recorded";
    for (std::size_t k = after_previous; k < *reply; ++k) {
      if (headers[k].type == kEvent) {
        return steps[i].name + ": an Event arrived before its reply";
      }
    }
    bool caused = false;
    for (std::size_t k = *reply; k < *pong; ++k)
      caused = caused || headers[k].type == kEvent;
    if (!caused) return steps[i].name + ": no event followed its reply (state_changed)";
    after_previous = *pong;
  }
  return std::string{};
}

}  // namespace

std::string Suite::replies_before_their_events() {
  auto c = greeted(Role::kController, true);
  if (!c) return std::string("cannot take control");
  (void)c->request(protocol::Reset{true});
  auto log = watch_events(*c);
  // Each command is followed by a Ping: every event the command caused at once (before the
  // daemon turned to the Ping) arrives before that Pong, so an Event between the previous
  // Pong and a command's reply was sent ahead of that reply.
  (void)c->request(protocol::Ping{1});
  c->record_headers(true);
  const std::vector<Step> steps = steps_to_zero_count_alignment();
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ids;  // command, then its Ping
  for (const Step& s : steps) {
    const Response r = c->request(s.message);
    if (auto e = want_ack(r, s.state); !e.empty()) {
      c->on_event(nullptr);
      return s.name + ": " + e;
    }
    ids.emplace_back(r.request_id, c->request(protocol::Ping{2}).request_id);
  }
  // The zero-count alignment's events.
  if (!wait_for_events(*log,
                       {protocol::EventKind::kMotionStarted, protocol::EventKind::kMotionFinished},
                       timeout())) {
    c->on_event(nullptr);
    return std::string(
        "the zero-count AlignBase was acknowledged but not opened and closed by "
        "motion_started / motion_finished");
  }
  c->on_event(nullptr);
  const auto headers = c->recorded_headers();
  c->record_headers(false);
  return events_after_replies(headers, steps, ids);
}

std::string Suite::observer_take_over_keeps_control() {
  auto ctl = greeted(Role::kController, true);
  auto obs = open();
  if (!ctl || !obs) return std::string("cannot connect");
  const Response w = obs->hello(Role::kObserver, true);
  const auto* welcome = w.get<protocol::Welcome>();
  if (!welcome) return "observer Hello with take_over: " + describe(w);
  if (welcome->granted_role != Role::kObserver) return std::string("granted controller");
  if (auto e = want<protocol::Ack>(ctl->request(protocol::Reset{false})); !e.empty()) {
    return "the controller lost control: " + e;
  }
  return std::string{};
}

std::string Suite::welcome_then_control_changed() {
  auto c = open();
  if (!c) return std::string("cannot connect");
  auto log = watch_events(*c);
  c->record_headers(true);
  const Response w = c->hello(Role::kController, true);
  if (!w.get<protocol::Welcome>()) {
    c->on_event(nullptr);
    return "Hello: " + describe(w);
  }
  const bool seen = wait_for_events(*log, {protocol::EventKind::kControlChanged}, timeout());
  c->on_event(nullptr);
  const auto headers = c->recorded_headers();
  c->record_headers(false);
  if (!seen) return std::string("no control_changed to the new controller");
  if (headers.empty() || headers.front().type != static_cast<std::uint16_t>(MessageType::kWelcome))
    return std::string("the first frame after Hello is not the Welcome");
  return std::string{};
}

void Suite::ordering() {
  moving(
      "order: each reply comes before the events it causes (measurements' state_changed, "
      "AlignBase's motion_started); a zero-count AlignBase is closed by motion_finished",
      [&] { return replies_before_their_events(); });
  check("roles: an observer Hello with take_over = 1 is granted observer; control stays",
        [&] { return observer_take_over_keeps_control(); });
  check("roles: the new controller gets its Welcome, then control_changed",
        [&] { return welcome_then_control_changed(); });
}

}  // namespace ajar::conformance
