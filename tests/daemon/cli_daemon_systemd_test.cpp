// run_daemon under a fake systemd: READY=1 once serving (after the port file), WATCHDOG=1 only
// while the control loop is healthy, STOPPING=1 and exit 0 on SIGTERM. The stall is observed over
// the daemon's own watchdog checks (counted), not over a stretch of wall-clock time.
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <future>

#include <gtest/gtest.h>

#include "ajar/daemon/cli.hpp"
#include "ajar/daemon/daemon.hpp"
#include "ajard_process.hpp"
#include "fake_door.hpp"
#include "test_client.hpp"
#include "test_client_harness.hpp"

namespace ajar::test {
namespace {

class NotifySocket {
 public:
  explicit NotifySocket(const std::string& path)
      : fd_(::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0)) {
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::copy(path.begin(), path.end(), address.sun_path);
    bound_ = ::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
  }
  ~NotifySocket() { ::close(fd_); }
  bool bound() const { return bound_; }
  // The next datagram, or "" after `timeout`.
  std::string receive(std::chrono::milliseconds timeout) {
    timeval tv{static_cast<time_t>(timeout.count() / 1000),
               static_cast<suseconds_t>((timeout.count() % 1000) * 1000)};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
    char buffer[1024] = {};
    const ssize_t n = ::recv(fd_, buffer, sizeof(buffer) - 1, 0);
    return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
  }
  // Waits for a datagram containing `text`; false after `timeout`.
  bool wait_for(std::string_view text, std::chrono::milliseconds timeout = 20s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      if (receive(200ms).find(text) != std::string::npos) return true;
    }
    return false;
  }

 private:
  int fd_;
  bool bound_ = false;
};

TEST(DaemonUnderSystemd, ReadyAfterServingWatchdogOnlyWhileHealthyStoppingOnSigterm) {
  ajar::testing::TempDir dir;
  NotifySocket notify(dir.path() + "/notify");
  ASSERT_TRUE(notify.bound());
  ::setenv("NOTIFY_SOCKET", (dir.path() + "/notify").c_str(), 1);
  ::setenv("WATCHDOG_USEC", "200000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);

  FakeEngine fake_engine;
  FakeEngine* fake = &fake_engine;
  // In front of the fake: counts the daemon's watchdog checks (control_loop_healthy(), asked once
  // per watchdog tick and nowhere else in run_daemon).
  auto engine = FakeEngine::in_front_of(fake_engine);
  FakeEngine* counter = engine.get();
  daemon::Config config;
  config.network.bind_address = "127.0.0.1";
  config.network.port = 0;
  daemon::RunOptions options;
  options.port_file = dir.path() + "/port";
  options.make_engine = [&engine](const daemon::Config&) -> std::unique_ptr<daemon::Engine> {
    return std::move(engine);
  };
  auto exit_code =
      std::async(std::launch::async, [&] { return daemon::run_daemon(config, options); });

  ASSERT_TRUE(notify.wait_for("READY=1"));
  EXPECT_TRUE(std::filesystem::exists(options.port_file));  // READY comes after the port file
  ASSERT_TRUE(notify.wait_for("WATCHDOG=1"));
  ASSERT_TRUE(notify.wait_for("WATCHDOG=1"));

  fake->set_healthy(false);  // the control loop stalls
  ASSERT_TRUE(notify.wait_for("STATUS=control loop stalled"));
  // Six more checks while stalled, none of them pets (a pet follows its check at once, so after
  // the count is reached every pet it could have sent is already queued on the socket).
  const int stalled_at = counter->health_checks();
  const auto guard = std::chrono::steady_clock::now() + 20s;  // against hanging only
  while (counter->health_checks() < stalled_at + 6 && std::chrono::steady_clock::now() < guard) {
    EXPECT_EQ(notify.receive(20ms).find("WATCHDOG=1"), std::string::npos) << "petted while stalled";
  }
  ASSERT_GE(counter->health_checks(), stalled_at + 6)
      << "the daemon stopped checking the control loop";
  for (std::string left = notify.receive(1ms); !left.empty(); left = notify.receive(1ms)) {
    EXPECT_EQ(left.find("WATCHDOG=1"), std::string::npos) << "petted while stalled";
  }
  fake->set_healthy(true);
  EXPECT_TRUE(notify.wait_for("WATCHDOG=1"));

  // Still serving.
  const auto port = static_cast<std::uint16_t>(std::stoul(read_text_file(options.port_file)));
  TestClient client(port);
  EXPECT_EQ(client.hello(protocol::Role::kObserver).granted_role, protocol::Role::kObserver);

  ::kill(::getpid(), SIGTERM);
  EXPECT_TRUE(notify.wait_for("STOPPING=1"));
  ASSERT_EQ(exit_code.wait_for(30s), std::future_status::ready);
  EXPECT_EQ(exit_code.get(), daemon::kExitOk);
  EXPECT_TRUE(client.wait_closed());
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  ::unsetenv("WATCHDOG_PID");
}

}  // namespace
}  // namespace ajar::test
