#include "ajar/drivers/arm_protocol.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <vector>

#include "ajar/core/words.hpp"

namespace ajar::drivers::arm {
namespace {

// One word list per enum of the protocol (docs/manipulator-serial.md): both directions read it.
constexpr std::array<Word<Command>, 8> kCommandWords{{{Command::kTask, "TASK"},
                                                      {Command::kStatus, "STAT"},
                                                      {Command::kStop, "STOP"},
                                                      {Command::kClear, "CLR"},
                                                      {Command::kAck, "ACK"},
                                                      {Command::kNak, "NAK"},
                                                      {Command::kReport, "STA"},
                                                      {Command::kDone, "DONE"}}};
constexpr std::array<Word<ControllerPhase>, 4> kPhaseWords{{{ControllerPhase::kIdle, "IDLE"},
                                                            {ControllerPhase::kBusy, "BUSY"},
                                                            {ControllerPhase::kDone, "DONE"},
                                                            {ControllerPhase::kFault, "FAULT"}}};
constexpr std::array<Word<RejectReason>, 4> kReasonWords{{{RejectReason::kBusy, "BUSY"},
                                                          {RejectReason::kFault, "FAULT"},
                                                          {RejectReason::kRefused, "REFUSED"},
                                                          {RejectReason::kBadRequest, "BADREQ"}}};

std::optional<Command> command_from(std::string_view name) {
  return value_of(kCommandWords, name);
}

bool is_request(Command c) {
  return c == Command::kTask || c == Command::kStatus || c == Command::kStop ||
         c == Command::kClear;
}

std::optional<ControllerPhase> phase_from(std::string_view s) {
  return value_of(kPhaseWords, s);
}

std::optional<RejectReason> reason_from(std::string_view s) {
  return value_of(kReasonWords, s);
}

std::optional<core::RotationDirection> direction_from(std::string_view s) {
  if (s == "CW") return core::RotationDirection::kClockwise;
  if (s == "CCW") return core::RotationDirection::kCounterClockwise;
  return std::nullopt;
}

constexpr char kHex[] = "0123456789ABCDEF";

std::optional<int> hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return std::nullopt;
}

void append_uint(std::string& out, std::uint64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void append_metres(std::string& out, double v) {
  char buf[48];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, 4);
  out.append(buf, r.ptr);
}

Error bad(ErrorCode code, std::string field, std::string message) {
  return make_error(code, std::move(field), "arm protocol: " + std::move(message));
}

template <typename T>
std::optional<T> parse_uint(std::string_view s, T max) {
  if (s.empty() || s.size() > 10) return std::nullopt;
  std::uint64_t v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc{} || r.ptr != s.data() + s.size() || v > max) return std::nullopt;
  return static_cast<T>(v);
}

Result<double> parse_metres(std::string_view s, const char* field) {
  double v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v, std::chars_format::fixed);
  if (s.empty() || r.ec != std::errc{} || r.ptr != s.data() + s.size()) {
    return bad(ErrorCode::kBadPayloadLength, field, "not a number: '" + std::string(s) + "'");
  }
  if (!std::isfinite(v)) return bad(ErrorCode::kNonFiniteNumber, field, "not finite");
  return v;
}

std::vector<std::string_view> split(std::string_view body) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const auto comma = body.find(',', start);
    out.push_back(body.substr(start, comma == std::string_view::npos ? comma : comma - start));
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

// A TASK's five lengths in the order they are sent, as its refusals name them.
constexpr const char* kTaskLengthNames[] = {"contact_base_m.x", "contact_base_m.y",
                                            "contact_base_m.z", "door_width_m", "handle_length_m"};

}  // namespace

const char* to_string(Command c) noexcept {
  return word_of(kCommandWords, c, "UNKNOWN").data();
}

const char* to_string(ControllerPhase p) noexcept {
  return word_of(kPhaseWords, p, "UNKNOWN").data();
}

const char* to_string(RejectReason r) noexcept {
  return word_of(kReasonWords, r, "UNKNOWN").data();
}

std::uint16_t crc16_ccitt(std::string_view bytes) noexcept {
  unsigned crc = 0xFFFFU;  // arithmetic in unsigned int, kept to 16 bits
  for (const char ch : bytes) {
    crc ^= static_cast<unsigned>(static_cast<unsigned char>(ch)) << 8U;
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x8000U) != 0 ? ((crc << 1U) ^ 0x1021U) & 0xFFFFU : (crc << 1U) & 0xFFFFU;
    }
  }
  return static_cast<std::uint16_t>(crc);
}

