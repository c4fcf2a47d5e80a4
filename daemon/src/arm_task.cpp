// The arm's side of the engine (arm_task.hpp): its lifecycle, its task and the arm interlock.
#include "arm_task.hpp"

#include <utility>

#include "ajar/protocol/message_table.hpp"
#include "driver_wire.hpp"

namespace ajar::daemon::detail {

namespace {
std::int64_t after(std::int64_t now_ns, double seconds) {
  return now_ns + static_cast<std::int64_t>(seconds * 1e9);
}
}  // namespace

ArmTask::ArmTask(std::unique_ptr<drivers::ManagedManipulator> arm, ControlLoop& loop,
                 Settings settings)
    : arm_(std::move(arm)), loop_(loop), settings_(settings) {
  loop_.set_arm_at_door(true);  // the arm interlock: until the arm reports idle
}

Outcome ArmTask::bring_up() {
  if (auto s = arm_->configure(); !s) return s;
  if (auto s = arm_->activate(); !s) {
    (void)arm_->cleanup();
    return s;
  }
  return Ok{};
}

void ArmTask::bring_down() noexcept {
  if (arm_->state() == drivers::LifecycleState::kActive) (void)arm_->deactivate();
  if (arm_->state() == drivers::LifecycleState::kInactive) (void)arm_->cleanup();
}

Result<std::uint32_t> ArmTask::hand_off(const drivers::DoorTask& task, std::int64_t now_ns) {
  auto id = arm_->hand_off(task);
  if (!id) return id;
  task_id_ = *id;
  task_open_ = true;
  at_door_ = true;  // until it reports idle after this task
  loop_.set_arm_at_door(true);
  // A driver shows the task busy at once (the mock, the serial driver's snapshot): a controller
  // that drops it before the first poll is caught too.
  seen_busy_ = arm_->status().phase == drivers::ArmPhase::kBusy;
  task_deadline_ns_ = after(now_ns, settings_.task_timeout_s);
  loop_.set_arm_moving(true);
  return id;
}

bool ArmTask::end_task() {
  if (!task_open_) return false;
  task_open_ = false;
  loop_.set_arm_moving(false);
  return true;
}

drivers::ArmStatus ArmTask::observe() {
  const drivers::ArmStatus st = arm_->status();
  const bool idle = reports_idle(st);
  if (idle && !task_open_) {
    at_door_ = false;
    stop_pending_ = false;
  }
  loop_.set_arm_at_door(at_door_ || !idle);
  return st;
}

Outcome ArmTask::check_clear() {
  const drivers::ArmStatus st = observe();
  if (!at_door_ && reports_idle(st)) return Ok{};
  std::string what;
  switch (st.phase) {
    case drivers::ArmPhase::kBusy:
      what = stop_pending_ ? ": its stop is not confirmed yet, wait for it to report idle"
                           : ": wait for it to report idle, or Stop";
      break;
    case drivers::ArmPhase::kDone:
      what = ": its task is done but it has not withdrawn; Stop sends it back to rest";
      break;
    case drivers::ArmPhase::kIdle:  // the driver is not active
      what = ": Reset";
      break;
    case drivers::ArmPhase::kDisconnected:
    case drivers::ArmPhase::kFault:
      what = ": check the arm and its link; Reset once it reports idle";
      break;
  }
  return make_error(ErrorCode::kDriveNotAllowed, std::string(protocol::refusal_field::kArm),
                    "the arm has not reported that it is clear of the door since its last task "
                    "(arm " +
                        describe(st) + ")" + what + "; the base must not move");
}

void ArmTask::stop(std::int64_t now_ns, bool fault_latched) {
  (void)arm_->stop();  // a refusal (link down) is no confirmation either: the deadline decides
  const drivers::ArmStatus st = observe();
  if (at_door_ && !reports_idle(st) && !stop_pending_ && !fault_latched) {
    stop_pending_ = true;
    stop_deadline_ns_ = after(now_ns, settings_.stop_timeout_s);
  }
}

Outcome ArmTask::recover() {
  if (arm_->state() == drivers::LifecycleState::kFault) {
    if (auto s = arm_->recover(); !s) return s;
  }
  if (arm_->state() == drivers::LifecycleState::kInactive) {
    if (auto s = arm_->activate(); !s) return s;
  }
  if (arm_->status().phase == drivers::ArmPhase::kFault) {
    if (auto s = arm_->clear_fault(); !s) return s;
  }
  return Ok{};
}

ArmVerdict ArmTask::supervise_stop(std::int64_t now_ns) {
  const drivers::ArmStatus st = observe();
  if (!stop_pending_ || now_ns <= stop_deadline_ns_) return {};
  stop_pending_ = false;
  return {ArmVerdict::Kind::kFault, ErrorCode::kArmNotClear,
          "the arm did not confirm its stop (report idle) within safety.arm_stop_timeout_s (arm " +
              describe(st) + "): it may still be at the door"};
}

ArmVerdict ArmTask::supervise_task(std::int64_t now_ns) {
  if (!task_open_) return {};
  const drivers::ArmStatus st = arm_->status();
  if (st.phase == drivers::ArmPhase::kBusy && st.task_id == task_id_) seen_busy_ = true;
  if (st.phase == drivers::ArmPhase::kDone && st.task_id == task_id_) {
    return {ArmVerdict::Kind::kTaskDone, ErrorCode::kOk, {}};
  }
  if (st.phase == drivers::ArmPhase::kFault) {
    return {ArmVerdict::Kind::kFault,
            st.last_error == ErrorCode::kOk ? ErrorCode::kArmRejected : st.last_error,
            "the arm reported a fault"};
  }
  if (st.phase == drivers::ArmPhase::kDisconnected) {
    const bool silent = st.last_error == ErrorCode::kArmTimeout;
    return {ArmVerdict::Kind::kFault, silent ? ErrorCode::kArmTimeout : ErrorCode::kArmDisconnected,
            silent ? "the arm controller stopped answering" : "the arm is disconnected"};
  }
  if (arm_->state() == drivers::LifecycleState::kFault) {
    return {ArmVerdict::Kind::kFault, ErrorCode::kDriverError, "the arm driver failed"};
  }
  if (seen_busy_ && st.phase != drivers::ArmPhase::kBusy) {
    return {ArmVerdict::Kind::kFault, ErrorCode::kArmFault,
            "the arm controller dropped the task (reset mid-task?)"};
  }
  if (now_ns > task_deadline_ns_) {
    (void)arm_->stop();
    return {ArmVerdict::Kind::kFault, ErrorCode::kArmTimeout,
            "the arm task did not finish within safety.arm_task_timeout_s"};
  }
  return {};
}

std::string ArmTask::describe(const drivers::ArmStatus& st) const {
  std::string s(protocol::to_string(to_wire(st.phase)));
  if (st.last_error != ErrorCode::kOk) s += " (" + std::string(to_string(st.last_error)) + ")";
  if (arm_->state() != drivers::LifecycleState::kActive) {
    s += std::string(", driver ") + drivers::to_string(arm_->state());
  }
  return s;
}

}  // namespace ajar::daemon::detail
