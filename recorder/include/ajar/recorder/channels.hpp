// The black box's channels: the one definition of every topic ajard records (docs/blackbox.md) and
// that the console's Foxglove live view publishes, so a recording and the live view look the same
// in Foxglove. Each row is a topic, its MCAP message encoding, its schema (name, encoding, text)
// and what it carries. Nothing else in the tree spells a topic, an encoding or a schema: writers
// (the recorder, the console's Foxglove server) and readers (ajarctl blackbox/replay, the Node
// test) take them from here (a reader in another language: the JSON Schema text of a recording's
// Schema records is this text, byte for byte).
//
// Encodings (the MCAP registry, mcap.dev/spec/registry):
//   - `json` with a `jsonschema` schema: what a person reads (events, faults, config, sessions,
//     the loop trace, telemetry, the recorder's own counters). Times in a message are the daemon's
//     monotonic clock in ns since its start (`daemon_time_ns`, the protocol's); the MCAP record's
//     log_time/publish_time are the wall clock (CLOCK_REALTIME, ns since the Unix epoch).
//   - `ajar.wire` without a schema (schema id 0, as the spec allows): every protocol frame in or
//     out, the exact bytes, for replay (`ajarctl replay`). Its layout is kWireLayout below.
//
// Channel ids are fixed (a row's `id`), and so are schema ids (`schema_id`, 0 = none): every file
// has the same ids for the same topics.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace ajar::recorder {

struct ChannelDefinition {
  std::uint16_t id;                   // MCAP channel id (>= 1)
  std::uint16_t schema_id;            // MCAP schema id (0: no schema)
  std::string_view topic;             // "/ajar/events"
  std::string_view message_encoding;  // "json" or "ajar.wire"
  std::string_view schema_name;       // "ajar.Event" ("" without a schema)
  std::string_view schema_encoding;   // "jsonschema" ("" without a schema)
  std::string_view schema;            // the JSON Schema text ("" without a schema)
  std::string_view what;              // one line for docs and `ajarctl blackbox`
};

// ---- /ajar/wire: one protocol frame (message encoding "ajar.wire"), little-endian ----
//   offset 0   u8   layout version, kWireLayoutVersion
//   offset 1   u8   direction: kWireIn (ajard received it) or kWireOut (ajard sent it)
//   offset 2   u64  session id (the daemon's; the same as in /ajar/sessions)
//   offset 10  u64  daemon_time_ns: when ajard received (after the frame's last byte) or queued it
//   offset 18  ...  the frame's bytes exactly as on the wire (header, payload, CRC:
//   docs/protocol.md)
// A frame ajard sent to several sessions (an event) is one message per session.
inline constexpr std::uint8_t kWireLayoutVersion = 1;
inline constexpr std::uint8_t kWireIn = 0;
inline constexpr std::uint8_t kWireOut = 1;
inline constexpr std::size_t kWireHeaderBytes = 18;
inline constexpr std::string_view kWireLayout =
    "u8 version=1, u8 direction (0 in, 1 out), u64 session_id, u64 daemon_time_ns, frame bytes; "
    "little-endian";

// ---- the JSON Schemas (draft 2020-12) ----
inline constexpr std::string_view kEventSchema = R"json({
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "ajar.Event",
  "description": "An event ajard broadcast to its sessions (docs/protocol.md, Event).",
  "type": "object",
  "properties": {
    "daemon_time_ns": {"type": "integer", "minimum": 0, "description": "monotonic, since daemon start"},
    "kind": {"type": "string", "enum": ["state_changed", "motion_started", "motion_finished", "motion_stopped", "fault_latched", "fault_cleared", "control_changed"]},
    "state": {"type": "string", "description": "the procedure state after the event"},
    "fault": {"type": "string", "description": "the error code's name for fault_latched, OK otherwise"},
    "detail": {"type": "string"}
  },
  "required": ["daemon_time_ns", "kind", "state", "fault", "detail"]
})json";

inline constexpr std::string_view kFaultSchema = R"json({
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "ajar.Fault",
  "description": "A fault latched or cleared (the engine's latch: it survives restarts until Reset).",
  "type": "object",
  "properties": {
    "daemon_time_ns": {"type": "integer", "minimum": 0},
    "change": {"type": "string", "enum": ["latched", "cleared"]},
    "code": {"type": "string", "description": "the error code's name (docs/protocol.md)"},
    "code_number": {"type": "integer", "minimum": 0},
    "detail": {"type": "string"}
  },
  "required": ["daemon_time_ns", "change", "code", "code_number", "detail"]
})json";

