#include "ajar/daemon/logging.hpp"

#include <cstdlib>
#include <memory>

#include <spdlog/async.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/sinks/systemd_sink.h>
#include <spdlog/spdlog.h>

#include "ajar/daemon/config.hpp"

namespace ajar::daemon {
namespace {

constexpr std::size_t kQueueLines = 8192;

bool parse_level(std::string_view text, spdlog::level::level_enum& level) {
  static constexpr std::string_view kNames[] = {"trace", "debug",    "info", "warn",
                                                "error", "critical", "off"};
  for (int i = 0; i < 7; ++i) {
    if (text == kNames[i]) {
      level = static_cast<spdlog::level::level_enum>(i);
      return true;
    }
  }
  return false;
}

}  // namespace

LogSink choose_log_sink(std::string_view configured) {
  if (configured == "journald") return LogSink::kJournald;
  if (configured == "stderr") return LogSink::kStderr;
  if (configured == "auto" &&
      (std::getenv("JOURNAL_STREAM") != nullptr || std::getenv("INVOCATION_ID") != nullptr)) {
    return LogSink::kJournald;
  }
  return LogSink::kStderr;
}

std::string_view to_string(LogSink sink) noexcept {
  return sink == LogSink::kJournald ? "journald" : "stderr";
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
  spdlog::level::level_enum level = spdlog::level::info;
  parse_level(config.level, level);
  logger->set_level(level);
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(std::move(logger));
}

bool set_log_level(std::string_view level) {
  spdlog::level::level_enum parsed = spdlog::level::info;
  if (!parse_level(level, parsed)) return false;
  spdlog::default_logger()->set_level(parsed);
  return true;
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
