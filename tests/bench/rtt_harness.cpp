// Round trips, each a baseline and a subject in alternating blocks within one run (harness.hpp:
// A B A B ..., the median of the block ratios, client and server threads pinned the same way):
// 1. one client's Ping -> Pong through ajard vs a minimal echo server answering every Ping with a
//    Pong (decode, encode, write: the wire and kernel cost without the daemon);
// 2. the same client's Ping while a second client, the controller, sends commands back to back
//    (Reset with clear_parameters, MeasureDoorWidth, MeasureHandle: every one persisted) vs the
//    controller paused;
// 3. a durable Ack (MeasureDoorWidth: the new state is saved before the Ack) vs the fsync floor:
//    the state store's save, syscall for syscall, in the same directory (target: Ack p50 <= floor
//    p50 + one loop period).
#include <netinet/in.h>
#include <sys/socket.h>

#include <atomic>
#include <memory>

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

std::vector<std::int64_t> ping_block(Conn& c, int n) {
  std::vector<std::int64_t> out;
  out.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    out.push_back(ping_once(c));
  return out;
}

// The state store's save, syscall for syscall (daemon/src/state_store.cpp save_file): open a
// temporary file, write `bytes`, fsync, close, rename over the file, open the directory, fsync
// it, close. Its duration is the floor of a durable Ack.
std::int64_t fsync_floor_once(const std::string& directory, std::size_t bytes) {
  static const std::string text(bytes, 'x');
  const std::string path = directory + "/floor", tmp = path + ".tmp";
  const std::int64_t t0 = now_ns();
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
  if (fd < 0 || ::write(fd, text.data(), text.size()) != static_cast<ssize_t>(text.size()) ||
      ::fsync(fd) != 0 || ::close(fd) != 0 || ::rename(tmp.c_str(), path.c_str()) != 0)
    fail("fsync floor: " + std::string(std::strerror(errno)));
  const int dir = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0 || ::fsync(dir) != 0 || ::close(dir) != 0)
    fail("fsync floor (directory): " + std::string(std::strerror(errno)));
  return now_ns() - t0;
}

// The largest file in the daemon's state directory (its state file), in bytes.
std::size_t state_file_bytes(const std::string& directory) {
  std::size_t largest = 0;
  for (const auto& f : std::filesystem::directory_iterator(directory))
    if (f.is_regular_file()) largest = std::max<std::size_t>(largest, f.file_size());
  return largest;
}

double loop_rate_hz(const std::string& config) {
  std::ifstream in(config);
  std::string line;
  while (std::getline(in, line))
    if (const auto at = line.find("rate_hz:"); at != std::string::npos)
      return std::strtod(line.c_str() + at + 8, nullptr);
  fail("no control.rate_hz in " + config);
}

// A controller that sends commands back to back while `active`, and says when it is paused.
class Controller {
 public:
  explicit Controller(std::uint16_t port) : conn_(port) {
    if (conn_.hello(Role::kController, "bench-controller").granted_role != Role::kController)
      fail("controller role not granted");
    thread_ = std::thread([this] { run(); });
  }
  ~Controller() {
    stop_ = true;
    thread_.join();
  }
  void set_active(bool on) {
    active_ = on;
    while (!on && busy_.load())
      std::this_thread::yield();  // the current command ends before a "controller off" block
  }
  std::uint64_t commands() const { return commands_.load(); }

 private:
  void run() {
    while (!stop_) {
      if (!active_) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
        continue;
      }
      busy_ = true;
      if (active_) {
        (void)conn_.request(Reset{true});
        (void)conn_.request(
            MeasureDoorWidth{base_point(1.5, 0.40, 1.0), base_point(1.5, -0.45, 1.0)});
        (void)conn_.request(
            MeasureHandle{base_point(1.45, -0.30, 1.0), base_point(1.45, -0.42, 1.0)});
        commands_ += 3;
      }
      busy_ = false;
    }
  }
  Conn conn_;
  std::thread thread_;
  std::atomic<bool> stop_{false}, active_{false}, busy_{false};
  std::atomic<std::uint64_t> commands_{0};
};

// 1. ajard vs the echo server: A (echo) B (ajard) A B ...
void rtt_vs_echo(Conn& to_daemon, Conn& to_echo, int blocks, int per_block) {
  SampleBlocks rtt;
  for (int b = 0; b < blocks; ++b) {
    auto base = ping_block(to_echo, per_block);
    auto subject = ping_block(to_daemon, per_block);
    rtt.add(base, subject);
  }
  latency_rows("Ping RTT ajard", rtt, "echo server", "<= 1.1x", "<= 1.1x");
}

