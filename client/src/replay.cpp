// ajarctl replay FILE: re-sends the recorded controller sessions' requests with their recorded
// timing to a daemon and reports every reply or event that differs from the recording
// (docs/blackbox.md, "Replay"; what is compared and what is ignored is listed there and in
// compare() below).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "ajar/client/client.hpp"
#include "ajar/recorder/channels.hpp"
#include "ajar/client/output.hpp"
#include "blackbox_cmd.hpp"
#include "session.hpp"

namespace ajar::client {

namespace {

using protocol::MessageType;
using SteadyClock = std::chrono::steady_clock;

// One recorded request and what answered it.
struct Exchange {
  std::uint64_t at_ns = 0;        // daemon time it was received
  std::size_t events_before = 0;  // events the recorded session had received before it
  std::vector<std::uint8_t> frame;
  protocol::Envelope request;
  std::optional<protocol::Message> recorded_reply;
  std::optional<protocol::Message> replayed_reply;
};

struct EventKey {
  protocol::EventKind kind;
  protocol::ProcedureState state;
  ErrorCode fault;
  std::string detail;
  friend bool same(const EventKey& a, const EventKey& b) {
    return a.kind == b.kind && a.state == b.state && a.fault == b.fault;
  }
};

struct ReplaySession {
  std::uint64_t id = 0;                    // the recorded session id
  std::optional<std::uint64_t> closed_ns;  // when the recorded session closed (/ajar/sessions)
  std::vector<Exchange> exchanges;
  std::vector<EventKey> recorded_events;
  // Replay:
  std::unique_ptr<Client> client;
  std::mutex mutex;
  std::vector<EventKey> replayed_events;
  bool connected = false;
};

EventKey key_of(const protocol::Event& e) {
  return {e.kind, e.state, e.fault, std::string(e.detail.view())};
}

// Types not re-sent: the black box's own requests (a replay saves and fetches nothing).
bool replayed(MessageType t) {
  return t != MessageType::kListRecordings && t != MessageType::kFetchRecording &&
         t != MessageType::kSaveRecording;
}

std::string event_text_of(const EventKey& e) {
  std::string text =
      std::string(protocol::to_string(e.kind)) + " -> " + std::string(protocol::to_string(e.state));
  if (e.fault != ErrorCode::kOk) text += " " + std::string(to_string(e.fault));
  return text;
}

std::string reply_text(const protocol::Message& m) {
  std::ostringstream s;
  const auto type = protocol::type_of(m);
  if (const auto* e = std::get_if<protocol::ErrorReply>(&m)) {
    s << "Error " << to_string(e->code);
    if (e->field.length > 0) s << " (" << e->field.view() << ")";
    s << ": " << e->message.view();
  } else if (const auto* a = std::get_if<protocol::Ack>(&m)) {
    s << "Ack, state " << protocol::to_string(a->state);
  } else if (const auto* st = std::get_if<protocol::Status>(&m)) {
    s << "Status, state " << protocol::to_string(st->state) << ", fault "
      << to_string(st->latched_fault);
  } else {
    s << protocol::to_string(type);
  }
  return s.str();
}

bool near(double a, double b) {
  return std::fabs(a - b) <= 1e-6 * std::max({1.0, std::fabs(a), std::fabs(b)});
}
bool near(const core::Vec3& a, const core::Vec3& b) {
  return near(a.x(), b.x()) && near(a.y(), b.y()) && near(a.z(), b.z());
}
bool same_span(const protocol::SpanAck& a, const protocol::SpanAck& b) {
  return near(a.length_m, b.length_m) && a.direction == b.direction &&
         near(a.p1_base_m, b.p1_base_m) && near(a.p2_base_m, b.p2_base_m);
}
bool same_plane(const protocol::PlaneAck& a, const protocol::PlaneAck& b) {
  return near(a.normal, b.normal) && near(a.yaw_deviation_rad, b.yaw_deviation_rad) &&
         a.left_counts == b.left_counts && a.right_counts == b.right_counts &&
         near(a.rms_residual_m, b.rms_residual_m) && a.point_count == b.point_count;
}
bool same_contact(const protocol::ContactAck& a, const protocol::ContactAck& b) {
  return near(a.contact_base_m, b.contact_base_m) && near(a.reach_margin_m, b.reach_margin_m);
}
bool same_approach(const protocol::ApproachAck& a, const protocol::ApproachAck& b) {
  return near(a.travel_m, b.travel_m) && near(a.start_distance_m, b.start_distance_m) &&
         a.left_counts == b.left_counts && a.right_counts == b.right_counts;
}

// What differs between the recorded and the replayed reply, or "" when they agree. Compared:
// the reply's type; Ack: acknowledged, state and the body's values (1e-6 relative); Error: code,
// offending type and field (not the sentence); Status: state (unless one side is mid-motion:
// aligning, engaging), latched fault, which measurements are stored and their values; Welcome: the
// granted role. Not compared (they legitimately
// differ): times (Pong, Event.daemon_time_ns, loop statistics and timing), session ids, the
// odometry and motion block of Status, Welcome's limits and version, RobotModel (the daemon's
// config), texts (Error.message, Event.detail).
std::string compare(const protocol::Message& recorded, const protocol::Message& now) {
  if (recorded.index() != now.index()) return "another reply";
  if (const auto* r = std::get_if<protocol::ErrorReply>(&recorded)) {
    const auto& n = std::get<protocol::ErrorReply>(now);
    if (r->code != n.code) return "another error code";
    if (r->field.view() != n.field.view()) return "another field";
    if (r->offending_type != n.offending_type) return "another offending type";
    return "";
  }
  if (const auto* r = std::get_if<protocol::Ack>(&recorded)) {
    const auto& n = std::get<protocol::Ack>(now);
    if (r->acknowledged != n.acknowledged) return "acknowledges another type";
    if (r->state != n.state) return "another state";
    if (r->body.index() != n.body.index()) return "another body";
    const bool same = std::visit(
        [&](const auto& body) {
          using T = std::decay_t<decltype(body)>;
          const auto& other = std::get<T>(n.body);
          if constexpr (std::is_same_v<T, protocol::SpanAck>) return same_span(body, other);
          if constexpr (std::is_same_v<T, protocol::PlaneAck>) return same_plane(body, other);
          if constexpr (std::is_same_v<T, protocol::ContactAck>) return same_contact(body, other);
          if constexpr (std::is_same_v<T, protocol::ApproachAck>) return same_approach(body, other);
          return true;
        },
        r->body);
    return same ? "" : "other derived values";
  }
  if (const auto* r = std::get_if<protocol::Status>(&recorded)) {
    const auto& n = std::get<protocol::Status>(now);
    // A status asked while a motion runs shows a state that depends on timing (aligning or
    // already aligned): the state is compared when neither side is mid-motion.
    const auto moving = [](protocol::ProcedureState s) {
      return s == protocol::ProcedureState::kAligning || s == protocol::ProcedureState::kEngaging;
    };
    if (r->state != n.state && !moving(r->state) && !moving(n.state)) return "another state";
    if (r->latched_fault != n.latched_fault) return "another latched fault";
    if (r->has_width != n.has_width || (r->has_width && !same_span(r->width, n.width)))
      return "another stored width";
    if (r->has_handle != n.has_handle || (r->has_handle && !same_span(r->handle, n.handle)))
      return "another stored handle";
    if (r->has_plane != n.has_plane || (r->has_plane && !same_plane(r->plane, n.plane)))
      return "another stored plane";
    if (r->has_contact != n.has_contact || (r->has_contact && !same_contact(r->contact, n.contact)))
      return "another stored contact point";
    return "";
  }
  if (const auto* r = std::get_if<protocol::Welcome>(&recorded)) {
    return r->granted_role == std::get<protocol::Welcome>(now).granted_role ? "" : "another role";
  }
  return "";
}

// Longest common subsequence of two event lists (kind, state, fault): the events only one side has.
void diff_events(const std::vector<EventKey>& a, const std::vector<EventKey>& b,
                 std::vector<std::size_t>& only_a, std::vector<std::size_t>& only_b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::uint32_t>> l(n + 1, std::vector<std::uint32_t>(m + 1, 0));
  for (std::size_t i = n; i-- > 0;) {
    for (std::size_t j = m; j-- > 0;) {
      l[i][j] = same(a[i], b[j]) ? l[i + 1][j + 1] + 1 : std::max(l[i + 1][j], l[i][j + 1]);
    }
  }
  std::size_t i = 0, j = 0;
  while (i < n && j < m) {
    if (same(a[i], b[j])) {
      ++i;
      ++j;
    } else if (l[i + 1][j] >= l[i][j + 1]) {
      only_a.push_back(i++);
    } else {
      only_b.push_back(j++);
    }
  }
  for (; i < n; ++i)
    only_a.push_back(i);
  for (; j < m; ++j)
    only_b.push_back(j);
}

// The recorded controller sessions: every session granted the controller role, with its requests
// paired with the replies of the same request id that followed them, and its events.
// When each recorded session closed (the /ajar/sessions channel), by session id.
std::map<std::uint64_t, std::uint64_t> session_closes(const recorder::McapFile& file) {
  std::map<std::uint64_t, std::uint64_t> closes;
  const auto* row = recorder::channel_by_id(recorder::kSessionsChannel);
  const recorder::McapChannel* channel = row ? file.channel(row->topic) : nullptr;
  if (channel == nullptr) return closes;
  for (const auto& m : file.messages) {
    if (m.channel_id != channel->id) continue;
    const auto data = file.data(m);
    const auto j = nlohmann::json::parse(data.begin(), data.end(), nullptr, false);
    if (!j.is_object() || j.value("change", std::string()) != "close") continue;
    closes[j.value("session_id", std::uint64_t{0})] = j.value("daemon_time_ns", std::uint64_t{0});
  }
  return closes;
}

std::vector<std::unique_ptr<ReplaySession>> controller_sessions(
    const std::vector<WireRecord>& wires) {
  std::set<std::uint64_t> controllers;
  for (const auto& w : wires) {
    if (w.in || !w.envelope) continue;
    if (const auto* welcome = std::get_if<protocol::Welcome>(&w.envelope->message)) {
      if (welcome->granted_role == protocol::Role::kController) controllers.insert(w.session_id);
    }
  }
  std::map<std::uint64_t, std::unique_ptr<ReplaySession>> sessions;
  for (const auto& w : wires) {
    if (!controllers.count(w.session_id) || !w.envelope) continue;
    auto& s = sessions[w.session_id];
    if (!s) {
      s = std::make_unique<ReplaySession>();
      s->id = w.session_id;
    }
    const auto type = protocol::type_of(w.envelope->message);
    if (w.in) {
      if (!replayed(type)) continue;
      Exchange e;
      e.at_ns = w.daemon_time_ns;
      e.events_before = s->recorded_events.size();
      e.frame = w.frame;
      e.request = *w.envelope;
      s->exchanges.push_back(std::move(e));
    } else if (const auto* event = std::get_if<protocol::Event>(&w.envelope->message)) {
      s->recorded_events.push_back(key_of(*event));
    } else if (type != MessageType::kTelemetry) {
      // The reply of the earliest request with this id that has none yet.
      for (auto& e : s->exchanges) {
        if (e.request.request_id == w.envelope->request_id && !e.recorded_reply) {
          e.recorded_reply = w.envelope->message;
          break;
        }
      }
    }
  }
  std::vector<std::unique_ptr<ReplaySession>> out;
  for (auto& [id, s] : sessions)
    if (!s->exchanges.empty()) out.push_back(std::move(s));
  return out;
}

// A Hello with a fresh client_instance_id (the daemon replayed against must not take the
// replay's requests for repeats of the recording's), in the frame's own minor version.
std::vector<std::uint8_t> frame_to_send(const Exchange& e, std::uint64_t instance_id) {
  const auto* hello = std::get_if<protocol::Hello>(&e.request.message);
  if (hello == nullptr || hello->client_instance_id == 0) return e.frame;
  protocol::Envelope changed = e.request;
  std::get<protocol::Hello>(changed.message).client_instance_id = instance_id;
  std::vector<std::uint8_t> out;
  const std::uint8_t minor = e.frame.size() > 5 ? e.frame[5] : protocol::kVersionMinor;
  if (!protocol::encode_append(changed, out, std::min(minor, protocol::kVersionMinor))) {
    return e.frame;
  }
  return out;
}

// The replies the session's client has received, each given to the request it answers.
void collect(ReplaySession& s) {
  while (auto reply = s.client->wait_reply(std::nullopt, Milliseconds{0})) {
    for (auto& e : s.exchanges) {
      if (e.request.request_id == reply->request_id && !e.replayed_reply && e.recorded_reply) {
        e.replayed_reply = reply->message;
        break;
      }
    }
  }
}

// The replies still owed to the session's requests, until `deadline`.
void await_replies(ReplaySession& s, SteadyClock::time_point deadline) {
  collect(s);
  for (auto& e : s.exchanges) {
    while (e.recorded_reply && !e.replayed_reply && SteadyClock::now() < deadline &&
           s.client->connected()) {
      std::this_thread::sleep_for(Milliseconds{2});
      collect(s);
    }
  }
}

// Until the replayed session has received `count` events, `until` passes or the user interrupts.
void await_events(ReplaySession& s, std::size_t count, SteadyClock::time_point until) {
  for (;;) {
    {
      std::lock_guard lock(s.mutex);
      if (s.replayed_events.size() >= count) break;
    }
    if (SteadyClock::now() >= until || interrupted()) break;
    std::this_thread::sleep_for(Milliseconds{2});
  }
}

// replay FILE [--settle S]; nullopt after a usage error (said on `err`).
struct ReplayArgs {
  std::string path;
  double settle_s = 2.0;
};
std::optional<ReplayArgs> parse_replay_args(const Command& command, std::ostream& err) {
  ReplayArgs r;
  for (std::size_t i = 0; i < command.args.size(); ++i) {
    const std::string& a = command.args[i];
    if (a == "--settle" && i + 1 < command.args.size()) {
      try {
        r.settle_s = std::stod(command.args[++i]);
      } catch (const std::exception&) {
        r.settle_s = -1;
      }
      if (!(r.settle_s >= 0 && r.settle_s <= 600)) {
        err << "ajarctl: replay: --settle wants seconds 0..600\n";
        return std::nullopt;
      }
    } else if (r.path.empty() && !a.starts_with("-")) {
      r.path = a;
    } else {
      err << "ajarctl: replay: unexpected '" << a << "' (usage: replay FILE [--settle S])\n";
      return std::nullopt;
    }
  }
  if (r.path.empty()) {
    err << "ajarctl: replay wants FILE (usage: replay FILE [--settle S])\n";
    return std::nullopt;
  }
  return r;
}

// A request of a recorded session, or where the recorded session closed.
struct Step {
  ReplaySession* session;
  Exchange* exchange;  // nullptr: the recorded session closed here
  std::uint64_t at_ns;
};

// Every request of every session, and each session's close after its last request, in recorded
// order.
std::vector<Step> replay_steps(std::vector<std::unique_ptr<ReplaySession>>& sessions,
                               const recorder::McapFile& file) {
  std::vector<Step> steps;
  const auto closes = session_closes(file);
  for (auto& s : sessions) {
    for (auto& e : s->exchanges)
      steps.push_back({s.get(), &e, e.at_ns});
    if (const auto c = closes.find(s->id);
        c != closes.end() && c->second >= s->exchanges.back().at_ns) {
      s->closed_ns = c->second;
      steps.push_back({s.get(), nullptr, c->second});
    }
  }
  std::stable_sort(steps.begin(), steps.end(),
                   [](const Step& a, const Step& b) { return a.at_ns < b.at_ns; });
  return steps;
}

// Plays the steps against the daemon at their recorded times, one client per recorded session:
// each request after the events its session had received before it (at most --settle; the time
// waited delays the rest), each recorded close as a close of the replayed session.
class Replayer {
 public:
  Replayer(const GlobalOptions& options, Milliseconds settle, std::uint64_t t0_ns)
      : options_(options), settle_(settle), t0_ns_(t0_ns) {
    client_options_.connect_timeout =
        Milliseconds(std::max<long>(1000, std::lround(options.timeout_s * 1000)));
    client_options_.tls = options.tls;
    client_options_.client_name = "ajarctl replay";
    start_ = SteadyClock::now();
  }

