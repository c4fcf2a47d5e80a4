#include "ajar/daemon/systemd_notify.hpp"

#include <cstdint>
#include <cstdlib>
#include <string>

#include <systemd/sd-daemon.h>

namespace ajar::daemon {

bool SystemdNotifier::enabled() const {
  return std::getenv("NOTIFY_SOCKET") != nullptr;
}

void SystemdNotifier::notify(std::string_view state) {
  const std::string text(state);
  (void)sd_notify(0, text.c_str());
}

void SystemdNotifier::ready(std::string_view status) {
  notify("READY=1\nSTATUS=" + std::string(status));
}

void SystemdNotifier::stopping(std::string_view status) {
  notify("STOPPING=1\nSTATUS=" + std::string(status));
}

void SystemdNotifier::status(std::string_view status) {
  notify("STATUS=" + std::string(status));
}

void SystemdNotifier::watchdog() {
  notify("WATCHDOG=1");
}

std::optional<std::chrono::microseconds> SystemdNotifier::watchdog_interval() const {
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) <= 0 || usec == 0) return std::nullopt;
  return std::chrono::microseconds(static_cast<std::int64_t>(usec / 2));
}

}  // namespace ajar::daemon
