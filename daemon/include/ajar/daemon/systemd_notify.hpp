// systemd integration (Type=notify) through libsystemd's sd_notify(3). Every call is a no-op when
// the daemon does not run under systemd (NOTIFY_SOCKET unset).
//   READY=1     once the drivers are active and the socket listens;
//   WATCHDOG=1  at half of WATCHDOG_USEC, and only while the control loop is healthy: a stalled
//   loop
//               stops the petting and systemd restarts the daemon (WatchdogSec= in the unit);
//   STOPPING=1  when shutdown begins; STATUS=... human-readable lines for `systemctl status`.
#pragma once

#include <chrono>
#include <optional>
#include <string_view>

namespace ajar::daemon {

class SystemdNotifier {
 public:
  // True when NOTIFY_SOCKET is set (we run under systemd with Type=notify).
  bool enabled() const;
  void ready(std::string_view status);
  void stopping(std::string_view status);
  void status(std::string_view status);
  void watchdog();
  // Half of WATCHDOG_USEC when systemd expects watchdog pings for this process, else nullopt.
  std::optional<std::chrono::microseconds> watchdog_interval() const;

 private:
  void notify(std::string_view state);
};

}  // namespace ajar::daemon
