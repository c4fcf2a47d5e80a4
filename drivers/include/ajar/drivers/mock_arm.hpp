// MockManipulator: an in-process arm for daemon tests, with the fault menu of settings.hpp.
// Thread-safe; never blocks (except connect() under kSlow). No thread of its own: the phase is
// derived from the time the task was handed off, on its clock (mock_clock.hpp: the steady clock
// unless one is injected; an injected clock must be safe to call from any thread).
//
//   kNone         a task is busy for kTaskDurationMs, then done.
//   kStuck        a task stays busy forever (until stop()).
//   kSlow         a task is busy for slow_ms * 4; connect() takes slow_ms.
//   kErrorCode    the arm refuses every task: kFault with kArmRejected.
//   kIntermittent every second task (the 2nd, 4th, ...) ends in kFault with kArmTimeout.
//   kGarbage      the line is garbled: every task ends in kFault with kArmTimeout after slow_ms,
//                 as the serial driver reports it when every reply is corrupt.
// stop() ends a task (kIdle); clear_fault() turns kFault into kIdle.
// Tests can also script a refusal (fail_next_call), set what the arm reports (set_phase: with
// kStuck the test decides when and how a task ends), read the calls made in order (calls(),
// count()) and the tasks handed off (tasks()).
#pragma once

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/drivers/manipulator.hpp"
#include "ajar/drivers/mock_clock.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

class MockManipulator final : public Manipulator {
 public:
  static constexpr int kTaskDurationMs = 20;

  explicit MockManipulator(MockFault fault = MockFault::kNone, int slow_ms = 50,
                           MockClock clock = {});

  Outcome connect() override;
  Outcome disconnect() override;
  Result<std::uint32_t> hand_off(const DoorTask& task) override;
  Outcome stop() override;
  Outcome clear_fault() override;
  ArmStatus status() const override;

  // Test controls and observations.
  void set_fault(MockFault fault);
  std::uint64_t tasks_started() const;
  std::uint64_t stops() const;
  // The next call (connect, disconnect, hand_off, stop or clear_fault) returns `error` and does
  // nothing else.
  void fail_next_call(Error error);
  // What the arm reports from now on, as if its own controller changed it: a task done, a fault
  // (with `last_error`), the link lost, a reset mid-task (busy -> idle). The connection itself
  // stays as it is (calls behave as before); a busy phase set here never ends by time.
  void set_phase(ArmPhase phase, ErrorCode last_error = ErrorCode::kOk);
  // Every call so far, by name ("connect", "hand_off", ...), in order; how many were `call`; and
  // the tasks handed off.
  std::vector<std::string> calls() const;
  std::size_t count(std::string_view call) const;
  std::vector<DoorTask> tasks() const;

 private:
  void settle_locked(std::int64_t now_ns) const;  // advances busy -> done/fault by time
  // Logs the call; the scripted refusal if there is one.
  std::optional<Error> enter_locked(const char* call);

  mutable std::mutex mutex_;
  MockFault fault_;
  int slow_ms_;
  MockClock clock_;
  bool connected_ = false;
  mutable ArmStatus status_;
  std::int64_t busy_until_ns_ = 0;
  ErrorCode task_outcome_ = ErrorCode::kOk;  // kOk = done, else fault with this code
  bool task_never_ends_ = false;
  std::uint32_t next_task_id_ = 1;
  std::uint64_t tasks_started_ = 0;
  std::uint64_t stops_ = 0;
  std::optional<Error> next_error_;
  std::vector<std::string> calls_;
  std::vector<DoorTask> tasks_;
};

}  // namespace ajar::drivers