// 2. The same client's Ping with the controller paused (A) and sending commands back to back
// (B), same daemon, same connections.
void rtt_with_controller(Conn& to_daemon, std::uint16_t port, int blocks, int per_block) {
  SampleBlocks loaded;
  std::uint64_t commands = 0;
  {
    Controller controller(port);
    for (int b = 0; b < blocks; ++b) {
      controller.set_active(false);
      auto base = ping_block(to_daemon, per_block);
      controller.set_active(true);
      std::this_thread::sleep_for(std::chrono::milliseconds(2));  // its first command is out
      auto subject = ping_block(to_daemon, per_block);
      loaded.add(base, subject);
    }
    controller.set_active(false);
    commands = controller.commands();
  }
  latency_rows("Ping RTT, controller sending commands", loaded, "controller paused", "", "<= 1.2x",
               true);
  info("Ping RTT with a controller: " + std::to_string(commands) +
       " commands (Reset, MeasureDoorWidth, MeasureHandle: each persisted) during the run");
}

// 3. A durable Ack (a command whose new state is saved before its Ack) vs the state store's
// save done by this harness in the same directory (the fsync floor): A (floor) B (command)...
// Target: Ack p50 <= floor p50 + one loop period. The floor's saves run on `server_cpu`.
void durable_ack_vs_fsync_floor(const Options& o, std::uint16_t port, int server_cpu, int blocks) {
  using namespace ajar::protocol;
  Conn c(port);
  if (c.hello(Role::kController, "bench-durable").granted_role != Role::kController)
    fail("controller role not granted");
  (void)c.request(Reset{true});
  (void)c.request(MeasureDoorWidth{base_point(1.5, 0.40, 1.0), base_point(1.5, -0.44, 1.0)});
  const std::size_t bytes = std::max<std::size_t>(state_file_bytes(o.dir + "/rtt/state"), 64);
  // A sibling of the daemon's state directory: the same file system, not the daemon's files.
  const std::string state_dir = o.dir + "/rtt/floor";
  std::filesystem::create_directories(state_dir);
  const double period_us = 1e6 / loop_rate_hz(o.config);
  const int per = o.smoke ? 5 : 40;
  SampleBlocks ack;
  Paired budget;  // per block: Ack p50 vs floor p50 + one loop period
  int i = 0;
  for (int b = 0; b < blocks; ++b) {
    std::vector<std::int64_t> floor, acks;
    created_on(server_cpu, [&] {
      for (int k = 0; k < per; ++k)
        floor.push_back(fsync_floor_once(state_dir, bytes));
      return 0;
    });
    for (int k = 0; k < per; ++k, ++i) {
      // Alternating widths: each one is a new accepted state, hence saved before its Ack.
      const double y = i % 2 ? -0.45 : -0.46;
      const std::int64_t t0 = now_ns();
      const auto reply =
          c.request(MeasureDoorWidth{base_point(1.5, 0.40, 1.0), base_point(1.5, y, 1.0)});
      acks.push_back(now_ns() - t0);
      if (!std::holds_alternative<Ack>(reply)) fail("MeasureDoorWidth not acknowledged");
    }
    ack.add(floor, acks);
    budget.add(ack.p50.base.back() + period_us, ack.p50.subject.back());
  }
  compare_row("durable Ack p50 (MeasureDoorWidth, saved)", ack.p50, "us", "",
              "vs the fsync floor: the state store's save, same directory, same run");
  compare_row("durable Ack p50 vs fsync floor + one loop period", budget, "us", "<= 1x",
              "baseline = floor p50 + " + format_number(period_us) + " us, per block");
  compare_row("durable Ack min", ack.min, "us", "", "vs the fsync floor's min", Over::kMin);
  compare_row("durable Ack p99", ack.p99, "us", "", "vs the fsync floor's p99");
  info("durable Ack: " + std::to_string(bytes) + "-byte saves in " + state_dir + "; " +
       std::to_string(per) + " per block and side");
}

}  // namespace
}  // namespace ajar::bench

int main(int argc, char** argv) {
  using namespace ajar::bench;
  using namespace ajar::protocol;
  const Options o = Options::parse(argc, argv);
  if (o.ajard.empty() || o.config.empty()) fail("--ajard and --config are required");
  const int blocks = o.smoke ? 3 : 2 * kMinBlocks;
  const int per_block = o.smoke ? 50 : 1000;
  const Placement where = placement();
  pin_this_thread(where.client);  // this thread and the controller's
  info("Ping RTT: " + where.describe() + "; " + std::to_string(blocks) + " blocks of " +
       std::to_string(per_block) + " per side, alternating; load average " + load_average() +
       " at start");

  Daemon daemon(o.ajard, o.config, o.dir + "/rtt", where.server);
  auto echo = created_on(where.server, [] { return std::make_unique<EchoServer>(); });
  Conn to_daemon(daemon.port());
  (void)to_daemon.hello(Role::kObserver, "bench-rtt");
  Conn to_echo(echo->port());
  (void)ping_block(to_daemon, per_block);  // warm-up
  (void)ping_block(to_echo, per_block);

  rtt_vs_echo(to_daemon, to_echo, blocks, per_block);
  to_echo.close();  // the echo thread sees EOF and returns
  echo.reset();
  rtt_with_controller(to_daemon, daemon.port(), blocks, per_block);
  durable_ack_vs_fsync_floor(o, daemon.port(), where.server, blocks);
  info("Ping RTT: load average " + load_average() + " at the end");
  return 0;
}
