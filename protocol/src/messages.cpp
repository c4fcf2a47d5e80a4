#include "ajar/protocol/messages.hpp"

#include <type_traits>

namespace ajar::protocol {

namespace {

// Length of the UTF-8 sequence starting at s[i] when it is valid (1..4), else 0.
std::size_t utf8_sequence_length(std::string_view s, std::size_t i) noexcept {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b0 = byte(i);
  if (b0 < 0x80) return 1;
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // allowed range of the second byte
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    n = 2;
  } else if (b0 >= 0xE0 && b0 <= 0xEF) {
    n = 3;
    if (b0 == 0xE0) lo = 0xA0;  // overlong
    if (b0 == 0xED) hi = 0x9F;  // surrogates
  } else if (b0 >= 0xF0 && b0 <= 0xF4) {
    n = 4;
    if (b0 == 0xF0) lo = 0x90;  // overlong
    if (b0 == 0xF4) hi = 0x8F;  // above U+10FFFF
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  if (byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
  }
  return n;
}

bool is_control(unsigned char c) noexcept {
  return c < 0x20 || c == 0x7F;
}

}  // namespace

std::size_t copy_wire_string(std::string_view in, char* out, std::size_t capacity) noexcept {
  std::size_t written = 0;
  std::size_t i = 0;
  while (i < in.size()) {
    const std::size_t n = utf8_sequence_length(in, i);
    if (n == 0) {
      if (written + 1 > capacity) break;
      out[written++] = '?';
      ++i;
      continue;
    }
    if (written + n > capacity) break;
    if (n == 1 && is_control(static_cast<unsigned char>(in[i]))) {
      out[written++] = ' ';
    } else {
      for (std::size_t k = 0; k < n; ++k)
        out[written++] = in[i + k];
    }
    i += n;
  }
  return written;
}

bool is_wire_string(std::string_view s) noexcept {
  std::size_t i = 0;
  while (i < s.size()) {
    const std::size_t n = utf8_sequence_length(s, i);
    if (n == 0) return false;
    if (n == 1 && is_control(static_cast<unsigned char>(s[i]))) return false;
    i += n;
  }
  return true;
}

MessageType type_of(const Message& m) noexcept {
  return std::visit(
      [](const auto& v) -> MessageType {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, Hello>) return MessageType::kHello;
        if constexpr (std::is_same_v<T, Ping>) return MessageType::kPing;
        if constexpr (std::is_same_v<T, MeasureDoorWidth>) return MessageType::kMeasureDoorWidth;
        if constexpr (std::is_same_v<T, MeasureHandle>) return MessageType::kMeasureHandle;
        if constexpr (std::is_same_v<T, MeasureDoorPlane>) return MessageType::kMeasureDoorPlane;
        if constexpr (std::is_same_v<T, SetContactPoint>) return MessageType::kSetContactPoint;
        if constexpr (std::is_same_v<T, AlignBase>) return MessageType::kAlignBase;
        if constexpr (std::is_same_v<T, Engage>) return MessageType::kEngage;
        if constexpr (std::is_same_v<T, Stop>) return MessageType::kStop;
        if constexpr (std::is_same_v<T, EmergencyStop>) return MessageType::kEmergencyStop;
        if constexpr (std::is_same_v<T, Reset>) return MessageType::kReset;
        if constexpr (std::is_same_v<T, GetStatus>) return MessageType::kGetStatus;
        if constexpr (std::is_same_v<T, Subscribe>) return MessageType::kSubscribe;
        if constexpr (std::is_same_v<T, Welcome>) return MessageType::kWelcome;
        if constexpr (std::is_same_v<T, Pong>) return MessageType::kPong;
        if constexpr (std::is_same_v<T, Ack>) return MessageType::kAck;
        if constexpr (std::is_same_v<T, ErrorReply>) return MessageType::kError;
        if constexpr (std::is_same_v<T, Event>) return MessageType::kEvent;
        if constexpr (std::is_same_v<T, Status>) return MessageType::kStatus;
        if constexpr (std::is_same_v<T, Telemetry>) return MessageType::kTelemetry;
        if constexpr (std::is_same_v<T, Drive>) return MessageType::kDrive;
        if constexpr (std::is_same_v<T, Approach>) return MessageType::kApproach;
        if constexpr (std::is_same_v<T, GetRobotModel>) return MessageType::kGetRobotModel;
        if constexpr (std::is_same_v<T, ResetLoopStatistics>)
          return MessageType::kResetLoopStatistics;
        if constexpr (std::is_same_v<T, RobotModel>) return MessageType::kRobotModel;
      },
      m);
}

bool is_request(MessageType t) noexcept {
  switch (t) {
    case MessageType::kHello:
    case MessageType::kPing:
    case MessageType::kMeasureDoorWidth:
    case MessageType::kMeasureHandle:
    case MessageType::kMeasureDoorPlane:
    case MessageType::kSetContactPoint:
    case MessageType::kAlignBase:
    case MessageType::kEngage:
    case MessageType::kStop:
    case MessageType::kEmergencyStop:
    case MessageType::kReset:
    case MessageType::kGetStatus:
    case MessageType::kSubscribe:
    case MessageType::kDrive:
    case MessageType::kApproach:
    case MessageType::kGetRobotModel:
    case MessageType::kResetLoopStatistics:
      return true;
    case MessageType::kWelcome:
    case MessageType::kPong:
    case MessageType::kAck:
    case MessageType::kError:
    case MessageType::kEvent:
    case MessageType::kStatus:
    case MessageType::kTelemetry:
    case MessageType::kRobotModel:
      return false;
  }
  return false;
}

