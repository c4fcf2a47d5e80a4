// The message table's policy columns: for each message, next to its fields (one Schema row in
// protocol/src/message_schema.hpp), who may send it, whether a repeat is executed again, whether
// its Ack waits for the state file, whether it starts a motion and whether it waits for the wheels
// to be at rest. The daemon's session hub and engine and ajarctl read these; docs/protocol.md
// section 4.2 is tested against them (tests/protocol/protocol_doc_test.cpp). A new message is one
// Schema row with its policy.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

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

}  // namespace ajar::protocol