  // kExitOk, or the exit code it stopped with (interrupted, no connection: said on `err`).
  int play(const std::vector<Step>& steps, std::ostream& err) {
    for (const Step& step : steps) {
      ReplaySession& s = *step.session;
      std::this_thread::sleep_until(start_ + late_ + std::chrono::nanoseconds(step.at_ns - t0_ns_));
      if (interrupted()) {
        err << "ajarctl: replay interrupted\n";
        return kExitConnection;
      }
      if (step.exchange == nullptr) {  // the recorded session closed: so does the replayed one
        close(s);
        continue;
      }
      // The operator reacted to what the session had seen: wait (at most --settle) for the events
      // the recorded session had received before this request.
      if (s.client) {
        const auto wait_until = SteadyClock::now() + settle_;
        const auto begin = SteadyClock::now();
        await_events(s, step.exchange->events_before, wait_until);
        late_ += SteadyClock::now() - begin;
      }
      if (!s.client && !connect(s, err)) return kExitConnection;
      s.client->send_raw(frame_to_send(*step.exchange, rng_() | 1));
      collect(s);
    }
    return kExitOk;
  }

 private:
  // Once its replies and the events the recorded session had got before it closed came (at most
  // --settle).
  void close(ReplaySession& s) {
    if (!s.client) return;
    const auto until = SteadyClock::now() + settle_;
    await_replies(s, until);
    await_events(s, s.recorded_events.size(), until);
    s.client->close();
  }
  bool connect(ReplaySession& s, std::ostream& err) {
    s.client = std::make_unique<Client>(client_options_);
    s.client->on_event([&s](const protocol::Event& e) {
      std::lock_guard lock(s.mutex);
      s.replayed_events.push_back(key_of(e));
    });
    if (const auto c = s.client->connect(options_.endpoint); !c) {
      err << "ajarctl: replay: connect: " << c.error().message << "\n";
      return false;
    }
    s.connected = true;
    return true;
  }

