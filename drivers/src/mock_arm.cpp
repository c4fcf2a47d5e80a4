#include "ajar/drivers/mock_arm.hpp"

#include <algorithm>
#include <chrono>
#include <thread>
#include <utility>

namespace ajar::drivers {

namespace {

MockArmFault arm_fault(MockFault fault) {
  switch (fault) {
    case MockFault::kNone:
      return MockArmFault::kNone;
    case MockFault::kStuck:
      return MockArmFault::kStuck;
    case MockFault::kSlow:
      return MockArmFault::kSlow;
    case MockFault::kErrorCode:
      return MockArmFault::kErrorCode;
    case MockFault::kIntermittent:
      return MockArmFault::kIntermittent;
    case MockFault::kGarbage:
      return MockArmFault::kGarbage;
  }
  return MockArmFault::kNone;
}

}  // namespace

MockManipulator::MockManipulator(MockArmFault fault, int slow_ms, MockClock clock)
    : fault_(fault),
      slow_ms_(slow_ms < 0 ? 0 : slow_ms),
      clock_(or_steady_clock(std::move(clock))) {}

MockManipulator::MockManipulator(MockFault fault, int slow_ms, MockClock clock)
    : MockManipulator(arm_fault(fault), slow_ms, std::move(clock)) {}

std::optional<Error> MockManipulator::enter_locked(const char* call) {
  calls_.emplace_back(call);
  std::optional<Error> error;
  error.swap(next_error_);
  return error;
}

Outcome MockManipulator::connect() {
  MockArmFault fault;
  int slow_ms;
  {
    std::lock_guard lock(mutex_);
    if (auto e = enter_locked("connect")) return std::move(*e);
    fault = fault_;
    slow_ms = slow_ms_;
  }
  if (fault == MockArmFault::kSlow) std::this_thread::sleep_for(std::chrono::milliseconds(slow_ms));
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
  if (midway_ns_ != 0 && now_ns >= midway_ns_ && !silent_) {
    if (status_.phase == ArmPhase::kBusy && fault_ == MockArmFault::kSilentMidTask) {
      silent_ = true;
      silent_since_ns_ = midway_ns_;
    } else if (status_.phase == ArmPhase::kBusy && fault_ == MockArmFault::kResetMidTask) {
      status_.phase = ArmPhase::kIdle;  // came back idle, the task forgotten
      status_.task_id = 0;
      task_never_ends_ = false;
    }
    midway_ns_ = 0;
  }
  if (silent_) return;  // nothing the controller does is heard of
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
  if (silent_) {
    return make_error(ErrorCode::kArmDisconnected, "", "mock arm: the controller does not answer");
  }
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
  midway_ns_ = 0;
  int duration_ms = kTaskDurationMs;
  switch (fault_) {
    case MockArmFault::kNone:
      break;
    case MockArmFault::kStuck:
    case MockArmFault::kStopIgnored:
      task_never_ends_ = true;
      break;
    case MockArmFault::kSlow:
      duration_ms = slow_ms_ * 4;
      break;
    case MockArmFault::kErrorCode:
      duration_ms = 0;
      task_outcome_ = ErrorCode::kArmRejected;
      break;
    case MockArmFault::kIntermittent:
      if (tasks_started_ % 2 == 0) task_outcome_ = ErrorCode::kArmTimeout;
      break;
    case MockArmFault::kGarbage:
      duration_ms = slow_ms_;
      task_outcome_ = ErrorCode::kArmTimeout;
      break;
    case MockArmFault::kSilentMidTask:
    case MockArmFault::kResetMidTask:
      task_never_ends_ = true;
      midway_ns_ = now + std::int64_t{kTaskDurationMs} * 500'000;  // half way
      break;
    case MockArmFault::kSilentMidStop:
      task_never_ends_ = true;
      silence_next_stop_ = true;
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
  const std::int64_t now = clock_();
  settle_locked(now);
  if (silence_next_stop_ && status_.phase == ArmPhase::kBusy && !silent_) {
    silence_next_stop_ = false;
    silent_ = true;  // this stop is the first thing it does not answer
    silent_since_ns_ = now;
  }
  if (silent_) {
    stop_owed_ = true;  // queued, as the serial driver keeps it for when the controller answers
  } else {
    apply_stop_locked();
  }
  if (!connected_) return make_error(ErrorCode::kArmDisconnected, "", "mock arm: not connected");
  return Ok{};
}

void MockManipulator::apply_stop_locked() {
  if (status_.phase == ArmPhase::kBusy && (ignore_stops_ || fault_ == MockArmFault::kStopIgnored)) {
    task_never_ends_ = true;  // answered, and it goes on working
    return;
  }
  if (status_.phase == ArmPhase::kBusy || status_.phase == ArmPhase::kDone) {
    status_.phase = ArmPhase::kIdle;
  }
  task_never_ends_ = false;
  midway_ns_ = 0;
}

void MockManipulator::answer_again_locked() {
  if (!silent_) return;
  silent_ = false;
  if (stop_owed_) {
    stop_owed_ = false;
    apply_stop_locked();
  }
}

Outcome MockManipulator::clear_fault() {
  std::lock_guard lock(mutex_);
  if (auto e = enter_locked("clear_fault")) return std::move(*e);
  settle_locked(clock_());
  if (!connected_) return make_error(ErrorCode::kArmDisconnected, "", "mock arm: not connected");
  if (silent_) {
    return make_error(ErrorCode::kArmDisconnected, "", "mock arm: the controller does not answer");
  }
  if (status_.phase == ArmPhase::kFault) {
    status_.phase = ArmPhase::kIdle;
    status_.last_error = ErrorCode::kOk;
  }
  return Ok{};
}

ArmStatus MockManipulator::status() const {
  std::lock_guard lock(mutex_);
  const std::int64_t now = clock_();
  settle_locked(now);
  ArmStatus reported = status_;
  if (silent_ && now - silent_since_ns_ >= std::int64_t{slow_ms_} * 1'000'000) {
    reported.phase = ArmPhase::kDisconnected;  // the driver's retries ran out
    reported.last_error = ErrorCode::kArmTimeout;
  }
  return reported;
}

void MockManipulator::set_fault(MockFault fault) {
  set_fault(arm_fault(fault));
}

void MockManipulator::set_fault(MockArmFault fault) {
  std::lock_guard lock(mutex_);
  settle_locked(clock_());
  fault_ = fault;
  if (fault == MockArmFault::kNone) {
    silence_next_stop_ = false;
    ignore_stops_ = false;
    answer_again_locked();
  }
}

void MockManipulator::go_silent() {
  std::lock_guard lock(mutex_);
  const std::int64_t now = clock_();
  settle_locked(now);
  if (silent_) return;
  silent_ = true;
  silent_since_ns_ = now;
}

void MockManipulator::answer_again() {
  std::lock_guard lock(mutex_);
  settle_locked(clock_());
  answer_again_locked();
}

void MockManipulator::silence_next_stop() {
  std::lock_guard lock(mutex_);
  silence_next_stop_ = true;
}

void MockManipulator::reset_controller() {
  std::lock_guard lock(mutex_);
  settle_locked(clock_());
  silent_ = false;
  stop_owed_ = false;
  midway_ns_ = 0;
  task_never_ends_ = false;
  if (connected_) status_.phase = ArmPhase::kIdle;
  status_.last_error = ErrorCode::kOk;
  status_.task_id = 0;
}

void MockManipulator::ignore_stops(bool ignore) {
  std::lock_guard lock(mutex_);
  ignore_stops_ = ignore;
}

bool MockManipulator::silent() const {
  std::lock_guard lock(mutex_);
  settle_locked(clock_());
  return silent_;
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
