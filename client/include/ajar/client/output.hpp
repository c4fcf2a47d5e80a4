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

// The JSON of a message is message_json() (json.hpp; docs/protocol.md section 10); these add
// ajarctl's own keys around it or pick one block out of it.

// A client-side error (no wire message): {code, field, message}.
JsonObject error_object(std::string_view code, std::string_view field, std::string_view message);
// The daemon's Error under its wire names, plus "number": the code's number.
JsonObject error_object(const protocol::ErrorReply& error);
// Status.loop and Status.recorder as message_json() writes them (the console sends them alone).
JsonObject loop_object(const protocol::LoopStatistics& loop);
JsonObject recorder_object(const protocol::RecorderState& recorder);
// `session_minor`: the protocol minor the Status came in (Response::session_minor); the fields a
// later minor appended (1.1: the motion block, realtime; 1.2: base_motion, recorder) are shown
// only when it has them.
JsonObject status_object(const protocol::Status& status,
                         std::uint8_t session_minor = protocol::kVersionMinor);
JsonObject welcome_object(const protocol::Welcome& welcome);
JsonObject robot_model_object(const protocol::RobotModel& model);
// Every field of RobotModel, one line each, under its wire name (from the same walk).
std::string robot_model_text(const protocol::RobotModel& model);

// One reply to `command` (e.g. "measure_width"): {"type": "ack"|"error"|"status"|..., "command",
// "ok", ...}: an Ack's and a Pong's fields follow (with request_id), a Status, RobotModel or
// Welcome is the object under "status", "robot_model", "welcome"; a refusal's Error is "error".
JsonObject response_object(std::string_view command, const Response& response);
std::string response_text(std::string_view command, const Response& response);

// {"type": "event"|"telemetry", then the message's fields}.
JsonObject event_object(const protocol::Event& event, std::uint8_t minor = protocol::kVersionMinor);
std::string event_text(const protocol::Event& event);
JsonObject telemetry_object(const protocol::Telemetry& telemetry,
                            std::uint8_t minor = protocol::kVersionMinor);
std::string telemetry_text(const protocol::Telemetry& telemetry);
std::string status_text(const protocol::Status& status, std::uint8_t session_minor = 0);
// "512 B", "12.3 KiB", "45.6 MiB" (binary units; KiB from 10 KiB, MiB from 10 MiB, GiB from 10
// GiB).
std::string bytes_text(std::uint64_t bytes);

}  // namespace ajar::client
