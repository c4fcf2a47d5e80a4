// run_daemon: ajard's life after the command line. Start-up order: bind (fails fast on a busy port;
// not listening yet, so a connect is refused), engine.start() (drivers active, state restored, the
// run recorded on disk, control loop running), listen and serve (a TCP connect now means the daemon
// serves), write the port file, READY=1. Then the I/O thread runs the server, the engine's poll
// timer, signals and the systemd watchdog until SIGTERM/SIGINT:
//   SIGTERM/SIGINT  STOPPING=1, stop accepting, Engine::begin_shutdown() (stops motion); sessions
//                   are still served — Stop and EmergencyStop executed and acknowledged, the rest
//                   SHUTTING_DOWN — until the wheels rest (timer, at most 5 s); seal_state()
//                   (the clean-shutdown mark), send held replies, close sessions after their queued
//                   frames; await the last save (at most 5 s) and the sessions (at most 3 s) on
//                   timers; engine.shutdown() (threads joined, drivers down), exit code 0. The I/O
//                   thread never blocks before the sessions are gone;
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