inline constexpr std::string_view kConfigSchema = R"json({
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "ajar.Config",
  "description": "The config in force: at start and after each SIGHUP (the effective config as ajard --check-config prints it).",
  "type": "object",
  "properties": {
    "daemon_time_ns": {"type": "integer", "minimum": 0},
    "reason": {"type": "string", "enum": ["start", "reload", "file_start"]},
    "file": {"type": "string", "description": "the config file's path"},
    "changed_keys": {"type": "array", "items": {"type": "string"}},
    "yaml": {"type": "string"}
  },
  "required": ["daemon_time_ns", "reason", "file", "changed_keys", "yaml"]
})json";

inline constexpr std::string_view kSessionSchema = R"json({
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "ajar.Session",
  "description": "A session opened, closed, or its role changed. TLS identities appear (never keys).",
  "type": "object",
  "properties": {
    "daemon_time_ns": {"type": "integer", "minimum": 0},
    "session_id": {"type": "integer", "minimum": 0},
    "change": {"type": "string", "enum": ["open", "close", "role"]},
    "peer": {"type": "string", "description": "address:port"},
    "identity": {"type": "string", "description": "plaintext, or the certificate's identity"},
    "role": {"type": "string", "enum": ["none", "controller", "observer"]},
    "detail": {"type": "string"}
  },
  "required": ["daemon_time_ns", "session_id", "change", "peer", "identity", "role", "detail"]
})json";

inline constexpr std::string_view kLoopSchema = R"json({
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "ajar.LoopSample",
  "description": "One control-loop cycle (every recorder.loop_decimation-th). Wheels are wheel-forward positive; commanded = what the card was told.",
  "type": "object",
  "properties": {
    "cycle": {"type": "integer", "minimum": 0},
    "daemon_time_ns": {"type": "integer", "minimum": 0},
    "left": {"$ref": "#/$defs/wheel"},
    "right": {"$ref": "#/$defs/wheel"},
    "motion": {"type": "string", "enum": ["idle", "moving", "jogging", "stopping"]},
    "phase": {"type": "string", "enum": ["none", "running", "coming_to_rest", "recovering"]},
    "motion_id": {"type": "integer", "minimum": 0},
    "stop_generation": {"type": "integer", "minimum": 0},
    "fault": {"type": "string"},
    "pose": {"type": "object", "properties": {"x_m": {"type": "number"}, "y_m": {"type": "number"}, "yaw_rad": {"type": "number"}}, "required": ["x_m", "y_m", "yaw_rad"]},
    "commanded_linear_m_s": {"type": "number"},
    "commanded_angular_rad_s": {"type": "number"},
    "timing": {"type": "object", "properties": {"wakeup_latency_ns": {"type": "integer"}, "execution_ns": {"type": "integer"}, "period_ns": {"type": "integer"}}, "required": ["wakeup_latency_ns", "execution_ns", "period_ns"]}
  },
  "required": ["cycle", "daemon_time_ns", "left", "right", "motion", "phase", "motion_id", "stop_generation", "fault", "pose", "commanded_linear_m_s", "commanded_angular_rad_s", "timing"],
  "$defs": {
    "wheel": {
      "type": "object",
      "properties": {
        "commanded_rad": {"type": "number", "description": "the target position the card was told (a move), else the measured one"},
        "measured_rad": {"type": "number"},
        "commanded_rad_s": {"type": "number"},
        "measured_rad_s": {"type": "number"},
        "counts": {"type": "integer"}
      },
      "required": ["commanded_rad", "measured_rad", "commanded_rad_s", "measured_rad_s", "counts"]
    }
  }
})json";

inline constexpr std::string_view kTelemetrySchema = R"json({
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "ajar.Telemetry",
  "description": "The daemon's Telemetry message (docs/protocol.md) as JSON: what the operator's console shows.",
  "type": "object",
  "properties": {
    "daemon_time_ns": {"type": "integer", "minimum": 0},
    "state": {"type": "string"},
    "moving": {"type": "boolean"},
    "left_wheel_rad": {"type": "number"},
    "right_wheel_rad": {"type": "number"},
    "base_yaw_odometry_rad": {"type": "number"},
    "odometry_x_m": {"type": "number"},
    "odometry_y_m": {"type": "number"},
    "arm_state": {"type": "string"},
    "commanded_linear_m_s": {"type": "number"},
    "commanded_angular_rad_s": {"type": "number"}
  },
  "required": ["daemon_time_ns", "state", "moving", "left_wheel_rad", "right_wheel_rad", "base_yaw_odometry_rad", "odometry_x_m", "odometry_y_m", "arm_state"]
})json";

