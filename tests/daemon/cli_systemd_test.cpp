// systemd integration: sd_notify messages reach NOTIFY_SOCKET; the watchdog interval is half of
// WATCHDOG_USEC; the unit file verifies and its sandbox keeps the exposure rating at 2.0 or less.
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "ajar/daemon/logging.hpp"
#include "ajar/daemon/systemd_notify.hpp"
#include "fake_door.hpp"

namespace ajar::daemon {
namespace {

std::string run(const std::string& command, int* status) {
  std::string output;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return output;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe) != nullptr)
    output += buffer;
  const int rc = ::pclose(pipe);
  *status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  return output;
}

bool have_systemd_analyze() {
  return std::system("command -v systemd-analyze > /dev/null 2>&1") == 0;
}

TEST(SystemdNotifier, SendsReadyWatchdogStatusAndStoppingToTheNotifySocket) {
  ajar::testing::TempDir dir;
  const std::string socket_path = dir.path() + "/notify";
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  ASSERT_LT(socket_path.size(), sizeof(address.sun_path));
  std::copy(socket_path.begin(), socket_path.end(), address.sun_path);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);
  timeval timeout{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));

  ::setenv("NOTIFY_SOCKET", socket_path.c_str(), 1);
  SystemdNotifier notifier;
  EXPECT_TRUE(notifier.enabled());
  auto receive = [&] {
    char buffer[512] = {};
    const ssize_t n = ::recv(fd, buffer, sizeof(buffer) - 1, 0);
    return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
  };
  notifier.ready("serving on 127.0.0.1:7450");
  EXPECT_EQ(receive(), "READY=1\nSTATUS=serving on 127.0.0.1:7450");
  notifier.watchdog();
  EXPECT_EQ(receive(), "WATCHDOG=1");
  notifier.status("control loop stalled");
  EXPECT_EQ(receive(), "STATUS=control loop stalled");
  notifier.stopping("stopping (SIGTERM)");
  EXPECT_EQ(receive(), "STOPPING=1\nSTATUS=stopping (SIGTERM)");
  ::unsetenv("NOTIFY_SOCKET");
  ::close(fd);
  EXPECT_FALSE(notifier.enabled());
}

TEST(SystemdNotifier, WatchdogIntervalIsHalfOfWatchdogUsecForThisProcess) {
  ::unsetenv("WATCHDOG_USEC");
  SystemdNotifier notifier;
  EXPECT_FALSE(notifier.watchdog_interval());
  ::setenv("WATCHDOG_USEC", "2000000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);
  ASSERT_TRUE(notifier.watchdog_interval());
  EXPECT_EQ(notifier.watchdog_interval()->count(), 1'000'000);
  ::setenv("WATCHDOG_PID", "1", 1);  // meant for another process
  EXPECT_FALSE(notifier.watchdog_interval());
  ::unsetenv("WATCHDOG_USEC");
  ::unsetenv("WATCHDOG_PID");
}

TEST(Logging, SinkFollowsTheConfigAndTheSystemdEnvironment) {
  ::unsetenv("JOURNAL_STREAM");
  ::unsetenv("INVOCATION_ID");
  EXPECT_EQ(choose_log_sink(LogSink::kAuto), LogSink::kStderr);
  EXPECT_EQ(choose_log_sink(LogSink::kJournald), LogSink::kJournald);
  ::setenv("INVOCATION_ID", "0123456789abcdef0123456789abcdef", 1);
  EXPECT_EQ(choose_log_sink(LogSink::kAuto), LogSink::kJournald);
  EXPECT_EQ(choose_log_sink(LogSink::kStderr), LogSink::kStderr);
  ::unsetenv("INVOCATION_ID");
  ::setenv("JOURNAL_STREAM", "8:12345", 1);
  EXPECT_EQ(choose_log_sink(LogSink::kAuto), LogSink::kJournald);
  ::unsetenv("JOURNAL_STREAM");
}

TEST(SystemdUnit, VerifiesAndItsSandboxExposureIsAtMostTwo) {
  if (!have_systemd_analyze()) GTEST_SKIP() << "systemd-analyze not installed";
  const std::string unit = AJAR_SOURCE_DIR "/systemd/ajard.service";
  // verify needs the ExecStart binary to exist: point it at the built ajard.
  ajar::testing::TempDir dir;
  std::ifstream in(unit);
  std::stringstream text;
  text << in.rdbuf();
  const std::string patched =
      std::regex_replace(text.str(), std::regex("/usr/s?bin/ajard"), std::string(AJARD_PATH));
  const std::string copy = dir.path() + "/ajard.service";
  std::ofstream(copy) << patched;
  int status = 0;
  // --man=no: the man pages the unit names are checked where they are installed
  // (tests/package/deb_test.sh verifies the installed unit in full).
  const std::string verify = run("systemd-analyze verify --man=no " + copy, &status);
  EXPECT_EQ(status, 0) << verify;

  const std::string security = run("systemd-analyze security --offline=yes " + unit, &status);
  std::smatch match;
  ASSERT_TRUE(std::regex_search(
      security, match, std::regex(R"(Overall exposure level for ajard\.service: ([0-9.]+))")))
      << security;
  EXPECT_LE(std::stod(match[1].str()), 2.0) << security;
  // Still allows what the control loop needs.
  EXPECT_NE(text.str().find("LimitRTPRIO="), std::string::npos);
  EXPECT_NE(text.str().find("LimitMEMLOCK=infinity"), std::string::npos);
  EXPECT_NE(text.str().find("RestrictRealtime=no"), std::string::npos);
  EXPECT_NE(text.str().find("Type=notify"), std::string::npos);
  EXPECT_NE(text.str().find("WatchdogSec="), std::string::npos);
}

}  // namespace
}  // namespace ajar::daemon
