// ArmControllerSimulator: an arm controller speaking docs/manipulator-serial.md on a
// pseudo-terminal, for the `sim` driver set and for the serial driver's tests. It opens a pty pair
// (openpty, raw mode via cfmakeraw on the slave), serves the master on its own thread, and keeps a
// slave fd open itself so the master never sees a hang-up while the driver reconnects.
//
// device_path() is a STABLE symlink in a private temp directory (mkdtemp) pointing at the current
// slave (/dev/pts/N). unplug() closes the pair and removes the link (the driver sees a hang-up /
// EIO, then ENOENT); replug() opens a new pair, whose slave has a different /dev/pts number, and
// re-points the link, so the driver's reconnect by path works.
//
// A task runs for task_duration_ms, then the controller sends DONE (unsolicited) and reports DONE.
// STOP ends a task, running or done (-> IDLE: the arm at rest, clear of the door).
// A repeated sequence number is answered with the previous reply and not acted upon.
//
// The controller's own faults (settings.fault for every task, or the calls below at any instant):
// it stops answering mid-task or at the first STOP of a task (a silent controller reads nothing,
// answers nothing and its task neither ends nor stops; for settings.silent_ms, 0 = until
// answer_again()), it resets mid-task (IDLE, task id 0, the last sequence number forgotten), or it
// answers STOP but stays BUSY (and its task no longer ends).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "ajar/drivers/arm_protocol.hpp"
#include "ajar/drivers/manipulator.hpp"

namespace ajar::drivers {

enum class ArmSimFault : std::uint8_t {
  kNone,
  kSilentMidTask,  // half way through every task the controller stops answering
  kSilentMidStop,  // the first STOP of every task is not answered: the controller falls silent
  kResetMidTask,   // half way through every task the controller resets (IDLE, task forgotten)
  kStopIgnored,    // STOP is answered, but a busy arm stays BUSY (and its task never ends)
};

struct ArmSimulatorSettings {
  int task_duration_ms = 200;  // time from accepting a task to DONE
  int reply_delay_ms = 0;      // delay before every reply (slow controller)
  ArmSimFault fault = ArmSimFault::kNone;
  int silent_ms = 0;  // how long a silence lasts (0: until answer_again())
};

class ArmControllerSimulator {
 public:
  // Opens the pty pair and the symlink and starts the thread. Throws std::runtime_error naming the
  // failing call (openpty, mkdtemp, symlink).
  explicit ArmControllerSimulator(ArmSimulatorSettings settings = {});
  ~ArmControllerSimulator();  // stops the thread, closes the pty, removes the link and directory
  ArmControllerSimulator(const ArmControllerSimulator&) = delete;
  ArmControllerSimulator& operator=(const ArmControllerSimulator&) = delete;

  // The stable path the driver opens (symlink to the current pty slave).
  std::string device_path() const;

  // --- fault injection (thread-safe) ---
  // The next `count` replies, or only the next `count` replies to requests of command `only_for`
  // (a replay for a repeated TASK counts as a reply to TASK), are:
  void corrupt_next_replies(int count, std::optional<arm::Command> only_for = std::nullopt);
  //   sent with a wrong CRC (the driver drops them and retries);
  void drop_next_replies(int count, std::optional<arm::Command> only_for = std::nullopt);
  //   not sent at all, the request having been acted upon (the driver times out and retries);
  void garble_next_replies(int count, std::optional<arm::Command> only_for = std::nullopt);
  //   preceded by garbage bytes (noise, a '$' fragment, a line with a bad CRC).
  void set_reply_delay_ms(int ms);  // slow replies
  void set_task_duration_ms(int ms);
  void set_refuse_tasks(bool refuse);  // TASK answered NAK REFUSED
  void fail_current_task();            // a running task ends in FAULT (no DONE)
  void send_raw(std::string bytes);    // writes bytes to the line as they are
  void set_fault(ArmSimFault fault);   // settings.fault from the next task on
  void go_silent();                    // stops answering now (for settings.silent_ms)
  void answer_again();                 // answers again (a task frozen by the silence goes on)
  void silence_next_stop();            // the next STOP during a task is not answered: silent
  void reset_controller();             // IDLE, task id 0, sequence forgotten, replies dropped
  void set_ignore_stops(bool ignore);  // STOP answered, a busy arm stays BUSY
  void unplug();                       // device gone: pty pair closed, link removed
  void replug();                       // device back: new pty pair, link re-pointed

  // --- observations ---
  struct Counters {
    std::uint64_t requests = 0;            // valid requests received, duplicates included
    std::uint64_t duplicates_ignored = 0;  // repeated seq answered by replay
    std::uint64_t tasks_executed = 0;      // TASK requests acted upon (started)
    std::uint64_t tasks_completed = 0;     // tasks that reached DONE
    std::uint64_t stops = 0;               // STOP requests acted upon
    std::uint64_t bad_requests = 0;        // lines dropped (bad CRC, malformed)
    std::uint64_t unanswered = 0;          // valid requests a silent controller ignored
  };
  Counters counters() const;
  arm::ControllerPhase phase() const;
  std::optional<DoorTask> last_task() const;  // the last task acted upon
  std::uint32_t last_task_id() const;
  bool plugged() const;
  bool silent() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ajar::drivers
