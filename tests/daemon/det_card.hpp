// DetCard: a deterministic MotionCard for the interleaving tests. Time comes from the test's fake
// clock (never the steady clock), so a seed replays exactly. Wheels move at constant speed towards
// their target; a smooth stop comes to rest `stop_delay_ns` later; an emergency stop halts at once.
// Fault menu (what the mock card offers, made deterministic): drive alarm, following error, limit,
// the card not answering for the next N calls, a refused move, a move that never progresses, a stop
// that never comes to rest. A jog (velocity mode) takes its new velocity at once and holds it; its
// smooth stop rests `stop_delay_ns` later like a move's. Every call is logged with the test's step
// counter (`tick`) so that the test can order card calls against acknowledged commands. One thread
// (the test's).
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "ajar/drivers/motion_card.hpp"

namespace ajar::testing {

struct DetCardState {
  struct Axis {
    double position = 0, start = 0, target = 0;
    std::int64_t t0_ns = 0;
    bool enabled = false, moving = false, stopping = false, stuck = false;
    std::int64_t rest_at_ns = 0;  // while stopping: when the axis rests
    bool alarm = false, following_error = false, positive_limit = false, negative_limit = false;
    bool emergency_stopped = false;
    std::uint64_t move_tick = 0;  // tick of the move_relative that set it moving
    bool jogging = false;         // velocity mode
    double velocity_counts_per_ns = 0;
    std::int64_t last_ns = 0;  // jog: position integrated up to here
  };
  struct Call {
    enum Kind { kMove, kSmoothStop, kEmergencyStop, kClearFaults, kEnable, kJog } kind;
    std::uint64_t tick;
    std::int64_t left = 0, right = 0;              // kMove: distances
    double left_velocity = 0, right_velocity = 0;  // kJog: counts/ms
  };

  const std::int64_t* now_ns = nullptr;  // the test's clock
  const std::uint64_t* tick = nullptr;   // the test's step counter
  int left_axis = 1, right_axis = 2;
  double speed_counts_per_ns = 1e-3;
  std::int64_t stop_delay_ns = 6'000'000;
  // Fault menu.
  int fail_calls = 0;  // the next N calls fail with kCardCommunication
  bool refuse_next_move = false;
  bool stick_next_move = false;
  bool stops_never_rest = false;
  bool stops_rest_at_once = false;  // for a shut-down under a frozen fake clock
  int enable_delay_reads = 0;       // servo-on shows after this many axis_status reads per axis
  bool alarm_persists = false;      // clear_faults() does not clear a drive alarm
  // Observations.
  std::vector<Call> calls;
  std::map<int, Axis> axes;
  std::map<int, int> enable_pending;

  void advance(Axis& a) const {
    if (!a.moving) return;
    const std::int64_t t = *now_ns;
    if (a.jogging) {
      const std::int64_t until = a.stopping && t >= a.rest_at_ns ? a.rest_at_ns : t;
      if (!a.stuck) a.position += a.velocity_counts_per_ns * static_cast<double>(until - a.last_ns);
      a.last_ns = until;
      a.target = a.position;
      if (a.stopping && !stops_never_rest && t >= a.rest_at_ns) {
        a.moving = a.stopping = a.jogging = false;
        a.velocity_counts_per_ns = 0;
      }
      return;
    }
    if (a.stopping) {
      if (!stops_never_rest && t >= a.rest_at_ns) a.moving = false, a.stopping = false;
      return;
    }
    if (a.stuck) return;
    const double travelled = speed_counts_per_ns * static_cast<double>(t - a.t0_ns);
    const double dist = a.target - a.start;
    if (travelled >= std::abs(dist)) {
      a.position = a.target;
      a.moving = false;
    } else {
      a.position = a.start + (dist > 0 ? travelled : -travelled);
    }
  }
  void halt(Axis& a) const {
    advance(a);
    a.jogging = false;
    a.velocity_counts_per_ns = 0;
    a.moving = false;
    a.stopping = false;
    a.stuck = false;
    a.target = a.position;
  }
  // Fault injection (the card latches it and stops that axis at once).
  void inject_alarm(int axis) {
    Axis& a = axes[axis];
    halt(a);
    a.alarm = true;
    a.enabled = false;
  }
  void inject_following_error(int axis) {
    Axis& a = axes[axis];
    halt(a);
    a.following_error = true;
  }
  void inject_limit(int axis) {
    Axis& a = axes[axis];
    halt(a);
    a.positive_limit = true;
  }
  bool any_moving() {
    for (auto& [n, a] : axes) {
      advance(a);
      if (a.moving) return true;
    }
    return false;
  }
};

class DetCard final : public drivers::MotionCard {
 public:
  explicit DetCard(DetCardState& s) : s_(s) {}

