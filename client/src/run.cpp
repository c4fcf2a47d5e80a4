#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
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
#include "ajar/client/teleop.hpp"
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

// The terminal in raw mode (keys arrive one by one, not echoed; Ctrl-C arrives as a byte) for as
// long as this lives; restored on every way out of the scope.
class RawTerminal {
 public:
  explicit RawTerminal(int fd) : fd_(fd) {
    if (tcgetattr(fd_, &saved_) != 0) return;
    termios raw = saved_;
    raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO | ISIG | IEXTEN);
    raw.c_iflag &= ~static_cast<tcflag_t>(IXON | ICRNL);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    active_ = tcsetattr(fd_, TCSAFLUSH, &raw) == 0;
  }
  ~RawTerminal() {
    if (active_) (void)tcsetattr(fd_, TCSAFLUSH, &saved_);
  }
  RawTerminal(const RawTerminal&) = delete;
  RawTerminal& operator=(const RawTerminal&) = delete;
  bool active() const { return active_; }

 private:
  int fd_;
  termios saved_{};
  bool active_ = false;
};

JsonObject pose_object(double x_m, double y_m, double yaw_rad) {
  JsonObject o;
  o.add("x_m", x_m).add("y_m", y_m).add("yaw_rad", yaw_rad);
  return o;
}

std::string pose_text(double x_m, double y_m, double yaw_rad) {
  return "x " + fixed(x_m, 4, true) + " m, y " + fixed(y_m, 4, true) + " m, yaw " +
         fixed(yaw_rad, 5, true) + " rad";
}

