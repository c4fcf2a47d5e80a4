// Internal to the engine: WheelMotions, the engine's side of the wheel motions it hands to the
// control loop (align, approach, jog). At most one is announced and not yet ended (current(), 0:
// none); motion ids count up from 1. During a read batch (Engine::begin_read_batch) a new move or
// jog is held instead of posted, so that a stop later in the same read cancels it before any wheel
// turns; end_read_batch() posts what is still held. It emits nothing and touches no procedure
// state: the engine does, from what these calls return.
#pragma once

#include <cstdint>
#include <optional>

#include "ajar/core/error.hpp"
#include "ajar/daemon/control_loop.hpp"

namespace ajar::daemon::detail {

enum class WheelKind : std::uint8_t { kAlign, kApproach, kJog };

// The words of the events that close a wheel motion.
inline const char* what_moves(WheelKind kind) {
  return kind == WheelKind::kJog        ? "driving"
         : kind == WheelKind::kApproach ? "approach"
                                        : "alignment";
}

class WheelMotions {
 public:
  explicit WheelMotions(ControlLoop& loop) : loop_(loop) {}

  std::uint32_t current() const noexcept { return current_; }  // 0: no wheel motion
  WheelKind kind() const noexcept { return kind_; }            // what current() is
  bool stopping() const noexcept { return stopping_; }         // a stop was asked for current()
  bool held() const noexcept { return held_move_.has_value() || held_drive_.has_value(); }

  // A stop (or a fault stop) was asked: the current motion, if any, is stopping.
  void stopping_asked() noexcept {
    if (current_ != 0) stopping_ = true;
  }

  // Starts a move (align, approach) or a jog with the next motion id: handed to the loop (or held
  // for the end of this read). False: the loop's command queue is full; nothing was started.
  bool start_move(std::int64_t left_counts, std::int64_t right_counts, MoveProfile profile,
                  WheelKind kind);
  bool start_jog(const core::BodyVelocity& velocity, std::int64_t stamp_ns);
  // A new velocity for the running jog (merged into a jog held in this read). False: queue full.
  bool update_jog(const core::BodyVelocity& velocity, std::int64_t stamp_ns);

  // The loop ended `motion_id` (or it never started): when it is the current motion, it is no
  // longer, and its kind is returned; else nothing (an older motion, already closed).
  std::optional<WheelKind> close(std::uint32_t motion_id) noexcept;
  // Shutdown: the wheels were emergency-stopped, the motion is over whatever the loop reports.
  void forget() noexcept { current_ = 0; }

  void begin_read_batch() noexcept { in_read_batch_ = true; }
  // Posts what this read held; `refused(motion_id)` for a started motion the full queue refused.
  template <typename F>
  void end_read_batch(F&& refused);
  // Drops what this read held (a stop came): `cancelled(motion_id)` for each motion it started.
  template <typename F>
  void cancel_held(F&& cancelled);

  // The forward jog's door guard: posted when it changed. False: the queue is full.
  bool sync_door_guard(const DoorGuard& guard);

  // Measurements, AlignBase and Engage while a Drive or Approach moves the wheels.
  Outcome check_at_rest() const;
  // AlignBase and Engage while any wheel motion (also an alignment's stop) has not ended.
  Outcome check_stopped() const;
  // Drive (jog = true) or Approach while a wheel motion runs: only a running jog may be updated.
  Outcome check_may_drive(bool jog) const;

 private:
  bool hand_over(const MoveCommand& move);
  bool hand_over(const DriveCommand& drive);
  void begin(std::uint32_t id, WheelKind kind) noexcept {
    last_id_ = id;
    current_ = id;
    kind_ = kind;
    stopping_ = false;
  }

  ControlLoop& loop_;
  std::uint32_t last_id_ = 0;  // the last motion id handed to the loop
  std::uint32_t current_ = 0;  // the announced wheel motion the loop has not ended (0: none)
  WheelKind kind_ = WheelKind::kAlign;
  bool stopping_ = false;
  bool in_read_batch_ = false;
  std::optional<MoveCommand> held_move_;    // accepted in this read, not yet handed to the loop
  std::optional<DriveCommand> held_drive_;  // likewise (the last Drive of this read)
  DoorGuard posted_guard_;  // the door guard the loop has (or will have: posted in order)
};

template <typename F>
void WheelMotions::end_read_batch(F&& refused) {
  in_read_batch_ = false;
  if (held_move_) {
    const MoveCommand move = *held_move_;
    held_move_.reset();
    if (!loop_.post_move(move)) refused(move.motion_id);
  }
  if (held_drive_) {
    const DriveCommand drive = *held_drive_;
    held_drive_.reset();
    if (!loop_.post_drive(drive) && drive.start) refused(drive.motion_id);
  }
}

template <typename F>
void WheelMotions::cancel_held(F&& cancelled) {
  if (held_drive_) {  // an update needs nothing more: the stop ends its jog
    const DriveCommand drive = *held_drive_;
    held_drive_.reset();
    if (drive.start) cancelled(drive.motion_id);
  }
  if (!held_move_) return;
  const std::uint32_t id = held_move_->motion_id;
  held_move_.reset();
  cancelled(id);
}

}  // namespace ajar::daemon::detail
