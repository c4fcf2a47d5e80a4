#include "ajar/client/conformance.hpp"

#include <ostream>

#include "ajar/client/cli.hpp"

namespace ajar::client {
int run_conformance(const Command&, const GlobalOptions&, std::ostream& out, std::ostream&) {
  out << "0 passed, 1 failed\n";
  return kExitRefused;
}
}  // namespace ajar::client