inline constexpr std::string_view kRecorderSchema = R"json({
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "ajar.RecorderStatus",
  "description": "The recorder's own counters: at a file's start, every second while they change, and at its end.",
  "type": "object",
  "properties": {
    "daemon_time_ns": {"type": "integer", "minimum": 0},
    "loop_samples": {"type": "integer", "minimum": 0, "description": "loop samples taken since start"},
    "loop_dropped": {"type": "integer", "minimum": 0, "description": "loop samples lost: ring full"},
    "io_records": {"type": "integer", "minimum": 0},
    "io_dropped": {"type": "integer", "minimum": 0, "description": "frames/events/sessions lost: queue full"},
    "write_failures": {"type": "integer", "minimum": 0, "description": "records lost: the disk refused (full, error)"},
    "disk_full": {"type": "boolean"},
    "file": {"type": "string"}
  },
  "required": ["daemon_time_ns", "loop_samples", "loop_dropped", "io_records", "io_dropped", "write_failures", "disk_full", "file"]
})json";

// The channels, by id. Topic names and ids never change meaning; a new one is a new row.
inline constexpr std::array<ChannelDefinition, 8> kChannels = {{
    {1, 0, "/ajar/wire", "ajar.wire", "", "", "",
     "every protocol frame in and out, exact bytes (kWireLayout)"},
    {2, 1, "/ajar/events", "json", "ajar.Event", "jsonschema", kEventSchema,
     "every event ajard broadcast"},
    {3, 2, "/ajar/faults", "json", "ajar.Fault", "jsonschema", kFaultSchema,
     "faults latched and cleared"},
    {4, 3, "/ajar/config", "json", "ajar.Config", "jsonschema", kConfigSchema,
     "the config in force at start and after each SIGHUP"},
    {5, 4, "/ajar/sessions", "json", "ajar.Session", "jsonschema", kSessionSchema,
     "sessions opened, closed, role changes (with TLS identities)"},
    {6, 5, "/ajar/loop", "json", "ajar.LoopSample", "jsonschema", kLoopSchema,
     "the control loop, every loop_decimation-th cycle"},
    {7, 6, "/ajar/telemetry", "json", "ajar.Telemetry", "jsonschema", kTelemetrySchema,
     "the Telemetry ajard sends (the console's live view)"},
    {8, 7, "/ajar/recorder", "json", "ajar.RecorderStatus", "jsonschema", kRecorderSchema,
     "the recorder's counters (drops, disk full)"},
}};

// Channel ids by name, for writers.
inline constexpr std::uint16_t kWireChannel = 1;
inline constexpr std::uint16_t kEventsChannel = 2;
inline constexpr std::uint16_t kFaultsChannel = 3;
inline constexpr std::uint16_t kConfigChannel = 4;
inline constexpr std::uint16_t kSessionsChannel = 5;
inline constexpr std::uint16_t kLoopChannel = 6;
inline constexpr std::uint16_t kTelemetryChannel = 7;
inline constexpr std::uint16_t kRecorderChannel = 8;

// The row of `topic` (nullptr if none).
constexpr const ChannelDefinition* find_channel(std::string_view topic) noexcept {
  for (const auto& c : kChannels) {
    if (c.topic == topic) return &c;
  }
  return nullptr;
}
// The row of channel `id` (nullptr if none).
constexpr const ChannelDefinition* channel_by_id(std::uint16_t id) noexcept {
  return id >= 1 && id <= kChannels.size() ? &kChannels[id - 1] : nullptr;
}
static_assert([] {
  for (std::size_t i = 0; i < kChannels.size(); ++i) {
    if (kChannels[i].id != i + 1) return false;
  }
  return true;
}());

// The MCAP Header's profile and library fields of ajard's recordings.
inline constexpr std::string_view kMcapProfile = "";  // not one of the registry's profiles
inline constexpr std::string_view kMcapLibrary = "ajar-recorder 1";

}  // namespace ajar::recorder
