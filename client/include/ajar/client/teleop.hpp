// ajarctl drive: the parts of the terminal teleop that need no terminal, socket or clock of their
// own (time is passed in), so that they are unit-tested: the key decoder, the velocity the keys
// set, the Drive re-send schedule and the status line.
#pragma once

#include <chrono>
#include <span>
#include <string>
#include <vector>

#include "ajar/protocol/messages.hpp"

namespace ajar::client::teleop {

enum class Key {
  kForward,   // Up arrow, w: linear velocity one step forward
  kBackward,  // Down arrow, s: one step backward
  kLeft,      // Left arrow, a: angular velocity one step CCW (+)
  kRight,     // Right arrow, d: one step CW (-)
  kStop,      // space: velocity 0 and a Stop
  kQuit,      // q, Esc, Ctrl-C (raw mode), Ctrl-D
};

// Terminal bytes (raw mode) -> keys. Arrow keys arrive as ESC [ A..D (or ESC O A..D in application
// mode); an ESC is held until the next byte tells whether it starts such a sequence, or until
// idle() says nothing followed (then it is the Esc key). Other bytes are ignored.
class KeyDecoder {
 public:
  void feed(std::span<const char> bytes, std::vector<Key>& out);
  void idle(std::vector<Key>& out);  // no byte came for a while

 private:
  enum class State { kText, kEscape, kSequence } state_ = State::kText;
};

// The velocity steps and limits: RobotModel's max_linear_speed_m_s / max_angular_speed_rad_s; a
// step is a tenth of the limit. A limit of 0 (a daemon that does not drive yet) falls back to
// 0.3 m/s and 0.5 rad/s: the daemon refuses or clamps anyway.
struct Limits {
  double max_linear_m_s = 0.3;
  double max_angular_rad_s = 0.5;
  double linear_step_m_s = 0.03;
  double angular_step_rad_s = 0.05;
};
Limits limits_from(const protocol::RobotModel& model);

struct Velocity {
  double linear_m_s = 0;     // + forward
  double angular_rad_s = 0;  // CCW +
  bool zero() const { return linear_m_s == 0 && angular_rad_s == 0; }
};

enum class Action { kChanged, kUnchanged, kStop, kQuit };
// Applies one key to `v`, clamped to the limits (a value within half a step of 0 snaps to 0, so
// that stepping back always reaches an exact stop).
Action apply(Key key, Velocity& v, const Limits& limits);

// When to send Drive: at once after the velocity changed; while it is non-zero again every
// `period` (the command is valid for drive_command_timeout_s only); after it became zero, once
// (the Drive{0, 0}), then not until it changes again.
class ResendScheduler {
 public:
  using Clock = std::chrono::steady_clock;
  explicit ResendScheduler(Clock::duration period) : period_(period) {}
  void changed() { pending_ = true; }
  // True when a Drive with `v` is to be sent at `now`; then counts it as sent.
  bool due(const Velocity& v, Clock::time_point now);
  // The latest time to call due() again: `now` when a send is pending, time_point::max() when
  // nothing is scheduled (so that `next - now` never overflows).
  Clock::time_point next(const Velocity& v, Clock::time_point now) const;
  Clock::duration period() const { return period_; }

 private:
  Clock::duration period_;
  bool pending_ = false;
  bool sent_once_ = false;
  Clock::time_point last_{};
};

// The re-send period: a third of drive_command_timeout_s, or 0.1 s when that is 0 (or not finite).
std::chrono::nanoseconds resend_period(double drive_command_timeout_s);

// The line the teleop refreshes in place: the speed the keys set, what the loop commands
// (Telemetry commanded_*), the live door distance and yaw when known, and a note (last refusal).
std::string status_line(const Velocity& set, const protocol::Telemetry* telemetry,
                        const std::string& note);

}  // namespace ajar::client::teleop
