// ajarctl conformance: the command-line side of the protocol conformance suite, which lives in its
// own target (conformance/, ajar::conformance::run; what it checks is said there and in
// docs/ajarctl.md).
#pragma once

#include <iosfwd>

namespace ajar::client {

struct Command;
struct GlobalOptions;

// ajarctl conformance [--vectors DIR] [--allow-motion-on-real-robot]. Exit 0 only when nothing
// failed; 1 when a check failed; 3 when the daemon cannot be reached at all; 2 on a usage error.
int run_conformance(const Command& command, const GlobalOptions& options, std::ostream& out,
                    std::ostream& err);

}  // namespace ajar::client
