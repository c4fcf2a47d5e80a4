#include "ajar/drivers/mock_card.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "ajar/drivers/card_checks.hpp"

namespace ajar::drivers {

using card::fail;

std::int64_t CardCallRecord::distance_counts(int axis) const noexcept {
  for (const AxisMove& m : moves)
    if (m.axis == axis) return m.distance_counts;
  return 0;
}

double CardCallRecord::velocity_counts_per_ms(int axis) const noexcept {
  for (const AxisVelocity& v : velocities)
    if (v.axis == axis) return v.velocity_counts_per_ms;
  return 0;
}

bool CardCallRecord::jogs() const noexcept {
  return std::any_of(velocities.begin(), velocities.end(),
                     [](const AxisVelocity& v) { return v.velocity_counts_per_ms != 0; });
}

MockMotionCard::MockMotionCard(MockFault fault, int slow_ms, double time_scale, int axis_count,
                               MockClock clock)
    : fault_(fault),
      slow_ms_(std::max(0, slow_ms)),
      time_scale_(time_scale > 0 && std::isfinite(time_scale) ? time_scale : 1.0),
      axis_count_(std::clamp(axis_count, 1, 32)),
      clock_(or_steady_clock(std::move(clock))),
      epoch_ns_(clock_()),
      axes_(static_cast<std::size_t>(axis_count_)) {}

std::int64_t MockMotionCard::now_ns() const noexcept {
  if (manual_clock_) return manual_ns_;
  const std::int64_t real_ns = clock_() - epoch_ns_;
  return base_ns_ + std::llround(static_cast<double>(real_ns) * time_scale_);
}

void MockMotionCard::set_manual_clock(bool manual) noexcept {
  const Lock lock(mutex_);
  const std::int64_t now = now_ns();
  manual_clock_ = manual;
  manual_ns_ = now;
  base_ns_ = now;
  epoch_ns_ = clock_();
}

void MockMotionCard::advance_clock_ns(std::int64_t ns) noexcept {
  const Lock lock(mutex_);
  if (manual_clock_ && ns > 0) manual_ns_ += ns;
}

// --- test configuration and observation -------------------------------------------------------

std::uint64_t MockMotionCard::calls() const noexcept {
  const Lock lock(mutex_);
  return calls_;
}
std::uint64_t MockMotionCard::calls(CardCall kind) const noexcept {
  const Lock lock(mutex_);
  return calls_by_kind_[static_cast<std::size_t>(kind)];
}
void MockMotionCard::set_motion_model(MockMotionModel model, std::int64_t stop_delay_ns) noexcept {
  const Lock lock(mutex_);
  model_ = model;
  stop_delay_ns_ = std::max<std::int64_t>(0, stop_delay_ns);
}
void MockMotionCard::block_calls(CardCall kind, int count, int block_ms) {
  const Lock lock(mutex_);
  block_ = BlockRule{kind, count, block_ms};
}

void MockMotionCard::release_blocked_calls() {
  {
    const Lock lock(mutex_);
    block_ = BlockRule{};
    ++release_generation_;
  }
  unblocked_.notify_all();
}

std::size_t MockMotionCard::blocked_calls() const noexcept {
  const Lock lock(mutex_);
  return blocked_now_;
}

void MockMotionCard::set_block_status(bool block) {
  if (block) {
    block_calls(CardCall::kAxisStatus, -1, -1);
  } else {
    release_blocked_calls();
  }
}

void MockMotionCard::hang_if_blocked(Lock& lock, CardCall kind) noexcept {
  if (block_.remaining == 0 || block_.kind != kind) return;
  if (block_.remaining > 0) --block_.remaining;
  const std::uint64_t generation = release_generation_;
  const auto released = [&] { return release_generation_ != generation; };
  ++blocked_now_;
  if (block_.block_ms < 0) {
    unblocked_.wait(lock, released);
  } else {
    unblocked_.wait_for(lock, std::chrono::milliseconds(block_.block_ms), released);
  }
  --blocked_now_;
}

void MockMotionCard::drop_next_calls(CardCall kind, int n) noexcept {
  set_locked(drop_calls_[static_cast<std::size_t>(kind)], n < 0 ? 0 : n);
}
void MockMotionCard::fail_after_next_call(CardCall kind) noexcept {
  set_locked(fail_after_calls_[static_cast<std::size_t>(kind)], 1);
}
void MockMotionCard::set_stale_status_reads(int n) noexcept {
  const Lock lock(mutex_);
  for (Axis& a : axes_)
    a.stale_reads = n < 0 ? 0 : n;
}
void MockMotionCard::stop_answering_for_ns(std::int64_t ns) noexcept {
  const Lock lock(mutex_);
  silent_until_ns_ = ns > 0 ? now_ns() + ns : -1;
}
bool MockMotionCard::answering() const noexcept {
  const Lock lock(mutex_);
  return now_ns() >= silent_until_ns_;
}

bool MockMotionCard::misbehaving() const noexcept {
  const Lock lock(mutex_);
  const auto pending = [](const auto& counts) {
    return std::any_of(counts.begin(), counts.end(), [](int n) { return n > 0; });
  };
  return pending(drop_calls_) || pending(fail_after_calls_) || now_ns() < silent_until_ns_ ||
         std::any_of(axes_.begin(), axes_.end(), [](const Axis& a) { return a.stale_reads > 0; });
}

bool MockMotionCard::take_drop(CardCall kind) noexcept {
  int& n = drop_calls_[static_cast<std::size_t>(kind)];
  if (n == 0) return false;
  --n;
  call_applied_ = false;
  return true;
}

ErrorCode MockMotionCard::applied_result(CardCall kind, ErrorCode result,
                                         const char* call) noexcept {
  int& n = fail_after_calls_[static_cast<std::size_t>(kind)];
  if (result != ErrorCode::kOk || n == 0) return result;
  --n;
  return fail(last_, ErrorCode::kCardCommunication, call, 0,
              "mock card: no answer after taking the command (test)");
}

AxisStatus MockMotionCard::peek(int n) noexcept {
  const Lock lock(mutex_);
  return valid(n) ? status_of(axis(n)) : AxisStatus{};
}

double MockMotionCard::velocity(int n) noexcept {
  const Lock lock(mutex_);
  double v = 0;
  if (valid(n)) (void)sample(axis(n), &v);
  return v;
}

bool MockMotionCard::any_moving() noexcept {
  const Lock lock(mutex_);
  double velocity = 0;
  return std::any_of(axes_.begin(), axes_.end(), [&](Axis& a) {
    (void)sample(a, &velocity);
    return a.moving;
  });
}

bool MockMotionCard::jogging(int n) noexcept {
  const Lock lock(mutex_);
  if (!valid(n)) return false;
  double velocity = 0;
  Axis& a = axis(n);
  (void)sample(a, &velocity);
  return a.moving && a.jogging;
}

std::size_t MockMotionCard::motion_call(int n) const noexcept {
  const Lock lock(mutex_);
  return valid(n) ? axes_[static_cast<std::size_t>(n - 1)].motion_call : 0;
}

std::size_t MockMotionCard::log_size() const {
  const Lock lock(mutex_);
  return log_.size();
}

std::vector<CardCallRecord> MockMotionCard::log_from(std::size_t index) const {
  const Lock lock(mutex_);
  if (index >= log_.size()) return {};
  return {log_.begin() + static_cast<std::ptrdiff_t>(index), log_.end()};
}

CardFailure MockMotionCard::last_failure() const noexcept {
  const Lock lock(mutex_);
  return last_;
}

// --- the model --------------------------------------------------------------------------------

double MockMotionCard::sample(Axis& a, double* velocity) noexcept {
  *velocity = 0;
  if (!a.moving) return a.rest_position;
  if (a.stuck) {
    if (a.stop_held && !stops_never_rest_) a.moving = a.stuck = a.stop_held = false;
    return a.rest_position;
  }
  const profile::Sample s = profile::sample(a.motion, now_ns());
  if (s.done) {
    a.moving = false;
    a.rest_position = s.position;
    return s.position;
  }
  *velocity = s.velocity;
  return s.position;
}

void MockMotionCard::halt(Axis& a) noexcept {
  double velocity = 0;
  a.rest_position = std::round(sample(a, &velocity));
  a.moving = false;
  a.stuck = a.stop_held = false;
}

AxisStatus MockMotionCard::flags_of(const Axis& a) noexcept {
  AxisStatus st;
  st.enabled = a.enabled;
  st.alarm = a.alarm;
  st.following_error = a.following_error;
  st.positive_limit = a.positive_limit;
  st.negative_limit = a.negative_limit;
  st.smooth_stopped = a.smooth_stopped;
  st.emergency_stopped = a.emergency_stopped;
  return st;
}

AxisStatus MockMotionCard::status_of(Axis& a) noexcept {
  double speed = 0;
  const double position = sample(a, &speed);
  AxisStatus st = flags_of(a);
  st.moving = a.moving;
  st.in_position = !a.moving && a.enabled;
  st.profile_position_counts = std::llround(position);
  st.encoder_position_counts = std::llround(position);
  return st;
}

ErrorCode MockMotionCard::check_can_move(int n, double direction, const char* call) noexcept {
  const std::int64_t sign = direction > 0 ? 1 : (direction < 0 ? -1 : 0);
  return card::check_can_move(flags_of(axis(n)), n, sign, call, last_);
}

ErrorCode MockMotionCard::check_can_start(int n, double direction, bool jog,
                                          const char* call) noexcept {
  if (const auto e = check_can_move(n, direction, call); e != ErrorCode::kOk) return e;
  double velocity = 0;
  Axis& a = axis(n);
  (void)sample(a, &velocity);
  if (a.moving && a.jogging != jog) {  // like the card: no mode change while the axis moves
    return fail(
        last_, ErrorCode::kDriverError, call, n,
        jog ? "axis runs a trapezoidal move: stop it first" : "axis is jogging: stop it first");
  }
  return ErrorCode::kOk;
}

void MockMotionCard::start(Axis& a, bool jog, bool stuck, double direction, double here,
                           double stop_dec, const profile::Motion& motion) noexcept {
  a.smooth_stopped = false;
  a.stuck = stuck;
  a.stop_held = false;
  a.jogging = jog;
  a.stop_dec = stop_dec;
  a.direction = direction;
  a.rest_position = here;
  a.motion_call = log_.size();
  a.motion = motion;
  a.moving = true;
  double velocity = 0;
  if (!a.stuck) (void)sample(a, &velocity);  // nothing to do: ends here
}

ErrorCode MockMotionCard::enter(Lock& lock, CardCall kind, const char* call,
                                bool realtime) noexcept {
  if (fault_ == MockFault::kSlow) std::this_thread::sleep_for(std::chrono::milliseconds(slow_ms_));
  lock = Lock(mutex_);
  call_applied_ = true;
  ++calls_;
  ++calls_by_kind_[static_cast<std::size_t>(kind)];
  hang_if_blocked(lock, kind);
  if (!realtime) return ErrorCode::kOk;
  if (fault_ == MockFault::kErrorCode) {
    return fail(last_, ErrorCode::kDriverError, call, 0, "mock card: injected error code");
  }
  if (fault_ == MockFault::kIntermittent && ++fault_calls_ % 3 == 0) {
    return fail(last_, ErrorCode::kCardCommunication, call, 0,
                "mock card: intermittent failure (every third call)");
  }
  if (now_ns() < silent_until_ns_) {  // a card that does not answer at all (e-stop included)
    return fail(last_, ErrorCode::kCardCommunication, call, 0, "mock card: not answering (test)");
  }
  if (fail_calls_ > 0 && kind != CardCall::kEmergencyStop) {
    --fail_calls_;
    return fail(last_, ErrorCode::kCardCommunication, call, 0, "mock card: not answering (test)");
  }
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::check_open(const char* call) noexcept {
  if (!open_) return fail(last_, ErrorCode::kDriverError, call, 0, "mock card is not open");
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::check_axes(std::span<const int> axes, const char* call) noexcept {
  if (const auto e = check_open(call); e != ErrorCode::kOk) return e;
  return card::check_axes(axes, axis_count_, call, last_);
}

ErrorCode MockMotionCard::logged(CardCallRecord&& record, ErrorCode result) noexcept {
  record.result = result;
  record.applied = call_applied_;
  call_applied_ = true;
  log_.push_back(std::move(record));  // tests only (record_calls): may allocate
  return result;
}

CardCallRecord MockMotionCard::record(CardCall kind, std::span<const int> axes) const {
  CardCallRecord r;
  r.kind = kind;
  r.at_ns = now_ns();
  r.axes.assign(axes.begin(), axes.end());
  return r;
}

void MockMotionCard::inject_alarm(int n) {
  const Lock lock(mutex_);
  if (!valid(n)) return;
  Axis& a = axis(n);
  halt(a);
  a.alarm = true;
  a.enabled = false;
}

void MockMotionCard::inject_following_error(int n) {
  const Lock lock(mutex_);
  if (!valid(n)) return;
  halt(axis(n));
  axis(n).following_error = true;
}

void MockMotionCard::inject_limit(int n, bool positive) {
  const Lock lock(mutex_);
  if (!valid(n)) return;
  Axis& a = axis(n);
  if (a.moving && (a.direction > 0) == positive) halt(a);
  (positive ? a.positive_limit : a.negative_limit) = true;
}

}  // namespace ajar::drivers
