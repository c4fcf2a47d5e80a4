#include "session.hpp"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <thread>

namespace ajar::client {

namespace {
std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) {
  g_interrupted.store(true);
}
}  // namespace

void catch_interrupts() {
  g_interrupted.store(false);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  std::signal(SIGHUP, on_interrupt);  // a closed terminal: leave like Ctrl-C (drive stops the base)
  std::signal(SIGPIPE, SIG_IGN);
}

bool interrupted() {
  return g_interrupted.load();
}

Milliseconds seconds_to_ms(double s) {
  return Milliseconds{static_cast<std::int64_t>(std::llround(s * 1000.0))};
}

int exit_code(const Response& r) {
  switch (r.outcome) {
    case CallOutcome::kReply:
      return kExitOk;
    case CallOutcome::kRefused:
      return kExitRefused;
    case CallOutcome::kTimeout:
    case CallOutcome::kDisconnected:
      return kExitConnection;
  }
  return kExitConnection;
}

Session::Session(const GlobalOptions& options, std::ostream& out, std::ostream& err)
    : options_(options), out_(out), err_(err), client_(client_options(options)) {
  client_.on_event([this](const protocol::Event& e) {
    {
      std::lock_guard lock(latest_mutex_);
      events_.push_back(e.kind);
      if (events_.size() > 1024) events_.erase(events_.begin());
    }
    if (show_events_.load()) print(event_object(e, session_minor()), event_text(e));
  });
  client_.on_telemetry([this](const protocol::Telemetry& t) {
    {
      std::lock_guard lock(latest_mutex_);
      latest_ = t;
      ++telemetry_count_;
    }
    if (show_telemetry_.load()) print(telemetry_object(t, session_minor()), telemetry_text(t));
  });
}

// The minor of this session's Welcome (handlers run without the client's locks): events and
// telemetry are printed in its layout, as replies are (Response::session_minor).
std::uint8_t Session::session_minor() const {
  const auto w = client_.welcome();
  return w ? w->version_minor : protocol::kVersionMinor;
}

ClientOptions Session::client_options(const GlobalOptions& o) {
  ClientOptions c;
  c.request_timeout = seconds_to_ms(o.timeout_s);
  c.connect_timeout = std::max(seconds_to_ms(o.timeout_s), Milliseconds{1000});
  c.retries = o.retries;
  c.client_name = "ajarctl";
  c.tls = o.tls;
  return c;
}

// Connects and says Hello once; later calls reuse the session.
int Session::open(bool controller) {
  if (greeted_) return kExitOk;
  if (const auto connected = client_.connect(options_.endpoint); !connected) {
    print_error("connect", kDisconnectedCode, connected.error().message);
    return kExitConnection;
  }
  const Response r =
      client_.hello(controller ? protocol::Role::kController : protocol::Role::kObserver,
                    controller && options_.take_over);
  if (!r.ok()) {
    print(response_object("hello", r), response_text("hello", r));
    return exit_code(r);
  }
  greeted_ = true;
  return kExitOk;
}

int Session::execute(const Command& c) {
  switch (c.kind) {
    case Command::Kind::kRequest:
    case Command::Kind::kStatus: {
      const Response r = client_.request(c.request);
      print(response_object(c.name, r), response_text(c.name, r));
      return exit_code(r);
    }
    case Command::Kind::kPing:
      return ping(c);
    case Command::Kind::kWatch:
      return watch(c);
    case Command::Kind::kAlign:
    case Command::Kind::kEngage:
      return motion(c);
    case Command::Kind::kDrive:
      return c.duration_s > 0 ? drive_for(c) : drive_keys(c);
    case Command::Kind::kApproach:
      return approach(c);
    case Command::Kind::kSleep: {
      client_.set_heartbeat(Milliseconds{100});
      std::this_thread::sleep_for(seconds_to_ms(c.duration_s));
      client_.set_heartbeat(Milliseconds{0});
      return kExitOk;
    }
    case Command::Kind::kHelp: {
      std::lock_guard lock(print_mutex_);
      out_ << (c.args.empty() ? usage() : command_help(c.args[0]));
      out_.flush();
      return kExitOk;
    }
    case Command::Kind::kConformance:
    case Command::Kind::kSimulate:
    case Command::Kind::kScript:
    case Command::Kind::kBlackbox:
    case Command::Kind::kReplay:
      print_error(c.name, "USAGE", c.name + " cannot run inside a session");
      return kExitUsage;
  }
  return kExitUsage;
}

void Session::print(const JsonObject& json, const std::string& text) {
  std::lock_guard lock(print_mutex_);
  if (options_.json) {
    out_ << json.str() << '\n';
  } else {
    out_ << text << '\n';
  }
  out_.flush();
}

