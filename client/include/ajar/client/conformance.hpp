// ajarctl conformance: holds a running daemon to the wire protocol (docs/protocol.md). Checks the
// golden vectors, provokes every error code it can on purpose, the session rules, and that garbage
// on one session does not hurt another. One line per check ("PASS name" / "FAIL name: why"), then
// exactly "N passed, N failed". Leaves the daemon clean (Reset with clear_parameters) at the end.
// It takes the controller role with take-over: do not run it against a robot in use.
#pragma once

#include <iosfwd>

namespace ajar::client {

struct Command;
struct GlobalOptions;

// ajarctl conformance [--vectors DIR]. Exit 0 only when nothing failed; 3 when the daemon cannot be
// reached at all.
int run_conformance(const Command& command, const GlobalOptions& options, std::ostream& out,
                    std::ostream& err);

}  // namespace ajar::client
