// FakeMotionCard: a scripted MotionCard for engine and control-loop tests. The test keeps a
// shared FakeCardControl to steer it (alarms, stuck motion, blocked status reads) and to observe
// what the engine asked for (moves, stops). Thread-safe (the control thread calls it).
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <vector>

#include "ajar/drivers/motion_card.hpp"

namespace ajar::testing {

struct FakeCardControl {
  struct Axis {
    std::int64_t position = 0;
    std::int64_t target = 0;
    bool moving = false;
    int remaining = 0;  // status reads until the move completes
    int stop_in = -1;   // status reads until a smooth stop comes to rest (-1: not stopping)
    bool estopped = false;
  };

  mutable std::mutex mutex;
  std::condition_variable unblocked;
  // Knobs.
  int status_reads_per_move = 10;
  bool hold_motion = false;  // moves never complete on their own
  bool hold_stop = false;    // smooth stops never come to rest
  bool fail_open = false;
  bool fail_move = false;
  bool block_status = false;  // axis_status() waits until cleared (stalls the loop)
  std::set<int> alarm_axes;
  // Observations.
  int opens = 0;
  int move_calls = 0;
  int jog_calls = 0;
  int smooth_stops = 0;
  int emergency_stops = 0;
  int clear_faults_calls = 0;
  std::vector<drivers::AxisMove> last_moves;
  drivers::TrapezoidProfile last_profile;
  std::vector<drivers::AxisVelocity> last_jog;
  drivers::JogProfile last_jog_profile;
  std::map<int, Axis> axes;

  template <typename F>
  auto with_lock(F f) {
    std::lock_guard lock(mutex);
    return f(*this);
  }
  void set_block_status(bool block) {
    {
      std::lock_guard lock(mutex);
      block_status = block;
    }
    unblocked.notify_all();
  }
};

class FakeMotionCard final : public drivers::MotionCard {
 public:
  explicit FakeMotionCard(std::shared_ptr<FakeCardControl> control) : c_(std::move(control)) {}

  Outcome open() override {
    std::lock_guard lock(c_->mutex);
    ++c_->opens;
    if (c_->fail_open) return make_error(ErrorCode::kCardOpenFailed, "card", "fake: no card");
    return Ok{};
  }
  Outcome close() override { return Ok{}; }
  ErrorCode enable_axes(std::span<const int>) noexcept override { return ErrorCode::kOk; }
  ErrorCode disable_axes(std::span<const int>) noexcept override { return ErrorCode::kOk; }
  ErrorCode clear_faults(std::span<const int> axes) noexcept override {
    std::lock_guard lock(c_->mutex);
    ++c_->clear_faults_calls;
    for (int a : axes) {
      c_->alarm_axes.erase(a);
      c_->axes[a].estopped = false;
    }
    return ErrorCode::kOk;
  }
  // The fake may allocate (std::map, std::vector) where a card must not: it observes the loop,
  // it is not part of it.
  ErrorCode move_relative(std::span<const drivers::AxisMove> moves,
                          const drivers::TrapezoidProfile& profile) noexcept override {
    std::lock_guard lock(c_->mutex);
    ++c_->move_calls;
    c_->last_moves.assign(moves.begin(), moves.end());
    c_->last_profile = profile;
    if (c_->fail_move) return ErrorCode::kCardBadParameter;
    for (const auto& m : moves) {
      auto& a = c_->axes[m.axis];
      a.target = a.position + m.distance_counts;
      a.moving = true;
      a.remaining = c_->status_reads_per_move;
      a.stop_in = -1;
    }
    return ErrorCode::kOk;
  }
  // A jog holds its velocity until a stop or a jog to 0 (which rests after 2 status reads); the
  // position does not advance (tests observe what was commanded).
  ErrorCode jog(std::span<const drivers::AxisVelocity> axes,
                const drivers::JogProfile& profile) noexcept override {
    std::lock_guard lock(c_->mutex);
    ++c_->jog_calls;
    c_->last_jog.assign(axes.begin(), axes.end());
    c_->last_jog_profile = profile;
    if (c_->fail_move) return ErrorCode::kCardBadParameter;
    for (const auto& v : axes) {
      auto& a = c_->axes[v.axis];
      a.target = a.position;
      if (v.velocity_counts_per_ms != 0) {
        a.moving = true;
        a.remaining = 1 << 30;
        a.stop_in = -1;
      } else if (a.moving && a.stop_in < 0) {
        a.stop_in = 2;
      }
    }
    return ErrorCode::kOk;
  }
  ErrorCode smooth_stop(std::span<const int> axes) noexcept override {
    std::lock_guard lock(c_->mutex);
    ++c_->smooth_stops;
    for (int axis : axes) {
      auto& a = c_->axes[axis];
      if (a.moving && a.stop_in < 0) a.stop_in = 2;
    }
    return ErrorCode::kOk;
  }
  ErrorCode emergency_stop(std::span<const int> axes) noexcept override {
    std::lock_guard lock(c_->mutex);
    ++c_->emergency_stops;
    for (int axis : axes) {
      auto& a = c_->axes[axis];
      a.moving = false;
      a.estopped = true;
      a.stop_in = -1;
    }
    return ErrorCode::kOk;
  }
  ErrorCode axis_status(int axis, drivers::AxisStatus& out) noexcept override {
    std::unique_lock lock(c_->mutex);
    c_->unblocked.wait(lock, [this] { return !c_->block_status; });
    auto& a = c_->axes[axis];
    if (a.moving) {
      if (a.stop_in >= 0) {
        if (!c_->hold_stop && --a.stop_in <= 0) a.moving = false;
      } else if (!c_->hold_motion) {
        if (--a.remaining <= 0) {
          a.position = a.target;
          a.moving = false;
        } else {
          a.position += (a.target - a.position) / (a.remaining + 1);
        }
      }
    }
    drivers::AxisStatus s;
    s.enabled = true;
    s.moving = a.moving;
    s.in_position = !a.moving && a.position == a.target;
    s.alarm = c_->alarm_axes.count(axis) != 0;
    s.emergency_stopped = a.estopped;
    s.profile_position_counts = a.position;
    s.encoder_position_counts = a.position;
    out = s;
    return ErrorCode::kOk;
  }

 private:
  std::shared_ptr<FakeCardControl> c_;
};

}  // namespace ajar::testing