  Outcome open() override { return Ok{}; }
  Outcome close() override { return Ok{}; }
  ErrorCode enable_axes(std::span<const int> axes) noexcept override {
    if (failing()) return comm();
    s_.calls.push_back({DetCardState::Call::kEnable, *s_.tick});
    for (int axis : axes) {
      auto& a = s_.axes[axis];
      if (a.alarm) return ErrorCode::kAxisAlarm;
      if (s_.enable_delay_reads > 0 && !a.enabled) {
        s_.enable_pending[axis] = s_.enable_delay_reads;
      } else {
        a.enabled = true;
      }
    }
    return ErrorCode::kOk;
  }
  ErrorCode disable_axes(std::span<const int> axes) noexcept override {
    for (int axis : axes)
      s_.axes[axis].enabled = false;
    return ErrorCode::kOk;
  }
  ErrorCode clear_faults(std::span<const int> axes) noexcept override {
    if (failing()) return comm();
    s_.calls.push_back({DetCardState::Call::kClearFaults, *s_.tick});
    for (int axis : axes) {
      auto& a = s_.axes[axis];
      if (!s_.alarm_persists) a.alarm = false;
      a.following_error = a.positive_limit = a.negative_limit = false;
      a.emergency_stopped = false;
    }
    return ErrorCode::kOk;
  }
  ErrorCode jog(std::span<const drivers::AxisVelocity> axes,
                const drivers::JogProfile&) noexcept override {
    if (failing()) return comm();
    DetCardState::Call call{DetCardState::Call::kJog, *s_.tick};
    for (const auto& v : axes)
      (v.axis == s_.left_axis ? call.left_velocity : call.right_velocity) =
          v.velocity_counts_per_ms;
    s_.calls.push_back(call);
    for (const auto& v : axes) {
      auto& a = s_.axes[v.axis];
      s_.advance(a);
      if (!a.enabled || a.alarm || a.following_error) return ErrorCode::kDriverError;
      if (a.moving && !a.jogging) return ErrorCode::kDriverError;  // a trapezoid runs
    }
    for (const auto& v : axes) {
      auto& a = s_.axes[v.axis];
      a.jogging = true;
      a.stopping = false;
      a.velocity_counts_per_ns = v.velocity_counts_per_ms / 1e6;
      a.last_ns = *s_.now_ns;
      a.moving = v.velocity_counts_per_ms != 0;
      if (!a.moving) a.jogging = false;
      a.target = a.position;
      a.move_tick = *s_.tick;
    }
    return ErrorCode::kOk;
  }
  ErrorCode move_relative(std::span<const drivers::AxisMove> moves,
                          const drivers::TrapezoidProfile&) noexcept override {
    if (failing()) return comm();
    DetCardState::Call call{DetCardState::Call::kMove, *s_.tick};
    for (const auto& m : moves)
      (m.axis == s_.left_axis ? call.left : call.right) = m.distance_counts;
    s_.calls.push_back(call);
    if (s_.refuse_next_move) {
      s_.refuse_next_move = false;
      return ErrorCode::kCardBusy;
    }
    for (const auto& m : moves) {
      auto& a = s_.axes[m.axis];
      s_.advance(a);
      if (!a.enabled || a.alarm || a.following_error || (a.jogging && a.moving)) {
        return ErrorCode::kDriverError;  // servo off, faulted, or jogging
      }
    }
    for (const auto& m : moves) {
      auto& a = s_.axes[m.axis];
      a.start = a.position;
      a.target = a.position + static_cast<double>(m.distance_counts);
      a.t0_ns = *s_.now_ns;
      a.moving = m.distance_counts != 0;
      a.stopping = false;
      a.stuck = s_.stick_next_move;
      a.jogging = false;
      a.move_tick = *s_.tick;
    }
    s_.stick_next_move = false;
    return ErrorCode::kOk;
  }
  ErrorCode smooth_stop(std::span<const int> axes) noexcept override {
    if (failing()) return comm();
    s_.calls.push_back({DetCardState::Call::kSmoothStop, *s_.tick});
    for (int axis : axes) {
      auto& a = s_.axes[axis];
      s_.advance(a);
      if (a.moving && !a.stopping) {
        a.stopping = true;
        a.rest_at_ns = *s_.now_ns + (s_.stops_rest_at_once ? 0 : s_.stop_delay_ns);
      }
    }
    return ErrorCode::kOk;
  }
  ErrorCode emergency_stop(std::span<const int> axes) noexcept override {
    // An emergency stop works even when the card is "not answering" for other calls: the
    // invariant under test is that the loop issues it, which the log records.
    s_.calls.push_back({DetCardState::Call::kEmergencyStop, *s_.tick});
    for (int axis : axes) {
      auto& a = s_.axes[axis];
      s_.halt(a);
      a.emergency_stopped = true;
    }
    return ErrorCode::kOk;
  }
  ErrorCode axis_status(int axis, drivers::AxisStatus& st) noexcept override {
    if (failing()) return comm();
    auto& a = s_.axes[axis];
    s_.advance(a);
    if (auto it = s_.enable_pending.find(axis); it != s_.enable_pending.end()) {
      if (--it->second <= 0) {
        a.enabled = !a.alarm;
        s_.enable_pending.erase(it);
      }
    }
    st = drivers::AxisStatus{};
    st.enabled = a.enabled;
    st.moving = a.moving;
    st.in_position = !a.moving && a.position == a.target;
    st.alarm = a.alarm;
    st.following_error = a.following_error;
    st.positive_limit = a.positive_limit;
    st.negative_limit = a.negative_limit;
    st.emergency_stopped = a.emergency_stopped;
    st.smooth_stopped = a.stopping;
    st.profile_position_counts = std::llround(a.moving ? a.target : a.position);
    st.encoder_position_counts = std::llround(a.position);
    return ErrorCode::kOk;
  }

 private:
  bool failing() {
    if (s_.fail_calls <= 0) return false;
    --s_.fail_calls;
    return true;
  }
  static ErrorCode comm() { return ErrorCode::kCardCommunication; }

  DetCardState& s_;
};

}  // namespace ajar::testing
