// run_daemon: ajard's life after the command line. Start-up order: bind (fails fast on a busy port;
// not listening yet, so a connect is refused), engine.start() (drivers active, state restored,
// control loop running), listen and serve (a TCP connect now means the daemon serves), write the
// port file, READY=1. Then the I/O thread runs the server, the engine's poll timer, signals and the
// systemd watchdog until SIGTERM/SIGINT:
//   SIGTERM/SIGINT  STOPPING=1, stop accepting, engine.shutdown() (stops motion — its
//                   motion_stopped event reaches the still-open sessions — and persists), send held
//                   replies, close sessions after their queued frames, exit code 0;
//   SIGHUP          re-reads the config file; applies logging.level only; every other change is
//                   logged as needing a restart; a broken file is logged and ignored.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/engine.hpp"

namespace ajar::daemon {

struct RunOptions {
  std::string port_file;                  // written (atomically) once serving; "" = none
  std::function<Config()> reload_config;  // for SIGHUP; empty = SIGHUP only logs
  std::function<std::unique_ptr<Engine>(const Config&)> make_engine;  // empty = make_engine()
};

// Returns kExitOk after a clean shutdown, kExitStartup when start-up failed (logged).
int run_daemon(const Config& config, const RunOptions& options);

// Writes `text` to `path` atomically (temporary file in the same directory, fsync, rename).
// Throws StartupError naming the file.
void write_file_atomically(const std::string& path, const std::string& text);

}  // namespace ajar::daemon