void Session::print_error(std::string_view command, std::string_view code,
                          const std::string& message) {
  JsonObject o;
  o.add("type", "error").add("command", command).add("ok", false);
  o.add("error", error_object(code, "", message));
  std::lock_guard lock(print_mutex_);
  if (options_.json) {
    out_ << o.str() << '\n';
  } else {
    err_ << "ajarctl: " << command << ": " << message << '\n';
  }
  out_.flush();
}

int Session::ping(const Command& c) {
  std::vector<double> rtts_ms;
  int last_failure = kExitOk;
  for (int i = 0; i < c.count && !interrupted(); ++i) {
    protocol::Ping p;
    p.client_time_ns = static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
            .count());
    const auto start = Clock::now();
    const Response r = client_.request(p);
    const double rtt_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    if (!r.ok()) {
      print(response_object("ping", r), response_text("ping", r));
      last_failure = exit_code(r);
      if (r.outcome == CallOutcome::kDisconnected) break;
    } else {
      rtts_ms.push_back(rtt_ms);
      JsonObject o;
      o.add("type", "pong").add("command", "ping").add("ok", true).add("seq", i + 1);
      o.add("rtt_ms", rtt_ms);
      char text[96];
      std::snprintf(text, sizeof text, "pong seq=%d rtt=%.3f ms", i + 1, rtt_ms);
      print(o, text);
    }
    if (c.interval_s > 0 && i + 1 < c.count) {
      std::this_thread::sleep_for(seconds_to_ms(c.interval_s));
    }
  }
  JsonObject o;
  o.add("type", "ping_stats").add("command", "ping").add("ok", !rtts_ms.empty());
  o.add("sent", c.count).add("received", static_cast<int>(rtts_ms.size()));
  std::string text = std::to_string(rtts_ms.size()) + "/" + std::to_string(c.count) + " replies";
  if (!rtts_ms.empty()) {
    std::sort(rtts_ms.begin(), rtts_ms.end());
    double sum = 0;
    for (double v : rtts_ms)
      sum += v;
    // Nearest-rank percentile.
    const auto rank =
        static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(rtts_ms.size())));
    const double p99 = rtts_ms[std::clamp<std::size_t>(rank, 1, rtts_ms.size()) - 1];
    const double avg = sum / static_cast<double>(rtts_ms.size());
    o.add("min_ms", rtts_ms.front()).add("avg_ms", avg).add("max_ms", rtts_ms.back());
    o.add("p99_ms", p99);
    char line[160];
    std::snprintf(line, sizeof line, ", rtt min/avg/max/p99 = %.3f/%.3f/%.3f/%.3f ms",
                  rtts_ms.front(), avg, rtts_ms.back(), p99);
    text += line;
  }
  print(o, text);
  if (rtts_ms.empty()) return last_failure == kExitOk ? kExitConnection : last_failure;
  return last_failure;
}

int Session::watch(const Command& c) {
  protocol::Subscribe s;
  s.telemetry_rate_hz = static_cast<float>(c.rate_hz);
  Response r = client_.request(s);
  if (!r.ok()) {
    print(response_object("watch", r), response_text("watch", r));
    return exit_code(r);
  }
  show_events_ = true;
  show_telemetry_ = true;
  const auto end = Clock::now() + seconds_to_ms(c.duration_s);
  while (!interrupted() && client_.connected() && (c.duration_s <= 0 || Clock::now() < end)) {
    std::this_thread::sleep_for(Milliseconds{50});
  }
  show_telemetry_ = false;
  show_events_ = false;
  if (!client_.connected()) {
    print_error("watch", kDisconnectedCode, "connection lost");
    return kExitConnection;
  }
  (void)client_.request(protocol::Subscribe{});
  return kExitOk;
}

std::optional<protocol::RobotModel> Session::robot_model(std::string_view command) {
  const Response r = client_.request(protocol::GetRobotModel{});
  if (const auto* m = r.get<protocol::RobotModel>()) return *m;
  print(response_object(command, r), response_text(command, r));
  return std::nullopt;
}

std::uint64_t Session::telemetry_count() {
  std::lock_guard lock(latest_mutex_);
  return telemetry_count_;
}

// Waits (bounded) for a Telemetry after the first `after` that shows the base at rest.
bool Session::wait_at_rest(std::uint64_t after, double seconds) {
  const auto deadline = Clock::now() + seconds_to_ms(seconds);
  while (Clock::now() < deadline && client_.connected()) {
    {
      std::lock_guard lock(latest_mutex_);
      if (telemetry_count_ > after && !latest_.moving) return true;
    }
    std::this_thread::sleep_for(Milliseconds{20});
  }
  return false;
}

}  // namespace ajar::client
