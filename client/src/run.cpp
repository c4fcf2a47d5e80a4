#include <algorithm>
#include <atomic>
#include <csignal>
#include <fstream>
#include <iostream>
#include <mutex>
#include <numbers>
#include <thread>

#include "ajar/client/cli.hpp"
#include "ajar/client/conformance.hpp"
#include "ajar/client/output.hpp"
#include "ajar/client/simulate.hpp"
#include "ajar/version.hpp"

namespace ajar::client {

namespace {

using Clock = std::chrono::steady_clock;

std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) {
  g_interrupted.store(true);
}

Milliseconds seconds_to_ms(double s) {
  return Milliseconds{static_cast<std::int64_t>(std::llround(s * 1000.0))};
}

int exit_code(const Response& r) {
  switch (r.outcome) {
    case Outcome::kReply:
      return kExitOk;
    case Outcome::kRefused:
      return kExitRefused;
    case Outcome::kTimeout:
    case Outcome::kDisconnected:
      return kExitConnection;
  }
  return kExitConnection;
}

// One connection and one Hello, shared by the commands of a session.
class Session {
 public:
  Session(const GlobalOptions& options, std::ostream& out, std::ostream& err)
      : options_(options), out_(out), err_(err), client_(client_options(options)) {
    client_.on_event([this](const protocol::Event& e) {
      if (show_events_.load()) print(event_object(e), event_text(e));
    });
    client_.on_telemetry([this](const protocol::Telemetry& t) {
      if (show_telemetry_.load()) print(telemetry_object(t), telemetry_text(t));
    });
  }

  static ClientOptions client_options(const GlobalOptions& o) {
    ClientOptions c;
    c.request_timeout = seconds_to_ms(o.timeout_s);
    c.connect_timeout = std::max(seconds_to_ms(o.timeout_s), Milliseconds{1000});
    c.retries = o.retries;
    c.client_name = "ajarctl";
    c.tls = o.tls;
    return c;
  }

