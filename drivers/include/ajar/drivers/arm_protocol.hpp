// The line protocol between the host (SerialManipulator) and the arm controller, as specified in
// docs/manipulator-serial.md. Pure encode/decode: no I/O, no threads.
//
//   $<seq>,<CMD>[,<field>...]*<CRC>\r\n
//
// seq: decimal 1..65535 (0 = unsolicited message from the controller). CRC: CRC-16/CCITT-FALSE
// (poly 0x1021, init 0xFFFF) over the bytes between '$' and '*', four upper-case hex digits.
// Lengths in metres with 4 decimals, directions "CW" / "CCW".
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "ajar/core/result.hpp"
#include "ajar/drivers/manipulator.hpp"

namespace ajar::drivers::arm {

inline constexpr std::size_t kMaxLineBytes = 160;  // longer candidate lines are discarded
inline constexpr std::uint16_t kUnsolicitedSeq = 0;

enum class Command : std::uint8_t {
  // host -> controller
  kTask,  // TASK,<task_id>,<x_m>,<y_m>,<z_m>,<door_width_m>,<handle_length_m>,<door_dir>,<handle_dir>
  kStatus,  // STAT
  kStop,    // STOP
  kClear,   // CLR
  // controller -> host (replies echo the request's seq)
  kAck,     // ACK,<acked CMD>,<phase>,<task_id>
  kNak,     // NAK,<refused CMD>,<reason>,<phase>,<task_id>
  kReport,  // STA,<phase>,<task_id>               (reply to STAT)
  kDone,    // DONE,<task_id>                      (unsolicited, seq 0)
};

// The controller's own state machine.
enum class ControllerPhase : std::uint8_t { kIdle, kBusy, kDone, kFault };

enum class RejectReason : std::uint8_t {
  kBusy,        // BUSY: a task is running
  kFault,       // FAULT: the controller is faulted; CLR first
  kRefused,     // REFUSED: the task is not feasible for the arm
  kBadRequest,  // BADREQ: fields out of range
};

struct Message {
  std::uint16_t seq = 0;
  Command command = Command::kStatus;
  Command subject = Command::kStatus;  // kAck / kNak: the command acknowledged or refused
  std::uint32_t task_id = 0;           // kTask, kAck, kNak, kReport, kDone
  DoorTask task;                       // kTask
  ControllerPhase phase = ControllerPhase::kIdle;  // kAck, kNak, kReport
  RejectReason reason = RejectReason::kRefused;    // kNak
};

const char* to_string(Command c) noexcept;          // "TASK", "STAT", ...
const char* to_string(ControllerPhase p) noexcept;  // "IDLE", "BUSY", "DONE", "FAULT"
const char* to_string(RejectReason r) noexcept;     // "BUSY", "FAULT", "REFUSED", "BADREQ"

// CRC-16/CCITT-FALSE of `bytes` (check value for "123456789": 0x29B1).
std::uint16_t crc16_ccitt(std::string_view bytes) noexcept;

// The complete line, '$' to "\r\n". Non-finite lengths are an error (kNonFiniteNumber).
Result<std::string> encode(const Message& message);

// Decodes one line as produced by LineReader (starting with '$', without the line terminator).
// Errors: kCrcMismatch, kUnknownMessageType, kBadPayloadLength (wrong field count / shape),
// kInvalidEnumValue, kNonFiniteNumber; `field` names the offending field.
Result<Message> decode(std::string_view line);

// Reassembles lines from a byte stream and resynchronises after garbage: bytes before a '$' are
// dropped, a '$' restarts the current line, a line is complete at '\n' (a '\r' before it is
// stripped), and lines longer than kMaxLineBytes are dropped. Counts what it dropped.
class LineReader {
 public:
  // Appends bytes; returns nothing. Complete lines are taken with next_line().
  void feed(std::string_view bytes);
  std::optional<std::string> next_line();
  void clear();
  std::uint64_t dropped_bytes() const noexcept { return dropped_bytes_; }

 private:
  std::string pending_;  // bytes fed but not yet scanned
  std::string current_;  // the line being assembled (starts with '$')
  bool in_line_ = false;
  std::uint64_t dropped_bytes_ = 0;
};

}  // namespace ajar::drivers::arm
