// ajar_bench_ping_under_load: does a controller's persisted commands slow down everybody else?
// (issue 10: persistence off the I/O thread.) In process: the real Server and engine on mock
// drivers, a state directory in $TMPDIR. An observer measures Ping round trips (one at a time,
// every
// `--interval-ms`) twice: alone, and while a controller sends a state-changing command (a door
// width, saved to disk) every 10 ms. Both with the state store as it is and with every save slowed
// by `--slow-ms` (the store's test hook: models robot flash). Prints one table; docs/performance.md
// records the figures. Not a test: nothing is asserted.
//   ajar_bench_ping_under_load [--samples N] [--interval-ms MS] [--slow-ms MS] [--smoke]
#include <utility>  // before Asio (asio issue 944)

#include <poll.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/connect.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/logging.hpp"
#include "ajar/daemon/server.hpp"
#include "ajar/protocol/codec.hpp"
#include "fake_door.hpp"

namespace {

namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

// A blocking client: one request at a time.
class Peer {
 public:
  explicit Peer(std::uint16_t port) : socket_(io_) {
    socket_.connect({asio::ip::make_address("127.0.0.1"), port});
    socket_.set_option(asio::ip::tcp::no_delay(true));
  }
  // Sends and waits for the reply with this id (events and telemetry skipped). False on failure.
  bool request(const ajar::protocol::Message& m, ajar::protocol::Message* reply = nullptr) {
    const std::uint32_t id = ++last_id_;
    std::vector<std::uint8_t> bytes;
    if (!ajar::protocol::encode_append(ajar::protocol::Envelope{id, 0, m}, bytes)) return false;
    boost::system::error_code ec;
    asio::write(socket_, asio::buffer(bytes), ec);
    if (ec) return false;
    const auto deadline = Clock::now() + 10s;
    ajar::protocol::StreamDecoder::Outcome outcome;
    for (;;) {
      while (offset_ < pending_.size()) {
        const std::size_t used = decoder_.feed(
            std::span<const std::uint8_t>(pending_.data() + offset_, pending_.size() - offset_),
            outcome);
        offset_ += used;
        if (outcome.kind == ajar::protocol::StreamDecoder::Kind::kMessage &&
            outcome.envelope.request_id == id) {
          if (reply) *reply = outcome.envelope.message;
          return true;
        }
        if (outcome.kind == ajar::protocol::StreamDecoder::Kind::kNeedMore && used == 0) break;
      }
      pending_.clear();
      offset_ = 0;
      if (Clock::now() > deadline) return false;
      pollfd p{socket_.native_handle(), POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      std::array<std::uint8_t, 8192> buffer{};
      const std::size_t n = socket_.read_some(asio::buffer(buffer), ec);
      if (ec) return false;
      pending_.assign(buffer.begin(), buffer.begin() + static_cast<long>(n));
    }
  }

 private:
  asio::io_context io_;
  asio::ip::tcp::socket socket_;
  ajar::protocol::StreamDecoder decoder_;
  std::vector<std::uint8_t> pending_;
  std::size_t offset_ = 0;
  std::uint32_t last_id_ = 0;
};

ajar::protocol::Hello hello(ajar::protocol::Role role) {
  ajar::protocol::Hello h;
  h.requested_role = role;
  h.client_name = "bench";
  return h;
}

struct Figures {
  double p50_us = 0, p99_us = 0, max_us = 0;
  std::size_t samples = 0;
  std::size_t commands = 0;  // controller commands acknowledged meanwhile
};

double percentile(std::vector<double>& v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(rank, v.size() - 1)];
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

// One run: a fresh daemon; the observer pings `samples` times; with `load`, a controller sends a
// door width every 10 ms meanwhile (alternating two widths: each one is a new accepted state).
Figures run(int slow_ms, bool load, int samples, int interval_ms) {
  ajar::testing::TempDir dir;
  ajar::daemon::Config config = ajar::daemon::load_config(AJAR_SOURCE_DIR "/config/ajard.yaml");
  config.drivers.kind = ajar::drivers::DriverKind::kMock;
  config.camera_to_base_m = ajar::testing::forward_camera_to_base_m();
  config.state.directory = dir.path() + "/state";
  config.recorder.directory = dir.path() + "/recordings";
  config.state.debug_write_delay_ms = slow_ms;
  config.network.bind_address = "127.0.0.1";
  config.network.port = 0;
  auto engine = ajar::daemon::make_engine(config);
  asio::io_context io{1};
  ajar::daemon::Server server(io, *engine, ajar::daemon::ServerOptions::from(config.network));
  const std::uint16_t port = server.bind();
  engine->start();
  server.start();
  std::thread io_thread([&] { io.run(); });

  Figures f;
  {
    Peer observer(port);
    observer.request(hello(ajar::protocol::Role::kObserver));
    std::atomic<bool> done{false};
    std::atomic<std::size_t> commands{0};
    std::thread controller_thread;
    if (load) {
      controller_thread = std::thread([&] {
        Peer controller(port);
        controller.request(hello(ajar::protocol::Role::kController));
        auto next = Clock::now();
        for (int i = 0; !done.load(); ++i) {
          auto width = ajar::testing::good_width();
          width.p2_moving_edge.position_m.y() -= (i % 2) * 0.01;
          ajar::protocol::Message reply;
          if (controller.request(width, &reply) &&
              std::holds_alternative<ajar::protocol::Ack>(reply))
            ++commands;
          next += 10ms;
          std::this_thread::sleep_until(next);
          if (Clock::now() > next + 100ms) next = Clock::now();  // a slow save: no burst after
        }
      });
      std::this_thread::sleep_for(200ms);  // the load is running
    }
    std::vector<double> rtts_us;
    for (int i = 0; i < samples; ++i) {
      const auto sent = Clock::now();
      if (!observer.request(ajar::protocol::Ping{})) break;
      rtts_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - sent).count());
      std::this_thread::sleep_for(std::chrono::milliseconds(interval_ms));
    }
    done = true;
    if (controller_thread.joinable()) controller_thread.join();
    f.samples = rtts_us.size();
    f.commands = commands.load();
    f.p50_us = percentile(rtts_us, 0.50);
    f.p99_us = percentile(rtts_us, 0.99);
    f.max_us = rtts_us.empty() ? 0 : rtts_us.back();
  }
  asio::post(io, [&] {
    server.stop_accepting();
    engine->shutdown();
    server.stop();
  });
  io_thread.join();
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  int samples = 3000;
  int interval_ms = 1;
  int slow_ms = 50;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--smoke") {
      samples = 200;
    } else if (a == "--samples" && i + 1 < argc) {
      samples = std::stoi(argv[++i]);
    } else if (a == "--interval-ms" && i + 1 < argc) {
      interval_ms = std::stoi(argv[++i]);
    } else if (a == "--slow-ms" && i + 1 < argc) {
      slow_ms = std::stoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--samples N] [--interval-ms MS] [--slow-ms MS] [--smoke]\n",
                   argv[0]);
      return 2;
    }
  }
  ajar::daemon::LoggingConfig quiet;
  quiet.level = ajar::daemon::LogLevel::kNone;
  quiet.sink = ajar::daemon::LogSink::kStderr;
  ajar::daemon::init_logging(quiet);

  std::printf(
      "# Ping RTT of an observer, %d samples every %d ms; load: a controller command "
      "(persisted) every 10 ms\n",
      samples, interval_ms);
  std::printf("# load average before: %s; hardware threads: %u\n", load_average().c_str(),
              std::thread::hardware_concurrency());
  std::printf("%-28s %8s %10s %10s %10s %9s %10s\n", "condition", "samples", "p50_us", "p99_us",
              "max_us", "commands", "p99/alone");
  for (const int slow : {0, slow_ms}) {
    const Figures alone = run(slow, false, samples, interval_ms);
    const Figures loaded = run(slow, true, samples, interval_ms);
    const std::string disk = slow == 0 ? "normal disk" : "fsync +" + std::to_string(slow) + " ms";
    std::printf("%-28s %8zu %10.1f %10.1f %10.1f %9s %10s\n", (disk + ", alone").c_str(),
                alone.samples, alone.p50_us, alone.p99_us, alone.max_us, "-", "1.00");
    std::printf("%-28s %8zu %10.1f %10.1f %10.1f %9zu %10.2f\n", (disk + ", controller").c_str(),
                loaded.samples, loaded.p50_us, loaded.p99_us, loaded.max_us, loaded.commands,
                alone.p99_us > 0 ? loaded.p99_us / alone.p99_us : 0.0);
  }
  std::printf("# load average after: %s\n", load_average().c_str());
  ajar::daemon::shutdown_logging();
  return 0;
}
