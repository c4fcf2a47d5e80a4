// ajar_bench_ping_under_load: do a controller's persisted commands slow down everybody else?
// (issue 10: persistence off the I/O thread.) In process: the real Server and engine on mock
// drivers, a state directory in $TMPDIR. An observer measures Ping round trips (one at a time,
// every `--interval-ms`) in alternating blocks (harness.hpp): the controller paused, and the
// controller sending a state-changing command (a door width, saved before its Ack) every 10 ms.
// With the state store as it is and with every save slowed by `--slow-ms` (the store's test hook:
// models robot flash). Prints ROW lines for scripts/bench's table. Nothing is asserted.
//   ajar_bench_ping_under_load [--blocks N] [--per-block N] [--interval-ms MS] [--slow-ms MS]
//                              [--smoke]
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
#include "harness.hpp"

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

// The controller: while active, a door width every 10 ms (two widths alternating: each one is a
// new accepted state, saved before its Ack); set_active(false) returns once the command under way
// was answered. Its thread runs from construction to destruction.
class WidthController {
 public:
  explicit WidthController(std::uint16_t port) : thread_([this, port] { run(port); }) {}
  ~WidthController() {
    done_ = true;
    thread_.join();
  }
  void set_active(bool on) {
    active_ = on;
    while (!on && busy_.load())
      std::this_thread::sleep_for(100us);  // a "controller paused" block starts after its Ack
  }
  std::size_t commands() const { return commands_.load(); }  // the widths acknowledged

 private:
  void run(std::uint16_t port) {
    Peer controller(port);
    controller.request(hello(ajar::protocol::Role::kController));
    auto next = Clock::now();
    for (int i = 0; !done_.load(); ++i) {
      if (!active_) {
        std::this_thread::sleep_for(1ms);
        next = Clock::now();
        continue;
      }
      busy_ = true;
      if (active_) {
        auto width = ajar::testing::good_width();
        width.p2_moving_edge.position_m.y() -= (i % 2) * 0.01;
        ajar::protocol::Message reply;
        if (controller.request(width, &reply) && std::holds_alternative<ajar::protocol::Ack>(reply))
          ++commands_;
      }
      busy_ = false;
      next += 10ms;
      std::this_thread::sleep_until(next);
      if (Clock::now() > next + 100ms) next = Clock::now();  // a slow save: no burst after
    }
  }

  std::atomic<bool> done_{false}, active_{false}, busy_{false};
  std::atomic<std::size_t> commands_{0};
  std::thread thread_;  // last: it starts once the flags above exist
};

// `per_block` Pings of the observer, one every `interval_ms`: their round trips.
std::vector<std::int64_t> ping_block(Peer& observer, int per_block, int interval_ms) {
  std::vector<std::int64_t> out;
  for (int i = 0; i < per_block; ++i) {
    const auto sent = Clock::now();
    if (!observer.request(ajar::protocol::Ping{})) ajar::bench::fail("Ping not answered");
    out.push_back(
        std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - sent).count());
    std::this_thread::sleep_for(std::chrono::milliseconds(interval_ms));
  }
  return out;
}

// The shipped config on mock drivers, its state and recordings in `dir`, every save `slow_ms`
// slower, on 127.0.0.1 at any free port.
ajar::daemon::Config bench_config(const ajar::testing::TempDir& dir, int slow_ms) {
  ajar::daemon::Config config = ajar::daemon::load_config(AJAR_SOURCE_DIR "/config/ajard.yaml");
  config.drivers.kind = ajar::drivers::DriverKind::kMock;
  config.camera_to_base_m = ajar::testing::forward_camera_to_base_m();
  config.state.directory = dir.path() + "/state";
  config.recorder.directory = dir.path() + "/recordings";
  config.state.debug_write_delay_ms = slow_ms;
  config.network.bind_address = "127.0.0.1";
  config.network.port = 0;
  return config;
}

