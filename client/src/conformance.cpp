#include "ajar/client/conformance.hpp"

#include <ostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

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
  CLI::App app("", "conformance");
  app.set_help_flag();  // `conformance --help` is answered before (cli_help.cpp)
  app.add_option("--vectors", o.vectors_dir, "the golden vectors' folder")->type_name("DIR");
  app.add_flag("--allow-motion-on-real-robot", o.allow_motion_on_real_robot,
               "run the motion checks against a daemon on real hardware");
  std::vector<std::string> reversed(command.args.rbegin(), command.args.rend());
  try {
    app.parse(reversed);  // CLI11 takes them reversed
  } catch (const CLI::ParseError& e) {
    err << "ajarctl: conformance takes [--vectors DIR] [--allow-motion-on-real-robot]: " << e.what()
        << "\n";
    return kExitUsage;
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
