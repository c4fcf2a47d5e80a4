// ajard: the Ajar controller daemon. Everything lives in ajar_daemon (cli.cpp, daemon.cpp) so that
// tests link the same code.
#include "ajar/daemon/cli.hpp"

int main(int argc, char** argv) {
  return ajar::daemon::ajard_main(argc, argv);
}
