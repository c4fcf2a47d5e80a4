// The control loop: construction, the thread and its timing, the command queues the I/O thread
// posts to, and one cycle. Motions are started and advanced in control_loop_motion.cpp; the card's
// status, supervision and stops are in control_loop_supervision.cpp.
#include "ajar/daemon/control_loop.hpp"

#include <pthread.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <limits>
#include <numbers>

#include "ajar/core/geometry.hpp"
#include "ajar/daemon/realtime.hpp"
#include "ajar/recorder/recorder.hpp"
#include "control_loop_units.hpp"

namespace ajar::daemon {
namespace {

// Motor counts per radian at the wheel.
double counts_per_wheel_rad(const core::BaseGeometry& base) noexcept {
  return base.gear_ratio * base.encoder_counts_per_rev / (2.0 * std::numbers::pi);
}

}  // namespace

drivers::TrapezoidProfile wheel_profile(const core::BaseGeometry& base) noexcept {
  const double per_rad = counts_per_wheel_rad(base);
  drivers::TrapezoidProfile profile;
  profile.velocity_counts_per_ms = base.max_wheel_speed_rad_s * per_rad / 1e3;
  profile.acceleration_counts_per_ms2 = base.max_wheel_accel_rad_s2 * per_rad / 1e6;
  profile.deceleration_counts_per_ms2 = profile.acceleration_counts_per_ms2;
  profile.smooth_time_ms = 0;
  return profile;
}

drivers::TrapezoidProfile straight_profile(const core::BaseGeometry& base,
                                           const core::DriveLimits& drive) noexcept {
  const double per_rad = counts_per_wheel_rad(base);
  drivers::TrapezoidProfile profile = wheel_profile(base);
  profile.velocity_counts_per_ms =
      std::min(profile.velocity_counts_per_ms,
               drive.max_linear_speed_m_s / base.wheel_radius_m * per_rad / 1e3);
  profile.acceleration_counts_per_ms2 =
      std::min(profile.acceleration_counts_per_ms2,
               drive.max_linear_accel_m_s2 / base.wheel_radius_m * per_rad / 1e6);
  profile.deceleration_counts_per_ms2 = profile.acceleration_counts_per_ms2;
  return profile;
}

drivers::TrapezoidProfile move_profile(const MoveCommand& move, const core::BaseGeometry& base,
                                       const core::DriveLimits& drive) noexcept {
  // Wheel-forward counts (polarity removed): a turn in place has them exactly opposite.
  const std::int64_t left = base.left.polarity < 0 ? -move.left_counts : move.left_counts;
  const std::int64_t right = base.right.polarity < 0 ? -move.right_counts : move.right_counts;
  const bool turn_in_place = left == -right;
  return move.profile == MoveProfile::kStraight || !turn_in_place ? straight_profile(base, drive)
                                                                  : wheel_profile(base);
}

drivers::JogProfile jog_profile(const core::BaseGeometry& base,
                                const core::DriveLimits& drive) noexcept {
  const double per_rad = counts_per_wheel_rad(base);
  const double wheel_rad_s2 = std::min(
      base.max_wheel_accel_rad_s2,
      (drive.max_linear_accel_m_s2 + drive.max_angular_accel_rad_s2 * base.turning_radius_m) /
          base.wheel_radius_m);
  const double counts_per_ms2 = wheel_rad_s2 * per_rad / 1e6;
  return drivers::JogProfile{counts_per_ms2, counts_per_ms2, 0};
}

double door_guard_room_m(const DoorGuard& guard, const core::PlanarPose& pose) noexcept {
  constexpr double kNone = std::numeric_limits<double>::infinity();
  if (guard.mode != DoorGuard::Mode::kStandoff) return kNone;
  // The rate at which driving forward closes the distance (the normal points at the robot).
  const double closing = -(guard.line.normal_x_m * std::cos(pose.yaw_rad) +
                           guard.line.normal_y_m * std::sin(pose.yaw_rad));
  if (!(closing > 1e-9)) return kNone;
  return (core::door_distance_m(guard.line, pose.x_m, pose.y_m) - guard.standoff_m) / closing;
}

double planned_duration_s(std::int64_t distance_counts,
                          const drivers::TrapezoidProfile& profile) noexcept {
  const double d = std::abs(static_cast<double>(distance_counts));
  const double v = profile.velocity_counts_per_ms;
  const double a =
      std::min(profile.acceleration_counts_per_ms2, profile.deceleration_counts_per_ms2);
  if (d == 0 || v <= 0 || a <= 0) return 0;
  const double ramp_distance = v * v / a;  // accelerate to v and decelerate back to 0
  const double ms = d >= ramp_distance ? d / v + v / a : 2.0 * std::sqrt(d / a);
  return ms / 1e3;
}

ControlLoop::ControlLoop(drivers::MotionCard& card, const ControlLoopSettings& settings)
    : card_(card),
      settings_(settings),
      axes_{settings.base.left.card_axis, settings.base.right.card_axis},
      counts_per_wheel_rad_(counts_per_wheel_rad(settings.base)),
      max_wheel_counts_per_ms_(settings.base.max_wheel_speed_rad_s * counts_per_wheel_rad_ / 1e3),
      card_scale_(settings.card_time_scale > 0 && std::isfinite(settings.card_time_scale)
                      ? settings.card_time_scale
                      : 1.0),
      period_ns_(std::max<std::int64_t>(1, std::llround(kNsPerS / settings.control.rate_hz))),
      deadman_ns_(seconds_to_ns(settings.safety.deadman_timeout_s)),
      margin_ns_(seconds_to_ns(settings.control.motion_timeout_margin_s)),
      mismatch_ns_(seconds_to_ns(settings.velocity_mismatch_s)),
      recovery_(seconds_to_ns(settings.recovery_timeout_s)),
      jog_(settings, jog_profile(settings.base, settings.drive), counts_per_wheel_rad_, card_scale_,
           period_ns_),
      statistics_(settings.control.rate_hz) {}

ControlLoop::~ControlLoop() {
  stop_thread();
}

std::vector<std::string> ControlLoop::start_thread() {
  if (thread_.joinable()) return {};
  exit_requested_.store(false);
  thread_ended_.store(false);
  std::promise<std::vector<std::string>> warnings;
  auto ready = warnings.get_future();
  const RealtimeRequest request{settings_.control.realtime, settings_.control.priority,
                                settings_.control.lock_memory};
  last_cycle_end_ns_.store(monotonic_now_ns());
  thread_ = std::thread([this, request, promise = std::move(warnings)]() mutable {
    thread_tid_.store(static_cast<int>(::gettid()), std::memory_order_release);
    pthread_setname_np(pthread_self(), "ajar-loop");  // top -H, perf, /proc/PID/task/*/comm
    auto refused = apply_realtime(request);
    const std::int64_t first = monotonic_now_ns() + period_ns_;
    promise.set_value(std::move(refused));
    thread_main(first);
    thread_ended_.store(true, std::memory_order_release);
  });
  auto result = ready.get();
  thread_running_.store(true, std::memory_order_release);
  return result;
}

void ControlLoop::stop_thread() noexcept {
  thread_running_.store(false, std::memory_order_release);
  exit_requested_.store(true);
  if (thread_.joinable()) thread_.join();
}

bool ControlLoop::stop_thread(std::int64_t limit_ns) noexcept {
  thread_running_.store(false, std::memory_order_release);
  exit_requested_.store(true);
  if (!thread_.joinable()) return true;
  const std::int64_t give_up = monotonic_now_ns() + limit_ns;
  while (!thread_ended_.load(std::memory_order_acquire)) {
    if (monotonic_now_ns() >= give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  thread_.join();
  return true;
}

void ControlLoop::thread_main(std::int64_t first_deadline_ns) noexcept {
  const OwnSchedstat own;  // this thread's: what it publishes of its sleep (sleep_record())
  // A realtime thread's waits are never excused (loop_supervisor.hpp): it publishes nothing, and
  // its cycle makes no system call for it (sleep_record() stays "awake").
  const bool publish_sleep = !thread_is_realtime(0);
  std::int64_t deadline = first_deadline_ns;
  while (!exit_requested_.load(std::memory_order_relaxed)) {
    if (publish_sleep) sleep_.store(own.going_to_sleep(deadline));
    sleep_until_ns(deadline);
    if (publish_sleep) sleep_.store(LoopSleep{});  // awake: the first thing it does with its CPU
    const std::int64_t wake = monotonic_now_ns();
    cycle(wake);
    const std::int64_t end = monotonic_now_ns();
    statistics_.record_cycle(deadline, wake, end);
    last_cycle_end_ns_.store(end, std::memory_order_release);
    if (recorder_ != nullptr) record_sample(deadline, wake, end);
    deadline += period_ns_;
    if (end > deadline) {  // missed at least one deadline: count it, skip to the next free slot
      statistics_.record_overrun();
      while (deadline <= end)
        deadline += period_ns_;
    }
  }
}

bool ControlLoop::post(Command c) noexcept {
  c.stop_stamp = stop_generation_.load();
  c.latch_stamp = latch_generation_.load();
  return commands_.push(c);
}
void ControlLoop::record_sample(std::int64_t deadline_ns, std::int64_t wake_ns,
                                std::int64_t end_ns) noexcept {
  // Velocities from the counts since the previous cycle (every cycle, decimated or not).
  const double dt_s = static_cast<double>(wake_ns - sample_last_wake_ns_) / 1e9;
  const bool have_last = sample_last_wake_ns_ != 0 && dt_s > 0;
  const std::int64_t previous_wake = sample_last_wake_ns_;
  sample_last_wake_ns_ = wake_ns;
  std::int64_t last[2][2];
  std::copy(&sample_last_counts_[0][0], &sample_last_counts_[0][0] + 4, &last[0][0]);
  for (int i = 0; i < 2; ++i) {
    sample_last_counts_[i][0] = status_[i].profile_position_counts;
    sample_last_counts_[i][1] = status_[i].encoder_position_counts;
  }
  if (!recorder_->take_loop_sample()) return;
  recorder::LoopSample s;
  s.cycle = snapshot_.cycles;
  s.time_ns = wake_ns;
  const core::WheelAxis* wheels[2] = {&settings_.base.left, &settings_.base.right};
  for (int i = 0; i < 2; ++i) {
    const auto rad = [&](std::int64_t counts) {
      return core::counts_to_wheel_rad(counts, *wheels[i], settings_.base);
    };
    s.commanded_rad[i] = rad(status_[i].profile_position_counts - origin_counts_[i]);
    s.measured_rad[i] = rad(status_[i].encoder_position_counts - origin_counts_[i]);
    if (have_last) {
      s.commanded_rad_s[i] = rad(status_[i].profile_position_counts - last[i][0]) / dt_s;
      s.measured_rad_s[i] = rad(status_[i].encoder_position_counts - last[i][1]) / dt_s;
    }
    s.counts[i] = status_[i].encoder_position_counts;
  }
  s.x_m = snapshot_.pose.x_m;
  s.y_m = snapshot_.pose.y_m;
  s.yaw_rad = snapshot_.pose.yaw_rad;
  s.commanded_linear_m_s = snapshot_.commanded.linear_m_s;
  s.commanded_angular_rad_s = snapshot_.commanded.angular_rad_s;
  s.motion = static_cast<std::uint8_t>(motion_);
  s.phase = recovery_.running()                                            ? 3
            : motion_ == Motion::kStopping || (jog_.resting() && moving()) ? 2
            : moving()                                                     ? 1
                                                                           : 0;
  s.fault = static_cast<std::uint16_t>(fault_);
  s.motion_id = motion_id_;
  s.stop_generation = handled_stop_;
  s.wakeup_latency_ns = wake_ns - deadline_ns;
  s.execution_ns = end_ns - wake_ns;
  s.period_ns = previous_wake != 0 ? wake_ns - previous_wake : 0;
  recorder_->loop_sample(s);
}

bool ControlLoop::post_move(const MoveCommand& move) noexcept {
  Command c;
  c.kind = CommandKind::kMove;
  c.move = move;
  return post(c);
}
bool ControlLoop::post_drive(const DriveCommand& drive) noexcept {
  Command c;
  c.kind = drive.start ? CommandKind::kDriveStart : CommandKind::kDriveUpdate;
  c.drive = drive;
  return post(c);
}
bool ControlLoop::post_door_guard(const DoorGuard& guard) noexcept {
  Command c;
  c.kind = CommandKind::kDoorGuard;
  c.guard = guard;
  return post(c);
}
bool ControlLoop::request_recover(std::uint32_t sequence) noexcept {
  Command c;
  c.kind = CommandKind::kRecover;
  c.sequence = sequence;
  return post(c);
}
// The generations are bumped after the code is queued: a cycle that sees the new generation sees
// the code too. The emergency generation is bumped before the latch generation for the same reason.
void ControlLoop::request_stop() noexcept {
  stop_generation_.fetch_add(1);
}
void ControlLoop::request_emergency_stop() noexcept {
  emergency_generation_.fetch_add(1);
  stop_generation_.fetch_add(1);
  latch_generation_.fetch_add(1);
}
void ControlLoop::request_fault_stop(ErrorCode code) noexcept {
  if (!fault_codes_.push(code)) {
    std::uint16_t none = 0;
    (void)fault_overflow_code_.compare_exchange_strong(none, static_cast<std::uint16_t>(code));
  }
  stop_generation_.fetch_add(1);
  latch_generation_.fetch_add(1);
}
void ControlLoop::latch_stalled() noexcept {
  stall_pending_.store(true);
  stop_generation_.fetch_add(1);
  latch_generation_.fetch_add(1);
}
void ControlLoop::set_arm_moving(bool moving) noexcept {
  arm_moving_.store(moving, std::memory_order_release);
}
void ControlLoop::set_arm_at_door(bool at_door) noexcept {
  arm_at_door_.store(at_door, std::memory_order_release);
}
bool ControlLoop::pop_report(LoopReport& r) noexcept {
  return reports_.pop(r);
}
void ControlLoop::heartbeat(std::int64_t now_ns) noexcept {
  heartbeat_ns_.store(now_ns, std::memory_order_release);
}

bool ControlLoop::healthy(std::int64_t now_ns) const noexcept {
  if (!thread_running_.load(std::memory_order_acquire)) return false;
  const std::int64_t limit = std::max<std::int64_t>(10 * period_ns_, 20'000'000);
  return now_ns - last_cycle_end_ns_.load(std::memory_order_acquire) <= limit;
}

void ControlLoop::cycle(std::int64_t now_ns) noexcept {
  read_axes(now_ns);  // first: odometry and a move's start position come from before any command
  handle_stops(now_ns);
  if (recovery_.running()) advance_recovery(now_ns);
  while (!recovery_.running()) {  // the queue waits behind a running recovery
    Command c;
    if (!commands_.pop(c)) break;
    execute(c, now_ns);
  }

  supervise(now_ns);
  if (motion_ == Motion::kJogging) advance_jog(now_ns);

  ++snapshot_.cycles;
  snapshot_.time_ns = now_ns;
  snapshot_.motion_active = motion_ != Motion::kIdle;
  snapshot_.jogging = motion_ == Motion::kJogging;
  snapshot_.commanded = within_wheel_cap(jog_.command(), settings_.base);
  snapshot_.fault = fault_;
  snapshot_.recover_sequence = recovery_.sequence();
  snapshot_.recovering = recovery_.running();
  snapshot_.card_state = card_state();
  snapshot_.reports_dropped = reports_dropped_;
  published_.store(snapshot_);
}

drivers::LifecycleState ControlLoop::card_state() const noexcept {
  if (!answered_) return drivers::LifecycleState::kFault;
  switch (fault_) {
    case ErrorCode::kCardCommunication:
    case ErrorCode::kAxisAlarm:
    case ErrorCode::kFollowingError:
    case ErrorCode::kDriverError:
    case ErrorCode::kDriverNotActive:
    case ErrorCode::kLoopStalled:  // a card call hung
      return drivers::LifecycleState::kFault;
    default:
      break;
  }
  if (recovery_.running()) return drivers::LifecycleState::kInactive;
  return status_[0].enabled && status_[1].enabled ? drivers::LifecycleState::kActive
                                                  : drivers::LifecycleState::kInactive;
}

}  // namespace ajar::daemon