Result<std::string> encode(const Message& m) {
  std::string body;
  append_uint(body, m.seq);
  body += ',';
  body += to_string(m.command);
  switch (m.command) {
    case Command::kTask: {
      const double lengths[] = {m.task.contact_base_m.x(), m.task.contact_base_m.y(),
                                m.task.contact_base_m.z(), m.task.door_width_m,
                                m.task.handle_length_m};
      body += ',';
      append_uint(body, m.task_id);
      for (std::size_t i = 0; i < 5; ++i) {
        if (!std::isfinite(lengths[i])) {
          return bad(ErrorCode::kNonFiniteNumber, kTaskLengthNames[i], "not finite");
        }
        body += ',';
        append_metres(body, lengths[i]);
      }
      body += ',';
      body += core::to_string(m.task.door_direction);
      body += ',';
      body += core::to_string(m.task.handle_direction);
      break;
    }
    case Command::kStatus:
    case Command::kStop:
    case Command::kClear:
      break;
    case Command::kAck:
    case Command::kNak:
      body += ',';
      body += to_string(m.subject);
      if (m.command == Command::kNak) {
        body += ',';
        body += to_string(m.reason);
      }
      [[fallthrough]];
    case Command::kReport:
      body += ',';
      body += to_string(m.phase);
      [[fallthrough]];
    case Command::kDone:
      body += ',';
      append_uint(body, m.task_id);
      break;
  }
  const std::uint16_t crc = crc16_ccitt(body);
  std::string line;
  line.reserve(body.size() + 8);
  line += '$';
  line += body;
  line += '*';
  for (int shift = 12; shift >= 0; shift -= 4) {
    line += kHex[(crc >> static_cast<unsigned>(shift)) & 0xFU];
  }
  line += "\r\n";
  return line;
}

namespace {

// The body between '$' and '*' of a line whose CRC matches it.
Result<std::string_view> checked_body(std::string_view line) {
  if (line.size() < 8 || line.front() != '$') {
    return bad(ErrorCode::kBadPayloadLength, "", "line too short or without '$'");
  }
  const auto star = line.rfind('*');
  if (star == std::string_view::npos || line.size() - star != 5) {
    return bad(ErrorCode::kBadPayloadLength, "crc", "no '*' followed by four hex digits");
  }
  unsigned crc_sent = 0;
  for (std::size_t i = star + 1; i < line.size(); ++i) {
    const auto d = hex_digit(line[i]);
    if (!d) return bad(ErrorCode::kBadPayloadLength, "crc", "not upper-case hex");
    crc_sent = (crc_sent << 4U) | static_cast<unsigned>(*d);
  }
  const std::string_view body = line.substr(1, star - 1);
  if (crc16_ccitt(body) != crc_sent) return bad(ErrorCode::kCrcMismatch, "crc", "CRC mismatch");
  return body;
}

// A line's fields (seq and command first) read into the message whose command they carry.
class Fields {
 public:
  Fields(const std::vector<std::string_view>& f, Message& m) : f_(f), m_(m) {}

  std::string_view operator[](std::size_t i) const { return f_[i]; }

  // Exactly `n` fields, seq and command included.
  Outcome count(std::size_t n) const {
    if (f_.size() != n) {
      return bad(
          ErrorCode::kBadPayloadLength, to_string(m_.command),
          "expected " + std::to_string(n - 2) + " fields, got " + std::to_string(f_.size() - 2));
    }
    return Ok{};
  }
  Outcome task_id_at(std::size_t i) {
    const auto id = parse_uint<std::uint32_t>(f_[i], 0xFFFFFFFFU);
    if (!id) return bad(ErrorCode::kBadPayloadLength, "task_id", "not a number");
    m_.task_id = *id;
    return Ok{};
  }
  Outcome phase_at(std::size_t i) {
    const auto p = phase_from(f_[i]);
    if (!p)
      return bad(ErrorCode::kInvalidEnumValue, "phase", "unknown '" + std::string(f_[i]) + "'");
    m_.phase = *p;
    return Ok{};
  }

