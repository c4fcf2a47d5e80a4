// ajarctl conformance: holds a running daemon to the wire protocol (docs/protocol.md). Checks the
// golden vectors, provokes every error code it can on purpose, the session rules, and that garbage
// on one session does not hurt another. One line per check ("PASS name" / "FAIL name: why"), then
// exactly "N passed, N failed". Leaves the daemon clean (Reset with clear_parameters) at the end.
// It takes the controller role with take-over: do not run it against a robot in use. The checks
// that move the base (or engage the arm) are refused against real hardware unless
// --allow-motion-on-real-robot; a check the daemon cannot do yet (NOT_SUPPORTED) is reported as
// "SKIP name: why", and the last line then ends ", N skipped".
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

#include "ajar/protocol/messages.hpp"

namespace ajar::client {

struct Command;
struct GlobalOptions;

// Whether the suite may run the checks that move the base: "" when it may, else the sentence saying
// why not. `kind` is Welcome.driver_kind (nullopt: a 1.0 daemon that does not say); only `real`
// (or not saying) is refused, and only without `allow_motion_on_real_robot`.
std::string motion_refusal(std::optional<protocol::DriverKind> kind,
                           bool allow_motion_on_real_robot);

// ajarctl conformance [--vectors DIR] [--allow-motion-on-real-robot]. Exit 0 only when nothing
// failed; 3 when the daemon cannot be reached at all.
int run_conformance(const Command& command, const GlobalOptions& options, std::ostream& out,
                    std::ostream& err);

}  // namespace ajar::client
