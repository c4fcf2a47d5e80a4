// The protocol conformance suite (`ajarctl conformance`, docs/ajarctl.md): holds a running daemon
// to the wire protocol (docs/protocol.md). It checks the golden vectors, provokes every error code
// it can on purpose, the session rules, protocol 1.1 (1.0 sessions, the robot model, loop
// statistics, Drive and Approach), the procedure, exactly-once execution, faults, and that garbage
// on one session does not hurt another. One line per check ("PASS name", "FAIL name: why" or
// "SKIP name: why"), then exactly "N passed, N failed" (+ ", N skipped" when a check was skipped).
// It takes the controller role with take-over and ends with Reset{clear_parameters}: do not run it
// against a robot in use. The checks that move the base or the arm are refused (SKIP, saying why)
// against real hardware unless allow_motion_on_real_robot; checks of Drive/Approach are SKIP while
// the daemon refuses them with NOT_SUPPORTED.
//
// The checks live in src/, one file per area: vectors, decode, session, protocol_1_1, procedure,
// driving, robustness (exactly once, faults, garbage); src/suite.hpp is their shared plumbing.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

#include "ajar/client/client.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::conformance {

struct Options {
  client::Endpoint endpoint;
  client::TlsOptions tls;                   // mutual TLS when tls.ca is set
  double timeout_s = 3.0;                   // per reply
  std::string vectors_dir;                  // the golden vectors (*.vec)
  bool allow_motion_on_real_robot = false;  // run the motion checks against real hardware too
};

enum class Result {
  kAllPassed,   // nothing failed (some checks may have been skipped)
  kSomeFailed,  // at least one FAIL
  kUnreachable  // the daemon could not be reached at all
};

// Runs the suite against options.endpoint, printing to `out`.
Result run(const Options& options, std::ostream& out);

// Whether the suite may run the checks that move the base: "" when it may, else the sentence saying
// why not. `kind` is Welcome.driver_kind (nullopt: a 1.0 daemon that does not say); only `real`
// (or not saying) is refused, and only without `allow_motion_on_real_robot`.
std::string motion_refusal(std::optional<protocol::DriverKind> kind,
                           bool allow_motion_on_real_robot);

}  // namespace ajar::conformance
