#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <thread>

#include "ajar/client/teleop.hpp"
#include "session.hpp"

namespace ajar::client {

namespace {

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

// The keys typed within `wait_ms` (none typed: what the decoder holds once idle, a lone Esc);
// false at the end of input.
bool read_keys(teleop::KeyDecoder& decoder, int wait_ms, std::vector<teleop::Key>& keys) {
  keys.clear();
  pollfd in{STDIN_FILENO, POLLIN, 0};
  if (poll(&in, 1, wait_ms) > 0 && (in.revents & (POLLIN | POLLHUP)) != 0) {
    char bytes[64];
    const ssize_t n = read(STDIN_FILENO, bytes, sizeof bytes);
    if (n <= 0) return false;  // end of input
    decoder.feed(std::span<const char>(bytes, static_cast<std::size_t>(n)), keys);
  } else {
    decoder.idle(keys);
  }
  return true;
}

// How long to wait for keys: until the next Drive is due, at most 50 ms.
int key_wait_ms(const teleop::ResendScheduler& schedule, const teleop::Velocity& v) {
  const auto now = Clock::now();
  const auto wake = std::min(schedule.next(v, now), now + Milliseconds{50});
  return static_cast<int>(std::clamp<std::int64_t>(
      std::chrono::duration_cast<Milliseconds>(wake - now).count(), 0, 50));
}

// What the keys asked besides a new velocity.
struct KeyRequests {
  bool stop = false;
  bool quit = false;
};

// The keys applied to the velocity `v` in order; a change clears the status line's `note`.
KeyRequests apply_keys(const std::vector<teleop::Key>& keys, teleop::Velocity& v,
                       const teleop::Limits& limits, teleop::ResendScheduler& schedule,
                       std::string& note) {
  KeyRequests asked;
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
        asked.stop = true;
        break;
      case teleop::Action::kQuit:
        asked.quit = true;
        break;
    }
  }
  return asked;
}

// A refused Drive that no other velocity would change: the daemon does not drive, or this
// session does not control; or no reply at all.
bool drive_hopeless(const Response& r) {
  return r.outcome != CallOutcome::kRefused || r.error.code == ErrorCode::kNotSupported ||
         r.error.code == ErrorCode::kNotController;
}

std::string drive_keys_help(const teleop::Limits& limits) {
  return "drive: Up/Down (w/s) " + fixed(limits.linear_step_m_s, 3) + " m/s steps up to " +
         fixed(limits.max_linear_m_s, 3) + " m/s, Left/Right (a/d) " +
         fixed(limits.angular_step_rad_s, 3) + " rad/s steps up to " +
         fixed(limits.max_angular_rad_s, 3) + " rad/s; space stops; q, Esc or Ctrl-C leave\n";
}

}  // namespace

// drive with keys: raw terminal, Drive re-sent while the velocity is not zero, a status line
// refreshed in place. Leaving (q, Esc, Ctrl-C, a signal, end of input) sends Drive 0 and Stop.
int Session::drive_keys(const Command& c) {
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
    out_ << drive_keys_help(limits);
    out_.flush();
  }
  int rc = kExitOk;
  std::string note;
  {
    RawTerminal terminal(STDIN_FILENO);
    rc = drive_by_keys(c.name, limits, schedule, note);
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

int Session::drive_by_keys(const std::string& name, const teleop::Limits& limits,
                           teleop::ResendScheduler& schedule, std::string& note) {
  teleop::KeyDecoder decoder;
  teleop::Velocity v;
  std::vector<teleop::Key> keys;
  auto next_draw = Clock::now();
  while (!interrupted()) {
    if (!client_.connected()) {
      note = "connection lost";
      return kExitConnection;
    }
    const bool input = read_keys(decoder, key_wait_ms(schedule, v), keys);
    const KeyRequests asked = apply_keys(keys, v, limits, schedule, note);
    if (!input || asked.quit) break;
    if (schedule.due(v, Clock::now())) {
      const Response r = client_.request(protocol::Drive{v.linear_m_s, v.angular_rad_s});
      if (!r.ok()) {
        note = response_text(name, r);
        v = {};
        if (drive_hopeless(r)) return exit_code(r);
      }
    }
    if (asked.stop) {
      const Response r = client_.request(protocol::Stop{});
      note = r.ok() ? "stopped" : response_text("stop", r);
    }
    if (Clock::now() >= next_draw) {
      draw_drive_status(v, note);
      next_draw = Clock::now() + Milliseconds{100};
    }
  }
  return kExitOk;
}

void Session::draw_drive_status(const teleop::Velocity& v, const std::string& note) {
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
}

// drive --linear V --angular W --for S: Drive re-sent at the steady rate for S seconds, then
// Drive 0; waits until Telemetry shows the base at rest; prints the odometry before and after.
int Session::drive_for(const Command& c) {
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
  std::string failure;
  int rc = drive_steadily(c, schedule, failure);
  const std::uint64_t count = telemetry_count();
  rc = come_to_rest(c.name, rc, failure, count);
  client_.set_heartbeat(Milliseconds{0});
  (void)client_.request(protocol::Subscribe{});
  if (rc != kExitOk) return rc;
  const Response last = client_.request(protocol::GetStatus{});
  if (!last.ok()) {
    print(response_object(c.name, last), response_text(c.name, last));
    return exit_code(last);
  }
  print_drive_result(c, before, *last.get<protocol::Status>());
  return kExitOk;
}

int Session::drive_steadily(const Command& c, teleop::ResendScheduler& schedule,
                            std::string& failure) {
  const teleop::Velocity v{c.linear_m_s, c.angular_rad_s};
  schedule.changed();
  const auto end = Clock::now() + seconds_to_ms(c.duration_s);
  while (Clock::now() < end) {
    if (interrupted()) {
      failure = "interrupted";
      return kExitRefused;
    }
    if (schedule.due(v, Clock::now())) {
      const Response r = client_.request(protocol::Drive{v.linear_m_s, v.angular_rad_s});
      if (!r.ok()) {
        print(response_object(c.name, r), response_text(c.name, r));
        return exit_code(r);
      }
    }
    const auto now = Clock::now();
    const auto wake = std::min({schedule.next(v, now), end, now + Milliseconds{50}});
    std::this_thread::sleep_until(wake);
  }
  return kExitOk;
}

int Session::come_to_rest(const std::string& name, int rc, const std::string& failure,
                          std::uint64_t count) {
  if (rc == kExitOk) {
    const Response zero = client_.request(protocol::Drive{0, 0});
    if (!zero.ok()) {
      print(response_object(name, zero), response_text(name, zero));
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
  return rc;
}

void Session::print_drive_result(const Command& c, const protocol::Status& before,
                                 const protocol::Status& after) {
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
}

}  // namespace ajar::client
