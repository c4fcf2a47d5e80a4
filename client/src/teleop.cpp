#include "ajar/client/teleop.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace ajar::client::teleop {

void KeyDecoder::feed(std::span<const char> bytes, std::vector<Key>& out) {
  for (const char ch : bytes) {
    switch (state_) {
      case State::kEscape:
        if (ch == '[' || ch == 'O') {
          state_ = State::kSequence;
          continue;
        }
        out.push_back(Key::kQuit);  // a lone Esc, then this byte as text
        state_ = State::kText;
        break;
      case State::kSequence:
        state_ = State::kText;
        switch (ch) {
          case 'A':
            out.push_back(Key::kForward);
            break;
          case 'B':
            out.push_back(Key::kBackward);
            break;
          case 'C':
            out.push_back(Key::kRight);
            break;
          case 'D':
            out.push_back(Key::kLeft);
            break;
          default:  // another sequence (function keys, ...): ignored up to its final byte
            if (!((ch >= 0x40 && ch <= 0x7E))) state_ = State::kSequence;
            break;
        }
        continue;
      case State::kText:
        break;
    }
    switch (ch) {
      case '\x1b':
        state_ = State::kEscape;
        break;
      case 'w':
      case 'W':
        out.push_back(Key::kForward);
        break;
      case 's':
      case 'S':
        out.push_back(Key::kBackward);
        break;
      case 'a':
      case 'A':
        out.push_back(Key::kLeft);
        break;
      case 'd':
      case 'D':
        out.push_back(Key::kRight);
        break;
      case ' ':
        out.push_back(Key::kStop);
        break;
      case 'q':
      case 'Q':
      case '\x03':  // Ctrl-C in raw mode
      case '\x04':  // Ctrl-D
        out.push_back(Key::kQuit);
        break;
      default:
        break;
    }
  }
}

void KeyDecoder::idle(std::vector<Key>& out) {
  if (state_ == State::kEscape) out.push_back(Key::kQuit);
  state_ = State::kText;
}

Limits limits_from(const protocol::RobotModel& model) {
  Limits l;
  if (std::isfinite(model.max_linear_speed_m_s) && model.max_linear_speed_m_s > 0) {
    l.max_linear_m_s = model.max_linear_speed_m_s;
  }
  if (std::isfinite(model.max_angular_speed_rad_s) && model.max_angular_speed_rad_s > 0) {
    l.max_angular_rad_s = model.max_angular_speed_rad_s;
  }
  l.linear_step_m_s = l.max_linear_m_s / 10;
  l.angular_step_rad_s = l.max_angular_rad_s / 10;
  return l;
}

namespace {
double step(double value, double delta, double limit) {
  double next = std::clamp(value + delta, -limit, limit);
  if (std::abs(next) < std::abs(delta) / 2) next = 0;
  return next;
}
}  // namespace

Action apply(Key key, Velocity& v, const Limits& limits) {
  const Velocity before = v;
  switch (key) {
    case Key::kForward:
      v.linear_m_s = step(v.linear_m_s, limits.linear_step_m_s, limits.max_linear_m_s);
      break;
    case Key::kBackward:
      v.linear_m_s = step(v.linear_m_s, -limits.linear_step_m_s, limits.max_linear_m_s);
      break;
    case Key::kLeft:
      v.angular_rad_s = step(v.angular_rad_s, limits.angular_step_rad_s, limits.max_angular_rad_s);
      break;
    case Key::kRight:
      v.angular_rad_s = step(v.angular_rad_s, -limits.angular_step_rad_s, limits.max_angular_rad_s);
      break;
    case Key::kStop:
      v = {};
      return Action::kStop;
    case Key::kQuit:
      v = {};
      return Action::kQuit;
  }
  return before.linear_m_s == v.linear_m_s && before.angular_rad_s == v.angular_rad_s
             ? Action::kUnchanged
             : Action::kChanged;
}

bool ResendScheduler::due(const Velocity& v, Clock::time_point now) {
  if (pending_ || (!v.zero() && sent_once_ && now - last_ >= period_)) {
    pending_ = false;
    sent_once_ = true;
    last_ = now;
    return true;
  }
  return false;
}

ResendScheduler::Clock::time_point ResendScheduler::next(const Velocity& v,
                                                         Clock::time_point now) const {
  if (pending_) return now;
  if (v.zero() || !sent_once_) return Clock::time_point::max();
  return last_ + period_;
}

std::chrono::nanoseconds resend_period(double drive_command_timeout_s) {
  if (!std::isfinite(drive_command_timeout_s) || drive_command_timeout_s <= 0) {
    return std::chrono::milliseconds(100);
  }
  // At least 10 ms: a daemon that says a tiny timeout does not make the client flood it.
  const double s = std::max(drive_command_timeout_s / 3, 0.01);
  return std::chrono::nanoseconds(std::llround(std::min(s, 3600.0) * 1e9));
}

std::string status_line(const Velocity& set, const protocol::Telemetry* t,
                        const std::string& note) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, "set %+.3f m/s %+.3f rad/s", set.linear_m_s,
                set.angular_rad_s);
  std::string line = buffer;
  if (t != nullptr) {
    std::snprintf(buffer, sizeof buffer, " | commanded %+.3f m/s %+.3f rad/s%s",
                  t->commanded_linear_m_s, t->commanded_angular_rad_s, t->moving ? " moving" : "");
    line += buffer;
    if (t->door.has_distance) {
      std::snprintf(buffer, sizeof buffer, " | door %.3f m", t->door.distance_m);
      line += buffer;
      if (t->door.has_yaw) {
        std::snprintf(buffer, sizeof buffer, " yaw %+.2f deg",
                      t->door.yaw_rad * 180 / std::numbers::pi);
        line += buffer;
      }
    } else {
      line += " | door unknown";
    }
    if (t->staleness.plane) line += " | plane STALE";
  }
  if (!note.empty()) line += " | " + note;
  return line;
}

}  // namespace ajar::client::teleop
