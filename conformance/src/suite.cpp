// The suite: its order of groups, the summary line, and the decision about motion on a real
// robot.
#include "suite.hpp"

namespace ajar::conformance {

Result Suite::run() {
  // Reachability first: nothing else makes sense without it.
  {
    auto c = open();
    if (!c) {
      out_ << "FAIL connect: cannot reach " << options_.endpoint.host << ":"
           << options_.endpoint.port << "\n0 passed, 1 failed\n";
      return Result::kUnreachable;
    }
  }
  // Which drivers: the checks that move the base refuse to run on real hardware unless told.
  {
    auto c = open();
    const Response r = c ? c->hello(Role::kObserver) : Response{};
    const auto* w = r.get<protocol::Welcome>();
    std::optional<protocol::DriverKind> kind;
    if (w && w->version_minor >= 1) kind = w->driver_kind;
    motion_refused_ = motion_refusal(kind, options_.allow_motion_on_real_robot);
    out_ << "daemon drivers: "
         << (kind ? std::string(protocol::to_string(*kind)) : std::string("not said (1.0)"))
         << '\n';
    if (!motion_refused_.empty()) out_ << "REFUSED motion checks: " << motion_refused_ << '\n';
  }
  clean("initial reset");
  golden_vectors();
  decode_errors();
  session_rules();
  protocol_1_1();
  recordings();
  roles();
  telemetry();
  procedure();
  ordering();
  driving();
  duplicates();
  faults();
  garbage();
  clean("final reset (clean state)");
  check("final state clean", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    const Response r = c->request(protocol::GetStatus{});
    const auto* s = r.get<protocol::Status>();
    if (!s) return "GetStatus: " + describe(r);
    if (s->state != ProcedureState::kAwaitingWidth || s->latched_fault != ErrorCode::kOk ||
        s->has_width || s->has_handle || s->has_plane || s->has_contact) {
      return "state " + std::string(protocol::to_string(s->state)) + ", fault " +
             std::string(ajar::to_string(s->latched_fault));
    }
    return std::string{};
  });
  if (!motion_refused_.empty()) out_ << "REFUSED motion checks: " << motion_refused_ << '\n';
  out_ << passed_ << " passed, " << failed_ << " failed";
  if (skipped_ > 0) out_ << ", " << skipped_ << " skipped";
  out_ << '\n';
  out_.flush();
  return failed_ == 0 ? Result::kAllPassed : Result::kSomeFailed;
}

std::string motion_refusal(std::optional<protocol::DriverKind> kind,
                           bool allow_motion_on_real_robot) {
  if (allow_motion_on_real_robot) return {};
  if (!kind) {
    return "the daemon speaks protocol 1.0 and does not say whether it drives real hardware; "
           "the checks that move the base are not run without --allow-motion-on-real-robot";
  }
  if (*kind == protocol::DriverKind::kReal) {
    return "the daemon drives the real robot (Welcome.driver_kind = real): the checks that turn "
           "or drive the base and engage the arm are not run without "
           "--allow-motion-on-real-robot (clear the robot's surroundings first)";
  }
  return {};
}

Result run(const Options& options, std::ostream& out) {
  Suite suite(options, out);
  return suite.run();
}

}  // namespace ajar::conformance
