// The engine's wheel motions (wheel_motions.hpp).
#include "wheel_motions.hpp"

#include <string>

namespace ajar::daemon::detail {

bool WheelMotions::start_move(std::int64_t left_counts, std::int64_t right_counts,
                              MoveProfile profile, WheelKind kind) {
  const MoveCommand move{last_id_ + 1, left_counts, right_counts, profile};
  if (!hand_over(move)) return false;
  begin(move.motion_id, kind);
  return true;
}

bool WheelMotions::start_jog(const core::BodyVelocity& velocity, std::int64_t stamp_ns) {
  const DriveCommand start{last_id_ + 1, true, velocity, stamp_ns};
  if (!hand_over(start)) return false;
  begin(start.motion_id, WheelKind::kJog);
  return true;
}

bool WheelMotions::update_jog(const core::BodyVelocity& velocity, std::int64_t stamp_ns) {
  if (held_drive_ && held_drive_->motion_id == current_) {
    held_drive_->velocity = velocity;
    held_drive_->stamp_ns = stamp_ns;
    return true;
  }
  return hand_over(DriveCommand{current_, false, velocity, stamp_ns});
}

std::optional<WheelKind> WheelMotions::close(std::uint32_t motion_id) noexcept {
  if (motion_id != current_ || current_ == 0) return std::nullopt;
  current_ = 0;
  return kind_;
}

bool WheelMotions::hand_over(const MoveCommand& move) {
  if (!in_read_batch_) return loop_.post_move(move);
  held_move_ = move;
  return true;
}

bool WheelMotions::hand_over(const DriveCommand& drive) {
  if (!in_read_batch_) return loop_.post_drive(drive);
  held_drive_ = drive;
  return true;
}

bool WheelMotions::sync_door_guard(const DoorGuard& guard) {
  if (guard == posted_guard_) return true;
  if (!loop_.post_door_guard(guard)) return false;
  posted_guard_ = guard;
  return true;
}

Outcome WheelMotions::check_at_rest() const {
  if (current_ == 0 || kind_ == WheelKind::kAlign) return Ok{};
  return make_error(ErrorCode::kMotionInProgress, "",
                    std::string("the base is moving (") + what_moves(kind_) +
                        "): wait for it to come to rest (motion_finished), or Stop");
}

Outcome WheelMotions::check_stopped() const {
  if (current_ == 0) return Ok{};
  return make_error(ErrorCode::kMotionInProgress, "",
                    "the wheels are still stopping: wait for them to rest");
}

Outcome WheelMotions::check_may_drive(bool jog) const {
  if (current_ == 0) return Ok{};
  if (stopping_) {  // a motion in progress, as for every other command (protocol.md 6.6)
    return make_error(ErrorCode::kMotionInProgress, "",
                      "the wheels are still stopping: wait for motion_stopped");
  }
  if (kind_ == WheelKind::kApproach) {
    return make_error(ErrorCode::kMotionInProgress, "",
                      "an approach is running: wait for motion_finished, or Stop");
  }
  if (jog) return Ok{};  // updates the running jog
  return make_error(ErrorCode::kMotionInProgress, "",
                    "the base is being driven: release the drive keys (or Stop) and wait for "
                    "motion_finished");
}

}  // namespace ajar::daemon::detail
