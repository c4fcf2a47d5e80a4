// ajarctl's output: every reply, event and telemetry sample as one JSON line (--json) or as text
// for people. The JSON fields are documented in docs/ajarctl.md; every object has "type" and, for
// replies, "command" and "ok".
#pragma once

#include <string>
#include <string_view>

#include "ajar/client/client.hpp"
#include "ajar/client/json.hpp"

namespace ajar::client {

// Client-side error codes for the "error" object when the daemon did not answer (no wire value).
inline constexpr std::string_view kTimeoutCode = "TIMEOUT";
inline constexpr std::string_view kDisconnectedCode = "DISCONNECTED";

// Fixed-point text with `digits` decimals; `sign` forces a leading + on positive values.
std::string fixed(double value, int digits, bool sign = false);

JsonObject error_object(std::string_view code, std::string_view field, std::string_view message);
JsonObject error_object(const protocol::ErrorReply& error);

// Fields of a stored/acknowledged value, shared by Ack and Status renderings.
void add_span_fields(JsonObject& o, const protocol::SpanAck& span, std::string_view length_key);
void add_plane_fields(JsonObject& o, const protocol::PlaneAck& plane);
void add_contact_fields(JsonObject& o, const protocol::ContactAck& contact);
void add_approach_fields(JsonObject& o, const protocol::ApproachAck& approach);
// The loop's statistics (rate_hz, cycles, overruns, period_p50/p99/max_ns, jitter_p99_ns), in
// Status and Telemetry; the console sends the same object.
JsonObject loop_object(const protocol::LoopStatistics& loop);
// `session_minor`: the protocol minor the Status came in (Response::session_minor); the fields a
// later minor appended (1.2: base_motion, recorder) are shown only when it has them.
JsonObject status_object(const protocol::Status& status, std::uint8_t session_minor = 0);
// Status.recorder (protocol 1.2) under its wire names; mode as its word.
JsonObject recorder_object(const protocol::RecorderState& recorder);
JsonObject welcome_object(const protocol::Welcome& welcome);
// GetRobotModel's reply under the wire names of docs/protocol.md 5.22 (camera_to_base as three
// rows of four).
JsonObject robot_model_object(const protocol::RobotModel& model);
std::string robot_model_text(const protocol::RobotModel& model);

// One reply to `command` (e.g. "measure_width"): {"type": "ack"|"error"|"status"|..., "command",
// "ok", ...}.
JsonObject response_object(std::string_view command, const Response& response);
std::string response_text(std::string_view command, const Response& response);

JsonObject event_object(const protocol::Event& event);
std::string event_text(const protocol::Event& event);
JsonObject telemetry_object(const protocol::Telemetry& telemetry);
std::string telemetry_text(const protocol::Telemetry& telemetry);
std::string status_text(const protocol::Status& status, std::uint8_t session_minor = 0);
// "512 B", "12.3 KiB", "45.6 MiB" (binary units; KiB from 10 KiB, MiB from 10 MiB, GiB from 10
// GiB).
std::string bytes_text(std::uint64_t bytes);

}  // namespace ajar::client
