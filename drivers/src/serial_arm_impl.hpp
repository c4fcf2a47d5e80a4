// SerialManipulator's state, shared by its three files (the contract is in serial_arm.hpp):
//   serial_arm.cpp         the Manipulator calls: queue work, read the snapshot, never block
//   serial_arm_worker.cpp  the worker thread: which job goes next, what its reply means for the
//                          snapshot, reopening the device with backoff
//   serial_arm_link.cpp    one request on the wire: write, wait, retries with the same sequence
//                          number, lines in (replies, DONE reports, garbage counted)
// and serial_arm_port.* opens the device.
#pragma once

#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "ajar/drivers/arm_protocol.hpp"
#include "ajar/drivers/serial_arm.hpp"

namespace ajar::drivers {

enum class JobKind : std::uint8_t { kTask, kStatus, kStop, kClear };

struct Job {
  JobKind kind = JobKind::kStatus;
  std::uint32_t task_id = 0;
  DoorTask task;
};

// How one request ended (transact).
enum class RequestEnd : std::uint8_t { kReply, kTimeout, kLinkLost, kPreempted };

struct SerialManipulator::Impl {
  using Clock = std::chrono::steady_clock;

  explicit Impl(SerialArmSettings s);  // a random first sequence number; the wake-up eventfd
  ~Impl();

  const SerialArmSettings settings;
  int wake_fd = -1;  // eventfd: wakes the worker when work is queued or on quit

  // Shared between the caller threads and the worker.
  mutable std::mutex mutex;
  ArmStatus snapshot;
  Counters counters;
  bool running = false;
  bool quit = false;
  bool stop_pending = false;
  bool clear_pending = false;
  std::optional<Job> task_pending;
  std::uint32_t next_task_id = 1;
  ErrorCode latched = ErrorCode::kOk;  // host-side fault (timeout, rejected, lost) until cleared
  std::uint32_t unconfirmed_task = 0;  // task sent but not acknowledged when the link was lost
  bool link_silent = false;            // the controller stopped answering the status poll

  // Worker-only (or the connecting thread before the worker starts).
  int fd = -1;
  arm::LineReader reader;
  std::uint16_t next_seq = 1;
  std::thread worker;

  // ---- serial_arm_worker.cpp ----
  void wake() const;  // from any thread
  void drain_wake() const;
  void close_fd();
  // Snapshot updates (mutex held).
  void apply_controller_locked(arm::ControllerPhase phase, std::uint32_t task_id);
  void link_lost_locked(ErrorCode why);
  // A reply or report arrived after a link loss or silence: count the reconnect, reconcile a task
  // whose acknowledgement was lost with the link.
  void link_back_locked(arm::ControllerPhase phase, std::uint32_t task_id);
  void on_link_lost();
  std::optional<Job> next_job(Clock::time_point& next_poll);
  void run_job(const Job& job);
  void run();  // the worker thread, until quit

  // ---- serial_arm_link.cpp (no lock held) ----
  // One request: the same sequence number on every attempt; `reply` set when kReply.
  RequestEnd transact(const Job& job, arm::Message& reply);
  std::uint16_t take_seq();
  bool write_all(const std::string& bytes);
  // Waits up to `timeout_ms` for bytes or a wake-up; feeds the reader. False when the link is lost.
  bool pump(int timeout_ms);
  // Handles complete lines; returns the reply with sequence number `seq` if one came.
  std::optional<arm::Message> take_lines(std::optional<std::uint16_t> seq);
  bool should_preempt(JobKind kind);
};

}  // namespace ajar::drivers