// One disk setting: a fresh daemon; an observer pings in blocks of `per_block` (one every
// `interval_ms`), alternately with the controller paused (A) and sending a door width every 10 ms
// (B; alternating two widths: each one is a new accepted state, saved before its Ack).
void run(int slow_ms, int blocks, int per_block, int interval_ms,
         const ajar::bench::Placement& where) {
  ajar::testing::TempDir dir;
  const ajar::daemon::Config config = bench_config(dir, slow_ms);
  // The daemon's threads (I/O, control, state writer) on the server CPU; the clients on the other.
  ajar::bench::pin_this_thread(where.server);
  auto engine = ajar::daemon::make_engine(config);
  asio::io_context io{1};
  ajar::daemon::Server server(io, *engine, ajar::daemon::ServerOptions::from(config.network));
  const std::uint16_t port = server.bind();
  engine->start();
  server.start();
  std::thread io_thread([&] { io.run(); });
  ajar::bench::pin_this_thread(where.client);

  ajar::bench::SampleBlocks b;
  std::size_t commands = 0;
  {
    Peer observer(port);
    observer.request(hello(ajar::protocol::Role::kObserver));
    WidthController controller(port);
    for (int k = 0; k < blocks; ++k) {
      controller.set_active(false);
      auto base = ping_block(observer, per_block, interval_ms);
      controller.set_active(true);
      std::this_thread::sleep_for(20ms);  // the controller's commands are flowing
      auto subject = ping_block(observer, per_block, interval_ms);
      b.add(base, subject);
    }
    controller.set_active(false);
    commands = controller.commands();
  }
  const std::string disk =
      slow_ms == 0 ? "normal disk" : "fsync +" + std::to_string(slow_ms) + " ms";
  ajar::bench::latency_rows("another client's Ping, controller commanding (" + disk + ")", b,
                            "controller paused", "", "<= 1.2x", true);
  ajar::bench::info("ping under load (" + disk + "): " + std::to_string(commands) +
                    " controller commands acknowledged (each saved before its Ack)");
  asio::post(io, [&] {
    server.stop_accepting();
    engine->shutdown();
    server.stop();
  });
  io_thread.join();
}

}  // namespace

int main(int argc, char** argv) {
  int blocks = 2 * ajar::bench::kMinBlocks;
  int per_block = 200;
  int interval_ms = 1;
  int slow_ms = 50;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--smoke") {
      blocks = 3;
      per_block = 30;
    } else if (a == "--blocks" && i + 1 < argc) {
      blocks = std::stoi(argv[++i]);
    } else if (a == "--per-block" && i + 1 < argc) {
      per_block = std::stoi(argv[++i]);
    } else if (a == "--interval-ms" && i + 1 < argc) {
      interval_ms = std::stoi(argv[++i]);
    } else if (a == "--slow-ms" && i + 1 < argc) {
      slow_ms = std::stoi(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: %s [--blocks N] [--per-block N] [--interval-ms MS] [--slow-ms MS] "
                   "[--smoke]\n",
                   argv[0]);
      return 2;
    }
  }
  ajar::daemon::LoggingConfig quiet;
  quiet.level = ajar::daemon::LogLevel::kNone;
  quiet.sink = ajar::daemon::LogSink::kStderr;
  ajar::daemon::init_logging(quiet);
  const ajar::bench::Placement where = ajar::bench::placement();
  ajar::bench::info("ping under load: an observer's Ping, " + std::to_string(blocks) +
                    " blocks of " + std::to_string(per_block) + " (one every " +
                    std::to_string(interval_ms) +
                    " ms) per side: controller paused / a door width every 10 ms; " +
                    where.describe() + "; load average " + ajar::bench::load_average());
  for (const int slow : {0, slow_ms})
    run(slow, blocks, per_block, interval_ms, where);
  ajar::bench::info("ping under load: load average " + ajar::bench::load_average() + " at the end");
  ajar::daemon::shutdown_logging();
  return 0;
}
