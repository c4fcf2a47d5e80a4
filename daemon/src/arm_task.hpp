// Internal to the engine: ArmTask, the arm's side of the procedure. It owns the manipulator (its
// lifecycle wrapper), the one door task the arm runs at a time (Engage) and the arm interlock
// (docs/procedure.md, "The arm interlock"): whether the arm may still be at the door, and a stop
// that must be confirmed by an idle report before a deadline. It tells the control loop whether the
// arm may be at the door (the loop's own refusal to start a wheel motion). It latches nothing and
// emits nothing itself: what it finds is returned to the engine (ArmVerdict), which does.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "ajar/core/error.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/drivers/lifecycle.hpp"

namespace ajar::daemon::detail {

// What supervising the arm found that the engine must act on.
struct ArmVerdict {
  enum class Kind : std::uint8_t { kNone, kTaskDone, kFault };
  Kind kind = Kind::kNone;
  ErrorCode code = ErrorCode::kOk;  // kFault: the fault to latch
  std::string detail;               // kFault: the sentence of the latch
};

class ArmTask {
 public:
  struct Settings {
    double task_timeout_s = 0;  // safety.arm_task_timeout_s
    double stop_timeout_s = 0;  // safety.arm_stop_timeout_s
  };

  // Tells the loop the arm may be at the door (unknown until the arm reports idle).
  ArmTask(std::unique_ptr<drivers::ManagedManipulator> arm, ControlLoop& loop, Settings settings);

  // Lifecycle policy (waits allowed), before the control thread runs / after it stopped.
  Outcome bring_up();  // configure + activate; an arm that configured but did not activate is
                       // cleaned up again
  void bring_down() noexcept;

  const drivers::ManagedManipulator& driver() const { return *arm_; }
  drivers::LifecycleState state() const noexcept { return arm_->state(); }
  drivers::ArmStatus status() const { return arm_->status(); }

  // Engage: hands `task` to the arm; from now on the arm is at the door until it reports idle after
  // this task, and the task must end (done) before safety.arm_task_timeout_s. The loop is told
  // the arm moves (its deadman watches it). The driver's refusal is returned as is.
  Result<std::uint32_t> hand_off(const drivers::DoorTask& task, std::int64_t now_ns);

  bool task_open() const noexcept { return task_open_; }  // an announced task not yet ended
  std::uint32_t task_id() const noexcept { return task_id_; }
  bool at_door() const noexcept { return at_door_; }
  bool stop_pending() const noexcept { return stop_pending_; }

  // Closes the open task (the loop no longer watches the arm move). False: none was open, so
  // there is nothing for the engine to announce.
  bool end_task();

  // Reads the arm's report. An idle report from an active arm, with no task open, means the arm
  // is clear of the door: it clears at_door() and confirms a pending stop. The loop is told
  // whether the arm may be at the door. Returns the report.
  drivers::ArmStatus observe();

  // Ok while the arm has reported idle since its last task and still does; else DRIVE_NOT_ALLOWED
  // (field `arm`) naming the arm's state. Every command that turns the wheels asks it.
  Outcome check_clear();

  // Tells the arm to stop. While the arm may be at the door (and `fault_latched` is false) the
  // stop must be confirmed by an idle report within safety.arm_stop_timeout_s, else
  // supervise() answers ARM_NOT_CLEAR.
  void stop(std::int64_t now_ns, bool fault_latched);

  // Tells the arm to stop, arming no confirmation (a fault latches right after).
  void send_stop() { (void)arm_->stop(); }

  // Reset with a fault latched: recovers the driver (fault -> inactive -> active) and the arm's
  // own fault.
  Outcome recover();

  // A pending stop's deadline (ARM_NOT_CLEAR), then the open task: done, fault, disconnect, a
  // controller that dropped the task, or its deadline (the arm is told to stop).
  ArmVerdict supervise_stop(std::int64_t now_ns);
  ArmVerdict supervise_task(std::int64_t now_ns);

  // The arm's state in words ("busy", "disconnected (ARM_TIMEOUT)", ...).
  std::string describe(const drivers::ArmStatus& st) const;

 private:
  bool reports_idle(const drivers::ArmStatus& st) const {
    return st.phase == drivers::ArmPhase::kIdle &&
           arm_->state() == drivers::LifecycleState::kActive;
  }

  std::unique_ptr<drivers::ManagedManipulator> arm_;
  ControlLoop& loop_;
  Settings settings_;
  std::uint32_t task_id_ = 0;
  bool task_open_ = false;  // an announced task not yet ended
  bool seen_busy_ = false;
  std::int64_t task_deadline_ns_ = 0;
  bool at_door_ = true;        // a task since the arm last reported idle (unknown at start)
  bool stop_pending_ = false;  // a stop sent while at_door_, not yet confirmed
  std::int64_t stop_deadline_ns_ = 0;
};

}  // namespace ajar::daemon::detail
