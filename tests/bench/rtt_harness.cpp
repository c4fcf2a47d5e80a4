// Round trip: one client's Ping -> Pong through ajard vs the same client against a minimal echo
// server answering every Ping with a Pong frame of the same size (decode, encode, write: the wire
// and kernel cost without the daemon). Interleaved (ajard, echo, ajard, ...) so both see the same
// machine load. Then the same client's Ping while a second client, the controller, sends
// commands back to back (MeasureDoorWidth, MeasureHandle, Reset with clear_parameters: every one
// persisted), vs idle.
#include <netinet/in.h>
#include <sys/socket.h>

#include <atomic>

#include "harness.hpp"

namespace ajar::bench {
namespace {

using namespace protocol;

core::FramedPoint base_point(double x, double y, double z) {
  return core::FramedPoint{core::Frame::kBase, core::Vec3(x, y, z)};
}

// A one-connection echo server on 127.0.0.1:<port()>: Ping in, Pong of the same size out.
class EchoServer {
 public:
  EchoServer() {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listen_fd_, 4) != 0)
      fail("echo server: bind/listen");
    socklen_t len = sizeof a;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] { serve(); });
  }
  ~EchoServer() {
    ::shutdown(listen_fd_, SHUT_RDWR);
    ::close(listen_fd_);
    if (thread_.joinable()) thread_.join();
  }
  std::uint16_t port() const { return port_; }

 private:
  void serve() {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) return;
    Conn c = Conn::adopt(fd);
    for (;;) {
      auto e = c.receive(-1);
      if (!e) return;
      if (const auto* ping = std::get_if<Ping>(&e->message))
        c.send(Envelope{e->request_id, 0, Pong{ping->client_time_ns, 0}});
    }
  }
  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
  std::thread thread_;
};

std::int64_t ping_once(Conn& c) {
  const std::int64_t t0 = now_ns();
  const auto reply = c.request(Ping{static_cast<std::uint64_t>(t0)});
  const std::int64_t t1 = now_ns();
  if (!std::holds_alternative<Pong>(reply)) fail("Ping not answered with Pong");
  return t1 - t0;
}

void report(const std::string& what, const ajar::bench::Quantiles& q,
            const ajar::bench::Quantiles& base, const std::string& base_name,
            const std::string& target) {
  row(what + " p50", q.p50 / 1e3, "us", base.p50 / 1e3, "", "vs " + base_name);
  row(what + " p99", q.p99 / 1e3, "us", base.p99 / 1e3, target, "vs " + base_name);
  row(what + " p99.9", q.p999 / 1e3, "us", base.p999 / 1e3, "", "vs " + base_name);
}

}  // namespace
}  // namespace ajar::bench

int main(int argc, char** argv) {
  using namespace ajar::bench;
  using namespace ajar::protocol;
  const Options o = Options::parse(argc, argv);
  if (o.ajard.empty() || o.config.empty()) fail("--ajard and --config are required");
  const int n = o.smoke ? 200 : 20000;

  Daemon daemon(o.ajard, o.config, o.dir + "/rtt");
  EchoServer echo;
  Conn to_daemon(daemon.port());
  (void)to_daemon.hello(Role::kObserver, "bench-rtt");
  Conn to_echo(echo.port());
  for (int i = 0; i < n / 10; ++i) {  // warm-up
    ping_once(to_daemon);
    ping_once(to_echo);
  }
  std::vector<std::int64_t> via_daemon, via_echo;
  for (int i = 0; i < n; ++i) {
    via_daemon.push_back(ping_once(to_daemon));
    via_echo.push_back(ping_once(to_echo));
  }
  const ajar::bench::Quantiles idle = quantiles(via_daemon);
  report("Ping RTT ajard", idle, quantiles(via_echo), "echo server", "<= 1.1x");

  // A controller sends commands back to back while the observer pings.
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> commands{0};
  std::thread controller([&] {
    Conn c(daemon.port());
    const auto welcome = c.hello(Role::kController, "bench-controller");
    if (welcome.granted_role != Role::kController) fail("controller role not granted");
    while (!stop.load()) {
      (void)c.request(Reset{true});
      (void)c.request(MeasureDoorWidth{base_point(1.5, 0.40, 1.0), base_point(1.5, -0.45, 1.0)});
      (void)c.request(MeasureHandle{base_point(1.45, -0.30, 1.0), base_point(1.45, -0.42, 1.0)});
      commands += 3;
    }
  });
  std::vector<std::int64_t> loaded;
  via_daemon.clear();
  for (int i = 0; i < n; ++i) {
    loaded.push_back(ping_once(to_daemon));
  }
  stop = true;
  controller.join();
  for (int i = 0; i < n; ++i)
    via_daemon.push_back(ping_once(to_daemon));
  const ajar::bench::Quantiles q = quantiles(loaded);
  const ajar::bench::Quantiles idle_after = quantiles(via_daemon);
  row("Ping RTT p99, controller sending commands", q.p99 / 1e3, "us", idle_after.p99 / 1e3,
      "<= 1.2x", "vs idle; " + std::to_string(commands.load()) + " commands meanwhile");
  row("Ping RTT p99.9, controller sending commands", q.p999 / 1e3, "us", idle_after.p999 / 1e3, "",
      "vs idle");
  return 0;
}