std::uint8_t minor_of(MessageType t) noexcept {
  switch (t) {
    case MessageType::kHello:
    case MessageType::kPing:
    case MessageType::kMeasureDoorWidth:
    case MessageType::kMeasureHandle:
    case MessageType::kMeasureDoorPlane:
    case MessageType::kSetContactPoint:
    case MessageType::kAlignBase:
    case MessageType::kEngage:
    case MessageType::kStop:
    case MessageType::kEmergencyStop:
    case MessageType::kReset:
    case MessageType::kGetStatus:
    case MessageType::kSubscribe:
    case MessageType::kWelcome:
    case MessageType::kPong:
    case MessageType::kAck:
    case MessageType::kError:
    case MessageType::kEvent:
    case MessageType::kStatus:
    case MessageType::kTelemetry:
      return 0;
    case MessageType::kDrive:
    case MessageType::kApproach:
    case MessageType::kGetRobotModel:
    case MessageType::kResetLoopStatistics:
    case MessageType::kRobotModel:
      return 1;
  }
  return 255;
}

std::string_view to_string(MessageType t) noexcept {
  switch (t) {
    case MessageType::kHello:
      return "Hello";
    case MessageType::kPing:
      return "Ping";
    case MessageType::kMeasureDoorWidth:
      return "MeasureDoorWidth";
    case MessageType::kMeasureHandle:
      return "MeasureHandle";
    case MessageType::kMeasureDoorPlane:
      return "MeasureDoorPlane";
    case MessageType::kSetContactPoint:
      return "SetContactPoint";
    case MessageType::kAlignBase:
      return "AlignBase";
    case MessageType::kEngage:
      return "Engage";
    case MessageType::kStop:
      return "Stop";
    case MessageType::kEmergencyStop:
      return "EmergencyStop";
    case MessageType::kReset:
      return "Reset";
    case MessageType::kGetStatus:
      return "GetStatus";
    case MessageType::kSubscribe:
      return "Subscribe";
    case MessageType::kWelcome:
      return "Welcome";
    case MessageType::kPong:
      return "Pong";
    case MessageType::kAck:
      return "Ack";
    case MessageType::kError:
      return "Error";
    case MessageType::kEvent:
      return "Event";
    case MessageType::kStatus:
      return "Status";
    case MessageType::kTelemetry:
      return "Telemetry";
    case MessageType::kDrive:
      return "Drive";
    case MessageType::kApproach:
      return "Approach";
    case MessageType::kGetRobotModel:
      return "GetRobotModel";
    case MessageType::kResetLoopStatistics:
      return "ResetLoopStatistics";
    case MessageType::kRobotModel:
      return "RobotModel";
  }
  return "Unknown";
}

std::string_view to_string(ProcedureState s) noexcept {
  switch (s) {
    case ProcedureState::kAwaitingWidth:
      return "awaiting_width";
    case ProcedureState::kAwaitingHandle:
      return "awaiting_handle";
    case ProcedureState::kAwaitingPlane:
      return "awaiting_plane";
    case ProcedureState::kReadyToAlign:
      return "ready_to_align";
    case ProcedureState::kAligning:
      return "aligning";
    case ProcedureState::kAligned:
      return "aligned";
    case ProcedureState::kReadyToEngage:
      return "ready_to_engage";
    case ProcedureState::kEngaging:
      return "engaging";
    case ProcedureState::kEngaged:
      return "engaged";
    case ProcedureState::kFault:
      return "fault";
  }
  return "unknown";
}

std::string_view to_string(EventKind k) noexcept {
  switch (k) {
    case EventKind::kStateChanged:
      return "state_changed";
    case EventKind::kMotionStarted:
      return "motion_started";
    case EventKind::kMotionFinished:
      return "motion_finished";
    case EventKind::kMotionStopped:
      return "motion_stopped";
    case EventKind::kFaultLatched:
      return "fault_latched";
    case EventKind::kFaultCleared:
      return "fault_cleared";
    case EventKind::kControlChanged:
      return "control_changed";
  }
  return "unknown";
}

std::string_view to_string(Role r) noexcept {
  switch (r) {
    case Role::kController:
      return "controller";
    case Role::kObserver:
      return "observer";
  }
  return "unknown";
}

std::string_view to_string(ArmState s) noexcept {
  switch (s) {
    case ArmState::kDisconnected:
      return "disconnected";
    case ArmState::kIdle:
      return "idle";
    case ArmState::kBusy:
      return "busy";
    case ArmState::kDone:
      return "done";
    case ArmState::kFault:
      return "fault";
  }
  return "unknown";
}

std::string_view to_string(DriverState s) noexcept {
  switch (s) {
    case DriverState::kUnconfigured:
      return "unconfigured";
    case DriverState::kInactive:
      return "inactive";
    case DriverState::kActive:
      return "active";
    case DriverState::kFault:
      return "fault";
  }
  return "unknown";
}

std::string_view to_string(DriverKind k) noexcept {
  switch (k) {
    case DriverKind::kSim:
      return "sim";
    case DriverKind::kMock:
      return "mock";
    case DriverKind::kReal:
      return "real";
  }
  return "unknown";
}

std::string_view to_string(SchedulingPolicy p) noexcept {
  switch (p) {
    case SchedulingPolicy::kOther:
      return "other";
    case SchedulingPolicy::kFifo:
      return "fifo";
    case SchedulingPolicy::kRoundRobin:
      return "rr";
  }
  return "unknown";
}

}  // namespace ajar::protocol