// One connection and one Hello, shared by the commands of a session.
class Session {
 public:
  Session(const GlobalOptions& options, std::ostream& out, std::ostream& err)
      : options_(options), out_(out), err_(err), client_(client_options(options)) {
    client_.on_event([this](const protocol::Event& e) {
      {
        std::lock_guard lock(latest_mutex_);
        events_.push_back(e.kind);
        if (events_.size() > 1024) events_.erase(events_.begin());
      }
      if (show_events_.load()) print(event_object(e), event_text(e));
    });
    client_.on_telemetry([this](const protocol::Telemetry& t) {
      {
        std::lock_guard lock(latest_mutex_);
        latest_ = t;
        ++telemetry_count_;
      }
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

  void set_script_mode() { script_mode_ = true; }

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

  // ---- drive and approach ----

  std::optional<protocol::RobotModel> robot_model(std::string_view command) {
    const Response r = client_.request(protocol::GetRobotModel{});
    if (const auto* m = r.get<protocol::RobotModel>()) return *m;
    print(response_object(command, r), response_text(command, r));
    return std::nullopt;
  }

  std::uint64_t telemetry_count() {
    std::lock_guard lock(latest_mutex_);
    return telemetry_count_;
  }

  // Waits (bounded) for a Telemetry after the first `after` that shows the base at rest.
  bool wait_at_rest(std::uint64_t after, double seconds) {
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

  // drive with keys: raw terminal, Drive re-sent while the velocity is not zero, a status line
  // refreshed in place. Leaving (q, Esc, Ctrl-C, a signal, end of input) sends Drive 0 and Stop.
  int drive_keys(const Command& c) {
    if (script_mode_ || isatty(STDIN_FILENO) == 0) {
      print_error(c.name, "USAGE",
                  "drive without --for reads keys from a terminal, and stdin is not one (in "
                  "scripts: drive --linear V --angular W --for S)");
      return kExitUsage;
    }
    const auto model = robot_model(c.name);
    if (!model) return kExitRefused;
    const teleop::Limits limits = teleop::limits_from(*model);
    teleop::ResendScheduler schedule(teleop::resend_period(model->drive_command_timeout_s));
    if (const Response r = client_.request(protocol::Subscribe{10.0f}); !r.ok()) {
      print(response_object(c.name, r), response_text(c.name, r));
      return exit_code(r);
    }
    client_.set_heartbeat(Milliseconds{100});
    {
      std::lock_guard lock(print_mutex_);
      out_ << "drive: Up/Down (w/s) " << fixed(limits.linear_step_m_s, 3) << " m/s steps up to "
           << fixed(limits.max_linear_m_s, 3) << " m/s, Left/Right (a/d) "
           << fixed(limits.angular_step_rad_s, 3) << " rad/s steps up to "
           << fixed(limits.max_angular_rad_s, 3) << " rad/s; space stops; q, Esc or Ctrl-C leave\n";
      out_.flush();
    }
    int rc = kExitOk;
    std::string note;
    {
      RawTerminal terminal(STDIN_FILENO);
      teleop::KeyDecoder decoder;
      teleop::Velocity v;
      std::vector<teleop::Key> keys;
      auto next_draw = Clock::now();
      bool quit = false;
      while (!quit && !g_interrupted.load()) {
        if (!client_.connected()) {
          note = "connection lost";
          rc = kExitConnection;
          break;
        }
        const auto now = Clock::now();
        const auto wake = std::min(schedule.next(v, now), now + Milliseconds{50});
        const int wait_ms = static_cast<int>(std::clamp<std::int64_t>(
            std::chrono::duration_cast<Milliseconds>(wake - now).count(), 0, 50));
        keys.clear();
        pollfd in{STDIN_FILENO, POLLIN, 0};
        if (poll(&in, 1, wait_ms) > 0 && (in.revents & (POLLIN | POLLHUP)) != 0) {
          char bytes[64];
          const ssize_t n = read(STDIN_FILENO, bytes, sizeof bytes);
          if (n > 0) {
            decoder.feed(std::span<const char>(bytes, static_cast<std::size_t>(n)), keys);
          } else {
            quit = true;  // end of input
          }
        } else {
          decoder.idle(keys);
        }
        bool stop = false;
        for (const teleop::Key key : keys) {
          switch (teleop::apply(key, v, limits)) {
            case teleop::Action::kChanged:
              schedule.changed();
              note.clear();
              break;
            case teleop::Action::kUnchanged:
              break;
            case teleop::Action::kStop:
              schedule.changed();
              stop = true;
              break;
            case teleop::Action::kQuit:
              quit = true;
              break;
          }
        }
        if (quit) break;
        if (schedule.due(v, Clock::now())) {
          const Response r = client_.request(protocol::Drive{v.linear_m_s, v.angular_rad_s});
          if (!r.ok()) {
            note = response_text(c.name, r);
            v = {};
            const bool hopeless = r.outcome != Outcome::kRefused ||
                                  r.error.code == ErrorCode::kNotSupported ||
                                  r.error.code == ErrorCode::kNotController;
            if (hopeless) {
              rc = exit_code(r);
              break;
            }
          }
        }
        if (stop) {
          const Response r = client_.request(protocol::Stop{});
          note = r.ok() ? "stopped" : response_text("stop", r);
        }
        if (Clock::now() >= next_draw) {
          protocol::Telemetry t;
          bool have = false;
          {
            std::lock_guard lock(latest_mutex_);
            have = telemetry_count_ > 0;
            t = latest_;
          }
          std::lock_guard lock(print_mutex_);
          out_ << "\r\033[K" << teleop::status_line(v, have ? &t : nullptr, note);
          out_.flush();
          next_draw = Clock::now() + Milliseconds{100};
        }
      }
      // Leaving: the base comes to rest whatever happened above.
      (void)client_.request(protocol::Drive{0, 0});
      (void)client_.request(protocol::Stop{});
    }  // the terminal is restored here
    client_.set_heartbeat(Milliseconds{0});
    (void)client_.request(protocol::Subscribe{});
    std::lock_guard lock(print_mutex_);
    out_ << "\n";
    if (!note.empty() && rc != kExitOk) out_ << note << "\n";
    out_.flush();
    return rc;
  }

  // drive --linear V --angular W --for S: Drive re-sent at the steady rate for S seconds, then
  // Drive 0; waits until Telemetry shows the base at rest; prints the odometry before and after.
  int drive_for(const Command& c) {
    const auto model = robot_model(c.name);
    if (!model) return kExitRefused;
    const Response first = client_.request(protocol::GetStatus{});
    if (!first.ok()) {
      print(response_object(c.name, first), response_text(c.name, first));
      return exit_code(first);
    }
    const protocol::Status before = *first.get<protocol::Status>();
    if (const Response r = client_.request(protocol::Subscribe{20.0f}); !r.ok()) {
      print(response_object(c.name, r), response_text(c.name, r));
      return exit_code(r);
    }
    client_.set_heartbeat(Milliseconds{100});
    teleop::ResendScheduler schedule(teleop::resend_period(model->drive_command_timeout_s));
    const teleop::Velocity v{c.linear_m_s, c.angular_rad_s};
    schedule.changed();
    const auto end = Clock::now() + seconds_to_ms(c.duration_s);
    int rc = kExitOk;
    std::string failure;
    while (Clock::now() < end) {
      if (g_interrupted.load()) {
        failure = "interrupted";
        rc = kExitRefused;
        break;
      }
      if (schedule.due(v, Clock::now())) {
        const Response r = client_.request(protocol::Drive{v.linear_m_s, v.angular_rad_s});
        if (!r.ok()) {
          print(response_object(c.name, r), response_text(c.name, r));
          rc = exit_code(r);
          break;
        }
      }
      const auto now = Clock::now();
      const auto wake = std::min({schedule.next(v, now), end, now + Milliseconds{50}});
      std::this_thread::sleep_until(wake);
    }
    const std::uint64_t count = telemetry_count();
    if (rc == kExitOk) {
      const Response zero = client_.request(protocol::Drive{0, 0});
      if (!zero.ok()) {
        print(response_object(c.name, zero), response_text(c.name, zero));
        rc = exit_code(zero);
      }
    }
    if (rc != kExitOk) {  // a refusal, an interruption or a lost reply: make sure it stops
      const Response stop = client_.request(protocol::Stop{});
      if (!failure.empty())
        print(response_object("stop", stop), failure + ": " + response_text("stop", stop));
    } else if (!wait_at_rest(count, 10)) {
      const Response stop = client_.request(protocol::Stop{});
      print(response_object("stop", stop),
            "drive: still moving 10 s after Drive 0: " + response_text("stop", stop));
      rc = kExitRefused;
    }
    client_.set_heartbeat(Milliseconds{0});
    (void)client_.request(protocol::Subscribe{});
    if (rc != kExitOk) return rc;
    const Response last = client_.request(protocol::GetStatus{});
    if (!last.ok()) {
      print(response_object(c.name, last), response_text(c.name, last));
      return exit_code(last);
    }
    const protocol::Status& after = *last.get<protocol::Status>();
    const double moved = std::hypot(after.odometry_x_m - before.odometry_x_m,
                                    after.odometry_y_m - before.odometry_y_m);
    const double turned = std::remainder(after.base_yaw_odometry_rad - before.base_yaw_odometry_rad,
                                         2 * std::numbers::pi);
    JsonObject o;
    o.add("type", "drive_result").add("command", c.name).add("ok", true);
    o.add("linear_m_s", c.linear_m_s).add("angular_rad_s", c.angular_rad_s);
    o.add("duration_s", c.duration_s);
    o.add("odometry_before",
          pose_object(before.odometry_x_m, before.odometry_y_m, before.base_yaw_odometry_rad));
    o.add("odometry_after",
          pose_object(after.odometry_x_m, after.odometry_y_m, after.base_yaw_odometry_rad));
    o.add("moved_m", moved).add("turned_rad", turned);
    std::string text = "drive: done, " + fixed(c.duration_s, 2) + " s at " +
                       fixed(c.linear_m_s, 3, true) + " m/s, " + fixed(c.angular_rad_s, 4, true) +
                       " rad/s, now at rest";
    text += "\n  odometry before: " +
            pose_text(before.odometry_x_m, before.odometry_y_m, before.base_yaw_odometry_rad);
    text += "\n  odometry after:  " +
            pose_text(after.odometry_x_m, after.odometry_y_m, after.base_yaw_odometry_rad);
    text += "\n  moved " + fixed(moved, 4) + " m, turned " + fixed(turned, 5, true) + " rad";
    print(o, text);
    return kExitOk;
  }

  // approach STANDOFF_M: the Ack's move, then (unless --no-wait) wait for the motion's end Event,
  // polling the status (progress; also feeds the deadman); reports the final door distance.
  int approach(const Command& c) {
    const double standoff_m = std::get<protocol::Approach>(c.request).standoff_m;
    std::size_t seen = 0;
    {
      std::lock_guard lock(latest_mutex_);
      seen = events_.size();
    }
    show_events_ = true;
    const Response ack = client_.request(c.request);
    print(response_object(c.name, ack), response_text(c.name, ack));
    if (!ack.ok() || !c.wait) {
      show_events_ = false;
      return exit_code(ack);
    }
    client_.set_heartbeat(Milliseconds{100});
    const auto started = Clock::now();
    const auto deadline = started + seconds_to_ms(c.wait_timeout_s);
    auto next_progress = started + kProgressInterval;
    std::optional<protocol::EventKind> end;
    int rc = kExitOk;
    while (!end && Clock::now() < deadline) {
      if (g_interrupted.load()) {
        const Response stop = client_.request(protocol::Stop{});
        print(response_object("stop", stop), "interrupted: " + response_text("stop", stop));
        rc = kExitRefused;
        break;
      }
      {
        std::lock_guard lock(latest_mutex_);
        for (std::size_t i = std::min(seen, events_.size()); i < events_.size(); ++i) {
          const auto kind = events_[i];
          if (kind == protocol::EventKind::kMotionFinished ||
              kind == protocol::EventKind::kMotionStopped ||
              kind == protocol::EventKind::kFaultLatched) {
            end = kind;
          }
        }
      }
      if (end) break;
      const Response r = client_.request(protocol::GetStatus{});
      if (!r.ok()) {
        print(response_object(c.name, r), response_text(c.name, r));
        rc = exit_code(r);
        break;
      }
      if (Clock::now() >= next_progress) {
        const auto& s = *r.get<protocol::Status>();
        const double elapsed_s = std::chrono::duration<double>(Clock::now() - started).count();
        JsonObject o;
        o.add("type", "progress").add("command", c.name).add("ok", true);
        o.add("elapsed_s", elapsed_s).add("state", protocol::to_string(s.state));
        std::string text = c.name + ": " + fixed(elapsed_s, 1) + " s, door ";
        if (s.door.has_distance) {
          o.add("door_distance_m", s.door.distance_m);
          text += fixed(s.door.distance_m, 4) + " m";
        } else {
          text += "unknown";
        }
        text += " (standoff " + fixed(standoff_m, 4) + " m)";
        print(o, text);
        next_progress += kProgressInterval;
      }
      std::this_thread::sleep_for(Milliseconds{50});
    }
    if (!end && rc == kExitOk) {
      const Response stop = client_.request(protocol::Stop{});
      print(response_object("stop", stop),
            c.name + " wait timed out: " + response_text("stop", stop));
    }
    client_.set_heartbeat(Milliseconds{0});
    show_events_ = false;
    if (rc != kExitOk) return rc;
    const Response last = client_.request(protocol::GetStatus{});
    const auto* s = last.get<protocol::Status>();
    const bool ok = end == protocol::EventKind::kMotionFinished;
    JsonObject o;
    o.add("type", "approach_result").add("command", c.name).add("ok", ok);
    o.add("outcome", end ? protocol::to_string(*end) : std::string_view("timeout"));
    o.add("standoff_m", standoff_m);
    std::string text = c.name + ": " + (ok ? "done" : "NOT done") + " (" +
                       (end ? std::string(protocol::to_string(*end)) : std::string("timed out")) +
                       ")";
    if (s != nullptr && s->door.has_distance) {
      o.add("door_distance_m", s->door.distance_m)
          .add("standoff_error_m", s->door.distance_m - standoff_m);
      text += ", door " + fixed(s->door.distance_m, 4) + " m from the base (standoff " +
              fixed(standoff_m, 4) + " m, error " +
              fixed(s->door.distance_m - standoff_m, 4, true) + " m)";
    }
    if (s != nullptr && s->latched_fault != ErrorCode::kOk) {
      o.add("error", error_object(ajar::to_string(s->latched_fault), "", "fault latched"));
      text += "\n  fault latched: " + std::string(ajar::to_string(s->latched_fault));
    }
    print(o, text);
    if (ok) return kExitOk;
    return end ? kExitRefused : kExitConnection;
  }

  const GlobalOptions& options_;
  std::ostream& out_;
  std::ostream& err_;
  bool script_mode_ = false;
  // Declared before client_: the client's callbacks use them until the client is destroyed.
  std::mutex latest_mutex_;
  protocol::Telemetry latest_;               // newest Telemetry (drive's status line, waits)
  std::uint64_t telemetry_count_ = 0;        // Telemetry frames received
  std::vector<protocol::EventKind> events_;  // kinds of the Events received, oldest first
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
  session.set_script_mode();
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
  std::signal(SIGHUP, on_interrupt);  // a closed terminal: leave like Ctrl-C (drive stops the base)
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
  if (options.keep) session.set_script_mode();  // stdin holds the commands that follow
  if (int rc = session.open(c.needs_controller || options.keep); rc != kExitOk) return rc;
  int rc = session.execute(c);
  if (options.keep && (rc == kExitOk || options.keep_going)) {
    const int script_rc = run_script(session, in, options, err);
    if (rc == kExitOk) rc = script_rc;
  }
  return rc;
}

}  // namespace ajar::client
