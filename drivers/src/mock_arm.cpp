#include "ajar/drivers/mock_arm.hpp"

#include <algorithm>
#include <chrono>
#include <thread>
#include <utility>

namespace ajar::drivers {

MockManipulator::MockManipulator(MockFault fault, int slow_ms, MockClock clock)
    : fault_(fault),
      slow_ms_(slow_ms < 0 ? 0 : slow_ms),
      clock_(or_steady_clock(std::move(clock))) {}

std::optional<Error> MockManipulator::enter_locked(const char* call) {
  calls_.emplace_back(call);
  std::optional<Error> error;
  error.swap(next_error_);
  return error;
}

Outcome MockManipulator::connect() {
  MockFault fault;
  int slow_ms;
  {
    std::lock_guard lock(mutex_);
    if (auto e = enter_locked("connect")) return std::move(*e);
    fault = fault_;
    slow_ms = slow_ms_;
  }
  if (fault == MockFault::kSlow) std::this_thread::sleep_for(std::chrono::milliseconds(slow_ms));
  std::lock_guard lock(mutex_);
  connected_ = true;
  if (status_.phase == ArmPhase::kDisconnected) {
    status_.phase = ArmPhase::kIdle;
    status_.last_error = ErrorCode::kOk;
  }
  return Ok{};
}

Outcome MockManipulator::disconnect() {
  std::lock_guard lock(mutex_);
  if (auto e = enter_locked("disconnect")) return std::move(*e);
  connected_ = false;
  status_.phase = ArmPhase::kDisconnected;
  status_.last_error = ErrorCode::kOk;
  return Ok{};
}

void MockManipulator::settle_locked(std::int64_t now_ns) const {
  if (status_.phase != ArmPhase::kBusy || task_never_ends_ || now_ns < busy_until_ns_) return;
  if (task_outcome_ == ErrorCode::kOk) {
    status_.phase = ArmPhase::kDone;
  } else {
    status_.phase = ArmPhase::kFault;
    status_.last_error = task_outcome_;
  }
}

Result<std::uint32_t> MockManipulator::hand_off(const DoorTask& task) {
  std::lock_guard lock(mutex_);
  if (auto e = enter_locked("hand_off")) return std::move(*e);
  const std::int64_t now = clock_();
  settle_locked(now);
  if (!connected_) return make_error(ErrorCode::kArmDisconnected, "", "mock arm: not connected");
  if (status_.phase == ArmPhase::kBusy || status_.phase == ArmPhase::kFault) {
    return make_error(ErrorCode::kWrongState, "",
                      status_.phase == ArmPhase::kBusy ? "mock arm: a task is busy"
                                                       : "mock arm: faulted, clear_fault first");
  }
  const std::uint32_t id = next_task_id_++;
  ++tasks_started_;
  tasks_.push_back(task);
  status_.task_id = id;
  status_.phase = ArmPhase::kBusy;
  status_.last_error = ErrorCode::kOk;
  task_never_ends_ = false;
  task_outcome_ = ErrorCode::kOk;
  int duration_ms = kTaskDurationMs;
  switch (fault_) {
    case MockFault::kNone:
      break;
    case MockFault::kStuck:
      task_never_ends_ = true;
      break;
    case MockFault::kSlow:
      duration_ms = slow_ms_ * 4;
      break;
    case MockFault::kErrorCode:
      duration_ms = 0;
      task_outcome_ = ErrorCode::kArmRejected;
      break;
    case MockFault::kIntermittent:
      if (tasks_started_ % 2 == 0) task_outcome_ = ErrorCode::kArmTimeout;
      break;
    case MockFault::kGarbage:
      duration_ms = slow_ms_;
      task_outcome_ = ErrorCode::kArmTimeout;
      break;
  }
  busy_until_ns_ = now + std::int64_t{duration_ms} * 1'000'000;
  settle_locked(now);
  return id;
}

Outcome MockManipulator::stop() {
  std::lock_guard lock(mutex_);
  if (auto e = enter_locked("stop")) return std::move(*e);
  ++stops_;
  settle_locked(clock_());
  if (status_.phase == ArmPhase::kBusy) status_.phase = ArmPhase::kIdle;
  task_never_ends_ = false;
  if (!connected_) return make_error(ErrorCode::kArmDisconnected, "", "mock arm: not connected");
  return Ok{};
}

Outcome MockManipulator::clear_fault() {
  std::lock_guard lock(mutex_);
  if (auto e = enter_locked("clear_fault")) return std::move(*e);
  settle_locked(clock_());
  if (!connected_) return make_error(ErrorCode::kArmDisconnected, "", "mock arm: not connected");
  if (status_.phase == ArmPhase::kFault) {
    status_.phase = ArmPhase::kIdle;
    status_.last_error = ErrorCode::kOk;
  }
  return Ok{};
}

ArmStatus MockManipulator::status() const {
  std::lock_guard lock(mutex_);
  settle_locked(clock_());
  return status_;
}

void MockManipulator::set_fault(MockFault fault) {
  std::lock_guard lock(mutex_);
  fault_ = fault;
}

std::uint64_t MockManipulator::tasks_started() const {
  std::lock_guard lock(mutex_);
  return tasks_started_;
}

std::uint64_t MockManipulator::stops() const {
  std::lock_guard lock(mutex_);
  return stops_;
}

void MockManipulator::fail_next_call(Error error) {
  std::lock_guard lock(mutex_);
  next_error_ = std::move(error);
}

void MockManipulator::set_phase(ArmPhase phase, ErrorCode last_error) {
  std::lock_guard lock(mutex_);
  settle_locked(clock_());
  status_.phase = phase;
  status_.last_error = last_error;
  if (phase == ArmPhase::kBusy) task_never_ends_ = true;
}

std::size_t MockManipulator::count(std::string_view call) const {
  std::lock_guard lock(mutex_);
  return static_cast<std::size_t>(std::count(calls_.begin(), calls_.end(), call));
}

std::vector<std::string> MockManipulator::calls() const {
  std::lock_guard lock(mutex_);
  return calls_;
}

std::vector<DoorTask> MockManipulator::tasks() const {
  std::lock_guard lock(mutex_);
  return tasks_;
}

}  // namespace ajar::drivers
