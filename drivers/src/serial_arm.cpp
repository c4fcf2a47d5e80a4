#include "ajar/drivers/serial_arm.hpp"

#include <pthread.h>

#include <cmath>
#include <string>

#include "serial_arm_impl.hpp"
#include "serial_arm_port.hpp"

namespace ajar::drivers {

SerialManipulator::SerialManipulator(SerialArmSettings settings)
    : impl_(std::make_unique<Impl>(std::move(settings))) {}

SerialManipulator::~SerialManipulator() {
  (void)disconnect();
}

Outcome SerialManipulator::connect() {
  {
    std::lock_guard lock(impl_->mutex);
    if (impl_->running) return Ok{};
    impl_->quit = false;
  }
  if (impl_->wake_fd < 0) {
    return make_error(ErrorCode::kDriverError, "", "serial arm: eventfd failed");
  }
  auto opened = open_arm_port(impl_->settings);
  if (!opened) return std::move(opened).error();
  impl_->fd = opened.value();
  arm::Message reply;
  const RequestEnd end = impl_->transact(Job{JobKind::kStatus, 0, {}}, reply);
  if (end != RequestEnd::kReply) {
    impl_->close_fd();
    const bool lost = end == RequestEnd::kLinkLost;
    return make_error(lost ? ErrorCode::kArmDisconnected : ErrorCode::kArmTimeout, "device",
                      "serial arm " + impl_->settings.device +
                          (lost ? ": link lost while connecting"
                                : ": the arm controller did not answer the status query"));
  }
  {
    std::lock_guard lock(impl_->mutex);
    impl_->running = true;
    impl_->snapshot.phase = ArmPhase::kIdle;
    impl_->snapshot.last_error = ErrorCode::kOk;
    impl_->apply_controller_locked(reply.phase, reply.task_id);
  }
  impl_->worker = std::thread([impl = impl_.get()] {
    pthread_setname_np(pthread_self(), "ajar-arm-serial");
    impl->run();
  });
  return Ok{};
}

Outcome SerialManipulator::disconnect() {
  {
    std::lock_guard lock(impl_->mutex);
    if (!impl_->running) return Ok{};
    impl_->quit = true;
  }
  impl_->wake();
  impl_->worker.join();
  impl_->close_fd();
  std::lock_guard lock(impl_->mutex);
  impl_->running = false;
  impl_->stop_pending = false;
  impl_->clear_pending = false;
  impl_->task_pending.reset();
  impl_->snapshot.phase = ArmPhase::kDisconnected;
  impl_->snapshot.last_error = ErrorCode::kOk;
  return Ok{};
}

Result<std::uint32_t> SerialManipulator::hand_off(const DoorTask& task) {
  if (!task.contact_base_m.allFinite() || !std::isfinite(task.door_width_m) ||
      !std::isfinite(task.handle_length_m)) {
    return make_error(ErrorCode::kNonFinite, "task", "serial arm: non-finite task field");
  }
  std::lock_guard lock(impl_->mutex);
  auto& s = impl_->snapshot;
  if (!impl_->running || s.phase == ArmPhase::kDisconnected) {
    return make_error(ErrorCode::kArmDisconnected, "",
                      "serial arm " + impl_->settings.device + ": not connected");
  }
  if (impl_->task_pending || s.phase == ArmPhase::kBusy) {
    return make_error(ErrorCode::kWrongState, "", "serial arm: a task is busy");
  }
  if (s.phase == ArmPhase::kFault) {
    return make_error(ErrorCode::kWrongState, "", "serial arm: faulted; clear_fault first");
  }
  const std::uint32_t id = impl_->next_task_id++;
  impl_->task_pending = Job{JobKind::kTask, id, task};
  s.phase = ArmPhase::kBusy;
  s.task_id = id;
  s.last_error = ErrorCode::kOk;
  impl_->wake();
  return id;
}

Outcome SerialManipulator::stop() {
  std::lock_guard lock(impl_->mutex);
  const auto& s = impl_->snapshot;
  // A task never sent is cancelled here; the phase stays what it shows until the controller's
  // reply to the STOP below says idle (the daemon moves the base only on that word).
  impl_->task_pending.reset();
  if (!impl_->running) {
    return make_error(ErrorCode::kArmDisconnected, "", "serial arm: not connected");
  }
  impl_->stop_pending = true;
  impl_->wake();
  if (s.phase == ArmPhase::kDisconnected) {
    return make_error(
        ErrorCode::kArmDisconnected, "",
        "serial arm " + impl_->settings.device + ": link down; the stop is sent when it returns");
  }
  return Ok{};
}

Outcome SerialManipulator::clear_fault() {
  std::lock_guard lock(impl_->mutex);
  if (!impl_->running || impl_->snapshot.phase == ArmPhase::kDisconnected) {
    return make_error(ErrorCode::kArmDisconnected, "",
                      "serial arm " + impl_->settings.device + ": not connected");
  }
  if (impl_->snapshot.phase != ArmPhase::kFault) return Ok{};  // nothing to clear
  impl_->clear_pending = true;
  impl_->wake();
  return Ok{};
}

ArmStatus SerialManipulator::status() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->snapshot;
}

SerialManipulator::Counters SerialManipulator::counters() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->counters;
}

}  // namespace ajar::drivers
