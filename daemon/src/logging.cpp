#include "ajar/daemon/logging.hpp"

#include <cstdlib>
#include <memory>

#include <spdlog/async.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/sinks/systemd_sink.h>
#include <spdlog/spdlog.h>

namespace ajar::daemon {
namespace {

// Each queued line costs ~400 bytes, allocated and touched at start (8192 lines were 3.2 MiB, a
// quarter of the daemon's resident memory). The daemon logs at most a few lines per event; a
// burst beyond the queue drops the oldest lines (overrun_oldest), it never blocks a thread.
constexpr std::size_t kQueueLines = 512;

spdlog::level::level_enum spdlog_level(LogLevel level) noexcept {
  switch (level) {
    case LogLevel::kTrace:
      return spdlog::level::trace;
    case LogLevel::kDebug:
      return spdlog::level::debug;
    case LogLevel::kInfo:
      return spdlog::level::info;
    case LogLevel::kWarn:
      return spdlog::level::warn;
    case LogLevel::kError:
      return spdlog::level::err;
    case LogLevel::kCritical:
      return spdlog::level::critical;
    case LogLevel::kNone:
      return spdlog::level::off;
  }
  return spdlog::level::info;
}

}  // namespace

LogSink choose_log_sink(LogSink configured) {
  if (configured != LogSink::kAuto) return configured;
  const bool under_systemd =
      std::getenv("JOURNAL_STREAM") != nullptr || std::getenv("INVOCATION_ID") != nullptr;
  return under_systemd ? LogSink::kJournald : LogSink::kStderr;
}

void init_logging(const LoggingConfig& config) {
  spdlog::init_thread_pool(kQueueLines, 1);
  spdlog::sink_ptr sink;
  const LogSink kind = choose_log_sink(config.sink);
  if (kind == LogSink::kJournald) {
    // journald stamps time, priority and the identifier itself.
    sink = std::make_shared<spdlog::sinks::systemd_sink_mt>("ajard");
  } else {
    sink = std::make_shared<spdlog::sinks::stderr_sink_mt>();
    sink->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  }
  auto logger = std::make_shared<spdlog::async_logger>(
      "ajard", sink, spdlog::thread_pool(), spdlog::async_overflow_policy::overrun_oldest);
  logger->set_level(spdlog_level(config.level));
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(std::move(logger));
}

void set_log_level(LogLevel level) {
  spdlog::default_logger()->set_level(spdlog_level(level));
}

void shutdown_logging() noexcept {
  try {
    // Keep the logger alive until the logging thread has drained the queue and been joined, so
    // that it is destroyed on this thread (the worker drops its references inside libspdlog).
    const auto logger = spdlog::default_logger();
    spdlog::shutdown();
  } catch (...) {
  }
}

}  // namespace ajar::daemon
