// The message table's policy columns: for each message, next to its fields (one Schema row in
// protocol/src/message_schema.hpp), who may send it, whether a repeat is executed again, whether
// its Ack waits for the state file, whether it starts a motion and whether it waits for the wheels
// to be at rest; and its refusals: every (error code, field) of an Error the daemon answers it
// with outside the decoder (the session hub's session rules, the engine's procedure, core's
// validation, the black box). The daemon's session hub and engine and ajarctl read these;
// docs/protocol.md sections 4.2 and 4.3 are tested against them
// (tests/protocol/protocol_doc_test.cpp), and tests/daemon/refusal_table_test.cpp drives the
// daemon through every refusal of every row (and nothing else). A new message is one Schema row
// with its policy and its refusals.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "ajar/core/error.hpp"
#include "ajar/core/fields.hpp"
#include "ajar/core/words.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::protocol {

// Who may send a message (docs/protocol.md 6.1, 6.2).
enum class Sender : std::uint8_t {
  kDaemon = 0,      // daemon -> host: a host sending it gets UNKNOWN_MESSAGE_TYPE
  kAny = 1,         // every greeted session, observers too (Hello: any session; it greets)
  kController = 2,  // the controller only, else NOT_CONTROLLER
  kStop = 3,  // a stop: every session, greeted or not, also while the daemon shuts down or its
              // session table is full; refused only for a TLS identity with may_stop false
};
inline constexpr std::array<Word<Sender>, 4> kSenderWords{{{Sender::kDaemon, "daemon"},
                                                           {Sender::kAny, "any"},
                                                           {Sender::kController, "controller"},
                                                           {Sender::kStop, "stop"}}};

struct MessagePolicy {
  Sender sender = Sender::kDaemon;
  // Executed at most once per (client_instance_id, request_id, type): a repeat gets the original
  // reply again (6.4; not when either id is 0, and a QUEUE_FULL refusal is not remembered).
  bool deduplicated = false;
  // When it changed the persisted state, its Ack is sent once the state file is saved (the
  // commanding session's later replies queue behind it; docs/operations.md, "Durable Acks").
  bool durable_ack = false;
  // An accepted one moves the base or the arm: a motion with a deadline and its closing event.
  bool starts_motion = false;
  // Refused with MOTION_IN_PROGRESS while the wheels are still moving or stopping (unless a fault
  // is latched: then the procedure's own refusal comes first).
  bool needs_wheels_at_rest = false;
};

// The policy of `t`; a daemon -> host policy (sender kDaemon, nothing else) for an unknown type.
const MessagePolicy& policy_of(MessageType t) noexcept;

inline bool needs_controller(MessageType t) noexcept {
  return policy_of(t).sender == Sender::kController;
}
inline bool is_stop(MessageType t) noexcept {
  return policy_of(t).sender == Sender::kStop;
}

// ---- refusals -------------------------------------------------------------------------------
// The fields the daemon's refusals name beyond core's measurements (core::fields): typed once
// here; the session hub, the engine and the black box take them from here. Most are the request's
// own wire fields; kArm, kPlane, kContact and kDoorYaw name what the daemon holds.
namespace refusal_field {
inline constexpr std::string_view kNone = "";  // not about one field
inline constexpr std::string_view kHeaderType = "header.type";
inline constexpr std::string_view kVersionMajor = "version_major";    // Hello
inline constexpr std::string_view kRequestedRole = "requested_role";  // Hello (TLS)
inline constexpr std::string_view kTakeOver = "take_over";            // Hello
inline constexpr std::string_view kTelemetryRate = "telemetry_rate_hz";
inline constexpr std::string_view kArm = "arm";                       // the arm, not yet clear
inline constexpr std::string_view kPlane = "plane";                   // the stored door plane
inline constexpr std::string_view kContact = core::fields::kContact;  // the stored contact point
inline constexpr std::string_view kStandoff = "standoff_m";           // Approach
inline constexpr std::string_view kDoorYaw = "door.yaw_rad";          // Status.door.yaw_rad
inline constexpr std::string_view kLinear = "linear_m_s";             // Drive
inline constexpr std::string_view kName = "name";                     // FetchRecording
inline constexpr std::string_view kOffset = "offset";                 // FetchRecording
inline constexpr std::string_view kMaxLength = "max_length";          // FetchRecording
inline constexpr std::string_view kLastS = "last_s";                  // SaveRecording
}  // namespace refusal_field

// One refusal of a request: an Error with this code naming this field. `indexed`: the field is
// `field[i]` for any element i (points[0], points[1], ...); `per_axis`: it is the field's
// coordinate, `.x`, `.y` or `.z`. INTERNAL (a bug) may answer anything and is in no row; the
// decoder's refusals (docs/protocol.md section 3) are in none either.
struct Refusal {
  ErrorCode code = ErrorCode::kOk;
  std::string_view field;
  bool indexed = false;
  bool per_axis = false;
};

// Every refusal of `t` (empty for a daemon -> host or unknown type), in the table's order.
std::span<const Refusal> refusals_of(MessageType t) noexcept;
// Whether `field` is one the refusal names.
bool names_field(const Refusal& r, std::string_view field) noexcept;
// The refusal of `t` an Error (code, field) is; nullptr when the row has none such.
const Refusal* find_refusal(MessageType t, ErrorCode code, std::string_view field) noexcept;
// The refusal's field as docs/protocol.md 4.3 writes it: `points[i].{x,y,z}`, `p2`; "–" for none.
std::string field_pattern(const Refusal& r);

}  // namespace ajar::protocol