 private:
  const std::vector<std::string_view>& f_;
  Message& m_;
};

// TASK: its id, the contact point, the door's width and handle's length, both directions.
Outcome read_task(Fields& f, Message& m) {
  if (auto s = f.count(10); !s) return s;
  if (auto s = f.task_id_at(2); !s) return s;
  double v[5] = {};
  for (std::size_t i = 0; i < 5; ++i) {
    auto r = parse_metres(f[3 + i], kTaskLengthNames[i]);
    if (!r) return std::move(r).error();
    v[i] = *r;
  }
  m.task.contact_base_m = core::Vec3(v[0], v[1], v[2]);
  m.task.door_width_m = v[3];
  m.task.handle_length_m = v[4];
  const auto door = direction_from(f[8]);
  if (!door) return bad(ErrorCode::kInvalidEnumValue, "door_direction", "not CW/CCW");
  const auto handle = direction_from(f[9]);
  if (!handle) return bad(ErrorCode::kInvalidEnumValue, "handle_direction", "not CW/CCW");
  m.task.door_direction = *door;
  m.task.handle_direction = *handle;
  return Ok{};
}

// ACK/NAK: the request answered, a NAK's reason, the controller's phase and task id.
Outcome read_reply(Fields& f, Message& m) {
  const bool nak = m.command == Command::kNak;
  if (auto s = f.count(nak ? 6 : 5); !s) return s;
  const auto subject = command_from(f[2]);
  if (!subject || !is_request(*subject)) {
    return bad(ErrorCode::kInvalidEnumValue, "subject", "not a request name");
  }
  m.subject = *subject;
  std::size_t i = 3;
  if (nak) {
    const auto reason = reason_from(f[i]);
    if (!reason) return bad(ErrorCode::kInvalidEnumValue, "reason", "unknown reason");
    m.reason = *reason;
    ++i;
  }
  if (auto s = f.phase_at(i); !s) return s;
  return f.task_id_at(i + 1);
}

// The fields after seq and command, as m.command defines them.
Outcome read_arguments(Fields& f, Message& m) {
  switch (m.command) {
    case Command::kTask:
      return read_task(f, m);
    case Command::kStatus:
    case Command::kStop:
    case Command::kClear:
      return f.count(2);
    case Command::kAck:
    case Command::kNak:
      return read_reply(f, m);
    case Command::kReport:
      if (auto s = f.count(4); !s) return s;
      if (auto s = f.phase_at(2); !s) return s;
      return f.task_id_at(3);
    case Command::kDone:
      if (auto s = f.count(3); !s) return s;
      return f.task_id_at(2);
  }
  return Ok{};
}

}  // namespace

Result<Message> decode(std::string_view line) {
  const auto body = checked_body(line);
  if (!body) return body.error();
  const auto f = split(*body);
  Message m;
  if (f.size() < 2) return bad(ErrorCode::kBadPayloadLength, "", "no command");
  const auto seq = parse_uint<std::uint16_t>(f[0], 0xFFFF);
  if (!seq) return bad(ErrorCode::kBadPayloadLength, "seq", "not a number 0..65535");
  m.seq = *seq;
  const auto cmd = command_from(f[1]);
  if (!cmd) {
    return bad(ErrorCode::kUnknownMessageType, "command", "unknown '" + std::string(f[1]) + "'");
  }
  m.command = *cmd;
  Fields fields(f, m);
  if (auto s = read_arguments(fields, m); !s) return std::move(s).error();
  return m;
}

void LineReader::feed(std::string_view bytes) {
  for (const char c : bytes) {
    if (c == '$') {
      if (in_line_) dropped_bytes_ += current_.size();
      current_.assign(1, '$');
      in_line_ = true;
      continue;
    }
    if (!in_line_) {
      ++dropped_bytes_;
      continue;
    }
    if (c == '\n') {
      if (!current_.empty() && current_.back() == '\r') current_.pop_back();
      pending_ += current_;
      pending_ += '\n';
      current_.clear();
      in_line_ = false;
      continue;
    }
    if (current_.size() >= kMaxLineBytes) {
      dropped_bytes_ += current_.size() + 1;
      current_.clear();
      in_line_ = false;
      continue;
    }
    current_ += c;
  }
}

std::optional<std::string> LineReader::next_line() {
  const auto nl = pending_.find('\n');
  if (nl == std::string::npos) return std::nullopt;
  std::string line = pending_.substr(0, nl);
  pending_.erase(0, nl + 1);
  return line;
}

void LineReader::clear() {
  pending_.clear();
  current_.clear();
  in_line_ = false;
}

}  // namespace ajar::drivers::arm
