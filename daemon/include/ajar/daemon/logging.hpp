// Logging for ajard: spdlog, asynchronous (a bounded queue drained by one logging thread; when the
// queue is full the oldest line is dropped: no thread, and never the I/O thread, blocks on a log
// line). Sink: journald (with the priority of each line) when running under systemd — detected by
// JOURNAL_STREAM or INVOCATION_ID in the environment — else stderr; config.logging.sink forces one.
// The logger is spdlog's default logger ("ajard"), so daemon code logs with spdlog::info() etc.
#pragma once

#include "ajar/daemon/config.hpp"

namespace ajar::daemon {

// kAuto -> kJournald when JOURNAL_STREAM or INVOCATION_ID is set, else kStderr; kStderr and
// kJournald as configured. Never kAuto.
LogSink choose_log_sink(LogSink configured);

// Installs the asynchronous default logger. Call once at start-up, before any thread logs.
void init_logging(const LoggingConfig& config);
// Changes the level (kNone: nothing is logged).
void set_log_level(LogLevel level);
// Flushes and stops the logging thread. Call once at exit.
void shutdown_logging() noexcept;

}  // namespace ajar::daemon
