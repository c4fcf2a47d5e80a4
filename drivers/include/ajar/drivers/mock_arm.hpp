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
// The arm controller's own faults (MockArmFault only; a task never ends by itself under them):
//   kSilentMidTask   half way through kTaskDurationMs the controller stops answering (go_silent).
//   kSilentMidStop   the first stop() of a task goes unanswered and the controller falls silent
//                    (silence_next_stop).
//   kResetMidTask    half way through kTaskDurationMs the controller resets (reset_controller).
//   kStopIgnored     stop() is answered but the arm stays busy (ignore_stops).
// stop() ends a task or a done task (kIdle: the arm at rest, clear of the door); clear_fault()
// turns kFault into kIdle.
//
// A silent controller acts on nothing: its task neither ends nor stops, stop() is accepted (Ok,
// as the serial driver queues it) and owed, hand_off() and clear_fault() are refused with
// kArmDisconnected. It reports its last phase for slow_ms (the driver's retries), then
// kDisconnected with kArmTimeout, as the serial driver shows a controller that stopped answering.
// answer_again() (or set_fault(kNone)) ends the silence: the owed stop acts, then it reports.
// Tests can also script a refusal (fail_next_call), set what the arm reports (set_phase: with
// kStuck the test decides when and how a task ends), inject the controller's faults at any instant
// (go_silent, silence_next_stop, reset_controller, ignore_stops), read the calls made in order
// (calls(), count()) and the tasks handed off (tasks()).
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

  explicit MockManipulator(MockArmFault fault = MockArmFault::kNone, int slow_ms = 50,
                           MockClock clock = {});
  // The card's menu word for word (MockFault's values are MockArmFault's first six).
  explicit MockManipulator(MockFault fault, int slow_ms = 50, MockClock clock = {});

  Outcome connect() override;
  Outcome disconnect() override;
  Result<std::uint32_t> hand_off(const DoorTask& task) override;
  Outcome stop() override;
  Outcome clear_fault() override;
  ArmStatus status() const override;

  // Test controls and observations.
  void set_fault(MockFault fault);
  // kNone also ends a silence (answer_again).
  void set_fault(MockArmFault fault);
  std::uint64_t tasks_started() const;
  std::uint64_t stops() const;
  // The next call (connect, disconnect, hand_off, stop or clear_fault) returns `error` and does
  // nothing else.
  void fail_next_call(Error error);
  // What the arm reports from now on, as if its own controller changed it: a task done, a fault
  // (with `last_error`), the link lost, a reset mid-task (busy -> idle). The connection itself
  // stays as it is (calls behave as before); a busy phase set here never ends by time.
  void set_phase(ArmPhase phase, ErrorCode last_error = ErrorCode::kOk);
  // The arm controller's faults, now: it stops answering (its phase freezes; after slow_ms it
  // shows kDisconnected with kArmTimeout); it answers again (an owed stop acts first); the next
  // stop() during a task goes unanswered and silences it; it resets (kIdle, task id 0, the task
  // forgotten); it answers stops but stays busy (while `ignore`; its task no longer ends).
  void go_silent();
  void answer_again();
  void silence_next_stop();
  void reset_controller();
  void ignore_stops(bool ignore);
  bool silent() const;
  // Every call so far, by name ("connect", "hand_off", ...), in order; how many were `call`; and
  // the tasks handed off.
  std::vector<std::string> calls() const;
  std::size_t count(std::string_view call) const;
  std::vector<DoorTask> tasks() const;

 private:
  void settle_locked(std::int64_t now_ns) const;  // advances busy -> done/fault by time
  void apply_stop_locked();                       // the controller acts on a stop
  void answer_again_locked();
  // Logs the call; the scripted refusal if there is one.
  std::optional<Error> enter_locked(const char* call);

  mutable std::mutex mutex_;
  MockArmFault fault_;
  int slow_ms_;
  MockClock clock_;
  bool connected_ = false;
  mutable ArmStatus status_;
  std::int64_t busy_until_ns_ = 0;
  ErrorCode task_outcome_ = ErrorCode::kOk;  // kOk = done, else fault with this code
  mutable bool task_never_ends_ = false;
  // The controller's faults (see go_silent ...).
  mutable bool silent_ = false;
  mutable std::int64_t silent_since_ns_ = 0;
  bool stop_owed_ = false;  // a stop() while silent: acts when it answers again
  bool silence_next_stop_ = false;
  bool ignore_stops_ = false;
  mutable std::int64_t midway_ns_ = 0;  // silent / reset mid-task: when (0: not scheduled)
  std::uint32_t next_task_id_ = 1;
  std::uint64_t tasks_started_ = 0;
  std::uint64_t stops_ = 0;
  std::optional<Error> next_error_;
  std::vector<std::string> calls_;
  std::vector<DoorTask> tasks_;
};

}  // namespace ajar::drivers
