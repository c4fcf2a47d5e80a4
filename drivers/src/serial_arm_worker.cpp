// The worker thread of SerialManipulator (serial_arm_impl.hpp): one job at a time (stop first,
// then clear, then the task, else the status poll every kStatusPollMs; only the poll while the link
// is down), what each ending means for the snapshot, and reopening the device with exponential
// backoff (reconnect_min_ms doubling to reconnect_max_ms).
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <random>

#include "serial_arm_impl.hpp"
#include "serial_arm_port.hpp"

namespace ajar::drivers {

using std::chrono::milliseconds;

SerialManipulator::Impl::Impl(SerialArmSettings s) : settings(std::move(s)) {
  std::random_device rd;
  next_seq = static_cast<std::uint16_t>(rd() % 65535U + 1U);
  wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
}

SerialManipulator::Impl::~Impl() {
  if (wake_fd >= 0) ::close(wake_fd);
}

void SerialManipulator::Impl::wake() const {
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(wake_fd, &one, sizeof one);
}

void SerialManipulator::Impl::drain_wake() const {
  std::uint64_t count = 0;
  [[maybe_unused]] const auto n = ::read(wake_fd, &count, sizeof count);
}

void SerialManipulator::Impl::close_fd() {
  if (fd >= 0) ::close(fd);
  fd = -1;
  reader.clear();
}

void SerialManipulator::Impl::apply_controller_locked(arm::ControllerPhase phase,
                                                      std::uint32_t task_id) {
  if (task_pending) return;  // a newer task is queued: keep showing it (busy, its id)
  if (task_id != 0) snapshot.task_id = task_id;
  if (latched != ErrorCode::kOk) {
    snapshot.phase = ArmPhase::kFault;
    snapshot.last_error = latched;
    return;
  }
  switch (phase) {
    case arm::ControllerPhase::kIdle:
      snapshot.phase = ArmPhase::kIdle;
      snapshot.last_error = ErrorCode::kOk;
      break;
    case arm::ControllerPhase::kBusy:
      snapshot.phase = ArmPhase::kBusy;
      snapshot.last_error = ErrorCode::kOk;
      break;
    case arm::ControllerPhase::kDone:
      snapshot.phase = ArmPhase::kDone;
      snapshot.last_error = ErrorCode::kOk;
      break;
    case arm::ControllerPhase::kFault:
      snapshot.phase = ArmPhase::kFault;
      snapshot.last_error = ErrorCode::kArmFault;
      break;
  }
}

void SerialManipulator::Impl::link_lost_locked(ErrorCode why) {
  snapshot.phase = ArmPhase::kDisconnected;
  snapshot.last_error = why;
}

void SerialManipulator::Impl::link_back_locked(arm::ControllerPhase phase, std::uint32_t task_id) {
  if (snapshot.phase == ArmPhase::kDisconnected || link_silent) {
    ++snapshot.reconnects;
    link_silent = false;
  }
  if (unconfirmed_task != 0) {
    if (task_id != unconfirmed_task) latched = ErrorCode::kArmDisconnected;
    unconfirmed_task = 0;
  }
  if (snapshot.phase == ArmPhase::kDisconnected) {
    snapshot.phase = task_pending ? ArmPhase::kBusy : ArmPhase::kIdle;
    snapshot.last_error = ErrorCode::kOk;
  }
  apply_controller_locked(phase, task_id);
}

void SerialManipulator::Impl::on_link_lost() {
  close_fd();
  std::lock_guard lock(mutex);
  link_lost_locked(ErrorCode::kArmDisconnected);
}

void SerialManipulator::Impl::run_job(const Job& job) {
  arm::Message reply;
  const RequestEnd end = transact(job, reply);
  if (end == RequestEnd::kLinkLost) {
    if (job.kind == JobKind::kTask) {
      std::lock_guard lock(mutex);
      unconfirmed_task = job.task_id;
    }
    if (job.kind == JobKind::kStop) {
      std::lock_guard lock(mutex);
      stop_pending = true;  // send it again on reconnect
    }
    on_link_lost();
    return;
  }
  std::lock_guard lock(mutex);
  switch (end) {
    case RequestEnd::kPreempted:
      return;  // a stop follows (or we are quitting); the stop's reply sets the phase
    case RequestEnd::kTimeout:
      if (job.kind == JobKind::kTask) {
        latched = ErrorCode::kArmTimeout;
        snapshot.phase = ArmPhase::kFault;
        snapshot.last_error = latched;
      } else {
        // The controller is silent: only the status poll runs until it answers again; an
        // unanswered stop goes out again then.
        link_silent = true;
        link_lost_locked(ErrorCode::kArmTimeout);
        if (job.kind == JobKind::kStop) stop_pending = true;
      }
      return;
    case RequestEnd::kReply:
    case RequestEnd::kLinkLost:
      break;
  }
  if (job.kind == JobKind::kClear && reply.command == arm::Command::kAck) {
    latched = ErrorCode::kOk;
  }
  if (job.kind == JobKind::kTask && reply.command == arm::Command::kNak) {
    latched = ErrorCode::kArmRejected;
  }
  link_back_locked(reply.phase, reply.task_id);
}

std::optional<Job> SerialManipulator::Impl::next_job(Clock::time_point& next_poll) {
  std::lock_guard lock(mutex);
  const bool link_up = snapshot.phase != ArmPhase::kDisconnected && !link_silent;
  if (!link_up) {
    // Only the status poll runs until the controller answers; it reconciles and brings the
    // link back, then queued work goes out.
    if (Clock::now() < next_poll) return std::nullopt;
    next_poll = Clock::now() + milliseconds(kStatusPollMs);
    return Job{JobKind::kStatus, 0, {}};
  }
  if (stop_pending) {
    stop_pending = false;
    return Job{JobKind::kStop, 0, {}};
  }
  if (clear_pending) {
    clear_pending = false;
    return Job{JobKind::kClear, 0, {}};
  }
  if (task_pending) {
    Job job = *task_pending;
    task_pending.reset();
    return job;
  }
  if (Clock::now() >= next_poll) {
    next_poll = Clock::now() + milliseconds(kStatusPollMs);
    return Job{JobKind::kStatus, 0, {}};
  }
  return std::nullopt;
}

void SerialManipulator::Impl::run() {
  int backoff_ms = std::max(settings.reconnect_min_ms, 1);
  auto next_poll = Clock::now() + milliseconds(kStatusPollMs);
  for (;;) {
    {
      std::lock_guard lock(mutex);
      if (quit) break;
    }
    if (fd < 0) {
      pollfd p{wake_fd, POLLIN, 0};
      ::poll(&p, 1, backoff_ms);
      drain_wake();
      {
        std::lock_guard lock(mutex);
        if (quit) break;
      }
      auto opened = open_arm_port(settings);
      if (!opened) {
        backoff_ms = std::min(backoff_ms * 2, std::max(settings.reconnect_max_ms, 1));
        continue;
      }
      fd = opened.value();
      backoff_ms = std::max(settings.reconnect_min_ms, 1);
      next_poll = Clock::now();  // the status report reconciles and marks the link back
      continue;
    }
    if (auto job = next_job(next_poll)) {
      run_job(*job);
      continue;
    }
    const auto left = std::chrono::ceil<milliseconds>(next_poll - Clock::now()).count();
    if (!pump(static_cast<int>(std::max<std::int64_t>(left, 0)))) {
      on_link_lost();
      continue;
    }
    take_lines(std::nullopt);
  }
}

}  // namespace ajar::drivers
