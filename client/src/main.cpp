// ajarctl: the command line over ajar_client (see docs/ajarctl.md).
#include <iostream>
#include <string>
#include <vector>

#include "ajar/client/cli.hpp"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return ajar::client::run_ajarctl(args, std::cin, std::cout, std::cerr);
}