  std::mt19937_64 rng_{std::random_device{}()};
  const GlobalOptions& options_;
  ClientOptions client_options_;
  Milliseconds settle_;
  std::uint64_t t0_ns_;
  SteadyClock::time_point start_;
  std::chrono::nanoseconds late_{0};  // how far the replay fell behind the recording (event waits)
};

// The session's differences from the recording, each a line on `out`: replies (at +seconds from
// `t0_ns`) and events; how many.
std::size_t report_differences(ReplaySession& s, std::uint64_t t0_ns, std::ostream& out) {
  std::size_t differences = 0;
  const auto when = [&](const Exchange& e) {
    char text[32];
    std::snprintf(text, sizeof text, "+%.3f s", static_cast<double>(e.at_ns - t0_ns) * 1e-9);
    return std::string(text);
  };
  for (const auto& e : s.exchanges) {
    if (!e.recorded_reply) continue;  // none recorded (the recording was cut): nothing to hold
    const std::string what = std::string(protocol::to_string(protocol::type_of(e.request.message)));
    std::string why;
    if (!e.replayed_reply) {
      why = "no reply";
    } else {
      why = compare(*e.recorded_reply, *e.replayed_reply);
    }
    if (why.empty()) continue;
    ++differences;
    out << "DIFFERENCE session " << s.id << " request " << e.request.request_id << " " << what
        << " at " << when(e) << ": " << why << "\n  recorded: " << reply_text(*e.recorded_reply)
        << "\n  replayed: " << (e.replayed_reply ? reply_text(*e.replayed_reply) : "(none)")
        << "\n";
  }
  std::vector<EventKey> replayed_events;
  {
    std::lock_guard lock(s.mutex);
    replayed_events = s.replayed_events;
  }
  std::vector<std::size_t> only_recorded, only_replayed;
  diff_events(s.recorded_events, replayed_events, only_recorded, only_replayed);
  for (const std::size_t i : only_recorded) {
    ++differences;
    out << "DIFFERENCE session " << s.id << " event " << event_text_of(s.recorded_events[i])
        << ": recorded, not replayed (" << s.recorded_events[i].detail << ")\n";
  }
  for (const std::size_t i : only_replayed) {
    ++differences;
    out << "DIFFERENCE session " << s.id << " event " << event_text_of(replayed_events[i])
        << ": replayed, not recorded (" << replayed_events[i].detail << ")\n";
  }
  return differences;
}

}  // namespace

int run_replay(const Command& command, const GlobalOptions& options, std::ostream& out,
               std::ostream& err) {
  const auto args = parse_replay_args(command, err);
  if (!args) return kExitUsage;
  const std::string& path = args->path;
  std::string error;
  const recorder::McapFile file = recorder::read_mcap(path, &error);
  if (!file.is_mcap) {
    err << "ajarctl: " << error << "\n";
    return kExitRefused;
  }
  if (!file.complete) err << "note: " << path << ": " << file.problem << "\n";
  std::string problem;
  const auto wires = wire_records(file, &problem);
  if (!problem.empty()) err << "note: " << problem << "\n";
  auto sessions = controller_sessions(wires);
  if (sessions.empty()) {
    err << "ajarctl: replay: " << path << " holds no controller session to replay\n";
    return kExitRefused;
  }

  const std::vector<Step> steps = replay_steps(sessions, file);
  std::size_t requests = 0;
  for (const auto& step : steps)
    requests += step.exchange != nullptr ? 1 : 0;
  std::uint64_t last_recorded_ns = 0;
  for (const auto& w : wires)
    last_recorded_ns = std::max(last_recorded_ns, w.daemon_time_ns);

  const std::uint64_t t0_ns = steps.front().at_ns;
  const auto settle =
      std::chrono::duration_cast<Milliseconds>(std::chrono::duration<double>(args->settle_s));
  Replayer replayer(options, settle, t0_ns);
  out << "replaying " << requests << " requests of " << sessions.size()
      << " controller session(s) from " << path << " ("
      << (static_cast<double>(steps.back().at_ns - t0_ns) * 1e-9) << " s)\n";
  if (const int code = replayer.play(steps, err); code != kExitOk) return code;
  // The replies still owed, then the events of the recording's tail.
  const auto tail = std::chrono::nanoseconds(last_recorded_ns - steps.back().at_ns);
  const auto deadline = SteadyClock::now() + tail + settle;
  for (auto& s : sessions) {
    if (!s->closed_ns) await_replies(*s, deadline);
  }
  std::this_thread::sleep_until(deadline);

  std::size_t differences = 0;
  for (auto& s : sessions) {
    differences += report_differences(*s, t0_ns, out);
    s->client->close();
  }
  out << (differences == 0 ? "no difference" : std::to_string(differences) + " difference(s)")
      << " in " << requests << " requests and their events\n";
  return differences == 0 ? kExitOk : kExitRefused;
}

}  // namespace ajar::client