  // Connects and says Hello once; later calls reuse the session.
  int open(bool controller) {
    if (greeted_) return kExitOk;
    const std::string why = client_.connect(options_.endpoint);
    if (!why.empty()) {
      print_error("connect", kDisconnectedCode, why);
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

  int execute(const Command& c) {
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
        print_error(c.name, "USAGE", c.name + " cannot run inside a session");
        return kExitUsage;
    }
    return kExitUsage;
  }

  void print(const JsonObject& json, const std::string& text) {
    std::lock_guard lock(print_mutex_);
    if (options_.json) {
      out_ << json.str() << '\n';
    } else {
      out_ << text << '\n';
    }
    out_.flush();
  }

  void print_error(std::string_view command, std::string_view code, const std::string& message) {
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

 private:
  int ping(const Command& c) {
    std::vector<double> rtts_ms;
    int last_failure = kExitOk;
    for (int i = 0; i < c.count && !g_interrupted.load(); ++i) {
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
        if (r.outcome == Outcome::kDisconnected) break;
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

  int watch(const Command& c) {
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
    while (!g_interrupted.load() && client_.connected() &&
           (c.duration_s <= 0 || Clock::now() < end)) {
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

  static constexpr auto kProgressInterval = Milliseconds{500};

  // While align / engage waits: elapsed time and, for align, the yaw turned so far and the yaw
  // still to turn (the measured plane's yaw minus the odometry yaw turned since the start); for
  // engage, the arm's state.
  void print_progress(const Command& c, bool align, const protocol::Status& start,
                      const protocol::Status& now, Clock::duration elapsed) {
    const double elapsed_s = std::chrono::duration<double>(elapsed).count();
    JsonObject o;
    o.add("type", "progress").add("command", c.name).add("ok", true);
    o.add("elapsed_s", elapsed_s).add("state", protocol::to_string(now.state));
    char text[200];
    if (align) {
      const double turned = std::remainder(now.base_yaw_odometry_rad - start.base_yaw_odometry_rad,
                                           2 * std::numbers::pi);
      o.add("yaw_turned_rad", turned);
      if (start.has_plane) {
        const double remaining = start.plane.yaw_deviation_rad - turned;
        o.add("yaw_remaining_rad", remaining);
        std::snprintf(text, sizeof text,
                      "%s: %5.1f s, turned %+.4f rad, %+.4f rad (%+.2f deg) to go", c.name.c_str(),
                      elapsed_s, turned, remaining, remaining * 180 / std::numbers::pi);
      } else {
        std::snprintf(text, sizeof text, "%s: %5.1f s, turned %+.4f rad", c.name.c_str(), elapsed_s,
                      turned);
      }
    } else {
      o.add("arm_state", protocol::to_string(now.arm_state));
      std::snprintf(text, sizeof text, "%s: %5.1f s, arm %s", c.name.c_str(), elapsed_s,
                    std::string(protocol::to_string(now.arm_state)).c_str());
    }
    print(o, text);
  }

  // align / engage: send, then (unless --no-wait) poll the status until the motion is over.
  int motion(const Command& c) {
    const bool align = c.kind == Command::Kind::kAlign;
    const Response before = client_.request(protocol::GetStatus{});
    if (!before.ok()) {
      print(response_object(c.name, before), response_text(c.name, before));
      return exit_code(before);
    }
    const protocol::Status start = *before.get<protocol::Status>();
    show_events_ = true;
    const Response ack = client_.request(c.request);
    print(response_object(c.name, ack), response_text(c.name, ack));
    if (!ack.ok() || !c.wait) {
      show_events_ = false;
      return exit_code(ack);
    }
    client_.set_heartbeat(Milliseconds{100});
    const auto busy =
        align ? protocol::ProcedureState::kAligning : protocol::ProcedureState::kEngaging;
    const auto started = Clock::now();
    const auto deadline = started + seconds_to_ms(c.wait_timeout_s);
    auto next_progress = started + kProgressInterval;
    protocol::Status last = start;
    bool finished = false;
    int rc = kExitOk;
    while (Clock::now() < deadline) {
      if (g_interrupted.load()) {
        // Ctrl-C while the robot moves: stop it rather than leave it to the deadman.
        const Response stop = client_.request(protocol::Stop{});
        print(response_object("stop", stop), "interrupted: " + response_text("stop", stop));
        rc = kExitRefused;
        break;
      }
      const Response r = client_.request(protocol::GetStatus{});
      if (!r.ok()) {
        print(response_object(c.name, r), response_text(c.name, r));
        rc = exit_code(r);
        break;
      }
      last = *r.get<protocol::Status>();
      if (last.state != busy) {
        finished = true;
        break;
      }
      if (Clock::now() >= next_progress) {
        print_progress(c, align, start, last, Clock::now() - started);
        next_progress += kProgressInterval;
      }
      std::this_thread::sleep_for(Milliseconds{50});
    }
    if (!finished && rc == kExitOk) {
      // --wait-timeout while still moving: stop it and wait for the Ack (with the heartbeat still
      // running) rather than disconnect and leave the stop to the deadman.
      const Response stop = client_.request(protocol::Stop{});
      print(response_object("stop", stop),
            c.name + " wait timed out: " + response_text("stop", stop));
      if (const Response r = client_.request(protocol::GetStatus{}); r.ok()) {
        last = *r.get<protocol::Status>();
      }
    }
    client_.set_heartbeat(Milliseconds{0});
    show_events_ = false;
    if (rc != kExitOk) return rc;

    const auto goal =
        align ? protocol::ProcedureState::kAligned : protocol::ProcedureState::kEngaged;
    const bool ok = finished && last.state == goal;
    JsonObject o;
    o.add("type", align ? "align_result" : "engage_result").add("command", c.name).add("ok", ok);
    o.add("state", protocol::to_string(last.state));
    std::string text = c.name + ": " + (ok ? "done" : "NOT done") + ", state " +
                       std::string(protocol::to_string(last.state));
    if (align) {
      const double turned = std::remainder(last.base_yaw_odometry_rad - start.base_yaw_odometry_rad,
                                           2 * std::numbers::pi);
      o.add("base_yaw_before_rad", start.base_yaw_odometry_rad)
          .add("base_yaw_after_rad", last.base_yaw_odometry_rad)
          .add("yaw_turned_rad", turned);
      char line[200];
      std::snprintf(line, sizeof line, "\n  odometry yaw: %+.5f -> %+.5f rad (turned %+.5f rad)",
                    start.base_yaw_odometry_rad, last.base_yaw_odometry_rad, turned);
      text += line;
      if (start.has_plane) {
        JsonObject p;
        add_plane_fields(p, start.plane);
        o.add("commanded", p);
        std::snprintf(line, sizeof line, "\n  commanded:    %+.5f rad (wheels %+.5f / %+.5f rad)",
                      start.plane.yaw_deviation_rad, start.plane.left_wheel_rad,
                      start.plane.right_wheel_rad);
        text += line;
      }
    } else {
      o.add("arm_state", protocol::to_string(last.arm_state));
      text += ", arm " + std::string(protocol::to_string(last.arm_state));
    }
    if (!ok) {
      std::string code = last.latched_fault != ErrorCode::kOk
                             ? std::string(ajar::to_string(last.latched_fault))
                             : (finished ? std::string("WRONG_STATE") : std::string(kTimeoutCode));
      const std::string message =
          finished
              ? "the " + c.name + " ended in state " + std::string(protocol::to_string(last.state))
              : "still " + std::string(protocol::to_string(busy)) + " after " +
                    std::to_string(c.wait_timeout_s) + " s: Stop sent";
      o.add("error", error_object(code, "", message));
      text += "\n  " + code + ": " + message;
    }
    print(o, text);
    if (ok) return kExitOk;
    return finished ? kExitRefused : kExitConnection;
  }

  const GlobalOptions& options_;
  std::ostream& out_;
  std::ostream& err_;
  // Declared before client_: the client's callbacks use them until the client is destroyed.
  std::mutex print_mutex_;
  std::atomic<bool> show_events_{false};
  std::atomic<bool> show_telemetry_{false};
  Client client_;
  bool greeted_ = false;
};

int usage_error(std::ostream& err, const std::string& message) {
  err << "ajarctl: " << message << "\n(ajarctl --help lists the commands)\n";
  return kExitUsage;
}

// Commands one per line from `in` on one controller session.
int run_script(Session& session, std::istream& in, const GlobalOptions& options,
               std::ostream& err) {
  if (int rc = session.open(true); rc != kExitOk) return rc;
  int worst = kExitOk;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto words = split_line(line);
    if (words.empty()) continue;
    if (words[0] == "quit" || words[0] == "exit") break;
    const CommandParse parsed = parse_command(words, options.frame);
    int rc = kExitOk;
    if (!parsed.command) {
      rc = usage_error(err, "line " + std::to_string(line_number) + ": " + parsed.error);
    } else {
      rc = session.execute(*parsed.command);
    }
    if (rc != kExitOk) {
      if (worst == kExitOk) worst = rc;
      if (!options.keep_going || rc == kExitConnection) return rc;
    }
  }
  return worst;
}

}  // namespace

int run_ajarctl(std::span<const std::string> args, std::istream& in, std::ostream& out,
                std::ostream& err) {
  if (!args.empty() && args[0] == "--complete") {  // bash completion (client/completion/ajarctl)
    for (const auto& word : completion_words(args.subspan(1)))
      out << word << '\n';
    return kExitOk;
  }
  const ParsedArgs parsed = parse_global_options(args);
  if (!parsed.error.empty()) return usage_error(err, parsed.error);
  const GlobalOptions& options = parsed.options;
  if (options.help) {
    out << usage();
    return kExitOk;
  }
  if (options.version) {
    out << "ajarctl " << ajar::kVersion << " (protocol " << int{protocol::kVersionMajor} << "."
        << int{protocol::kVersionMinor} << ")\n";
    return kExitOk;
  }
  g_interrupted.store(false);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  std::signal(SIGPIPE, SIG_IGN);

  if (parsed.command.empty()) {
    if (!options.keep) return usage_error(err, "no command given");
    Session session(options, out, err);
    return run_script(session, in, options, err);
  }
  const CommandParse command = parse_command(parsed.command, options.frame);
  if (!command.command) return usage_error(err, command.error);
  const Command& c = *command.command;
  switch (c.kind) {
    case Command::Kind::kHelp:
      out << (c.args.empty() ? usage() : command_help(c.args[0]));
      return kExitOk;
    case Command::Kind::kConformance:
      return run_conformance(c, options, out, err);
    case Command::Kind::kSimulate:
      return run_simulate(c, options, out, err);
    case Command::Kind::kScript: {
      Session session(options, out, err);
      if (c.args.empty()) return run_script(session, in, options, err);
      std::ifstream file(c.args[0]);
      if (!file) return usage_error(err, "cannot read script file '" + c.args[0] + "'");
      return run_script(session, file, options, err);
    }
    default:
      break;
  }
  Session session(options, out, err);
  if (int rc = session.open(c.needs_controller || options.keep); rc != kExitOk) return rc;
  int rc = session.execute(c);
  if (options.keep && (rc == kExitOk || options.keep_going)) {
    const int script_rc = run_script(session, in, options, err);
    if (rc == kExitOk) rc = script_rc;
  }
  return rc;
}

}  // namespace ajar::client
