#include "ajar/client/conformance.hpp"

#include <ostream>

#include "ajar/client/cli.hpp"
#include "ajar/conformance/conformance.hpp"

namespace ajar::client {

int run_conformance(const Command& command, const GlobalOptions& options, std::ostream& out,
                    std::ostream& err) {
  conformance::Options o;
  o.endpoint = options.endpoint;
  o.tls = options.tls;
  o.timeout_s = options.timeout_s;
  o.vectors_dir = default_vectors_dir();
  for (std::size_t i = 0; i < command.args.size(); ++i) {
    if (command.args[i] == "--vectors" && i + 1 < command.args.size()) {
      o.vectors_dir = command.args[++i];
    } else if (command.args[i] == "--allow-motion-on-real-robot") {
      o.allow_motion_on_real_robot = true;
    } else {
      err << "ajarctl: conformance takes [--vectors DIR] [--allow-motion-on-real-robot], got '"
          << command.args[i] << "'\n";
      return kExitUsage;
    }
  }
  switch (conformance::run(o, out)) {
    case conformance::Result::kAllPassed:
      return kExitOk;
    case conformance::Result::kSomeFailed:
      return kExitRefused;
    case conformance::Result::kUnreachable:
      return kExitConnection;
  }
  return kExitRefused;
}

}  // namespace ajar::client
