// Logging for ajard: spdlog, asynchronous (a bounded queue drained by one logging thread; when the
// queue is full the oldest line is dropped: no thread, and never the I/O thread, blocks on a log
// line). Sink: journald (with the priority of each line) when running under systemd — detected by
// JOURNAL_STREAM or INVOCATION_ID in the environment — else stderr; config.logging.sink forces one.
// The logger is spdlog's default logger ("ajard"), so daemon code logs with spdlog::info() etc.
#pragma once

#include <string>
#include <string_view>

namespace ajar::daemon {

struct LoggingConfig;

enum class LogSink { kStderr, kJournald };

// "auto" -> journald when JOURNAL_STREAM or INVOCATION_ID is set, else stderr; "stderr",
// "journald" as named. Unknown values: stderr.
LogSink choose_log_sink(std::string_view configured);
std::string_view to_string(LogSink sink) noexcept;

// Installs the asynchronous default logger. Call once at start-up, before any thread logs.
void init_logging(const LoggingConfig& config);
// Changes the level ("trace" ... "off"). False (and no change) for an unknown level.
bool set_log_level(std::string_view level);
// Flushes and stops the logging thread. Call once at exit.
void shutdown_logging() noexcept;

}  // namespace ajar::daemon
