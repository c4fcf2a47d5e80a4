// SerialManipulator: the real arm over RS-232 (libserial), speaking docs/manipulator-serial.md.
//
// A worker thread owns the port. The Manipulator calls only queue work or read a snapshot and
// return at once; stop() jumps the queue (it also cuts short a request that is still being
// retried). Every request is retried up to settings.retries times after the first attempt, each
// attempt waiting settings.ack_timeout_ms, always with the SAME sequence number (the controller
// replays its previous reply for a repeated number, so a retry never moves the arm twice); then
// kArmTimeout. The worker polls STAT every kStatusPollMs while connected.
//
// Link loss (read/write error such as EIO, hang-up, the device node gone) shows as kDisconnected
// with last_error kArmDisconnected; a controller that stops answering the status poll shows as
// kDisconnected with kArmTimeout. The worker reopens the device with exponential backoff
// (reconnect_min_ms doubling to reconnect_max_ms), counts reconnects and resumes. A task whose
// acknowledgement was lost with the link is reconciled with the controller's status after the
// reconnect: adopted if the controller reports it, otherwise kFault (kArmDisconnected).
#pragma once

#include <cstdint>
#include <memory>

#include "ajar/drivers/manipulator.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

class SerialManipulator final : public Manipulator {
 public:
  static constexpr int kStatusPollMs = 100;

  explicit SerialManipulator(SerialArmSettings settings);
  ~SerialManipulator() override;  // disconnects
  SerialManipulator(const SerialManipulator&) = delete;
  SerialManipulator& operator=(const SerialManipulator&) = delete;

  // Opens the device and waits (start-up only, at most (retries + 1) * ack_timeout_ms) for the
  // controller's first status report. kArmDisconnected naming the device if it cannot be opened or
  // configured; kArmTimeout if the controller does not answer. Either way the port is closed again.
  Outcome connect() override;
  Outcome disconnect() override;
  // kArmDisconnected when not connected; kWrongState while a task is busy, queued or the arm is
  // faulted (clear_fault first).
  Result<std::uint32_t> hand_off(const DoorTask& task) override;
  // Queued ahead of everything else. When the link is down the stop stays queued and is sent on
  // reconnect, and kArmDisconnected is returned so the caller knows it has not reached the arm.
  Outcome stop() override;
  // Queues CLR when the arm is in kFault (a no-op otherwise); the reply sets the phase.
  Outcome clear_fault() override;
  ArmStatus status() const override;

  // Diagnostics (logs, tests).
  struct Counters {
    std::uint64_t requests = 0;         // distinct requests sent (sequence numbers used)
    std::uint64_t retransmissions = 0;  // attempts after the first, same sequence number
    std::uint64_t timeouts = 0;         // requests that ran out of retries
    std::uint64_t bad_lines = 0;        // lines dropped: bad CRC, malformed, unexpected seq
    std::uint64_t dropped_bytes = 0;    // garbage bytes skipped while resynchronising
  };
  Counters counters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;  // keeps libserial out of this header
};

}  // namespace ajar::drivers
