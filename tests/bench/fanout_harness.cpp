// Fan-out: 256 observers subscribed to telemetry at 100 Hz while a controller runs the procedure
// and AlignBase over and over, in blocks within one run (harness.hpp; one daemon, one bare
// fan-out server, both started once, pinned the same way): idle (ajard with its sessions but
// nobody subscribed, the controller paused; the bare server paused), loaded (every observer
// subscribed, the controller aligning), bare (the bare server writing the same Telemetry frame to
// 256 sockets every 10 ms, ajard idle). Per cycle: the loop's wake-up latency loaded vs idle
// (ResetLoopStatistics at each block's start, Status at its end), the telemetry inter-arrival at
// the observers loaded vs bare; sessions dropped, the daemon's CPU in the loaded blocks. With
// --fifo the daemon runs with control.realtime (SCHED_FIFO) and lock_memory; with
// --no-controller the controller stays paused (to tell its commands' cost apart). The footprint
// (RSS, exec -> serving) is footprint_harness.cpp.
#include <netinet/in.h>
#include <sys/epoll.h>
#include <sys/socket.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <utility>

#include "harness.hpp"

namespace ajar::bench {
namespace {

using namespace protocol;

constexpr int kObservers = 256;
constexpr float kTelemetryHz = 100.0F;

core::FramedPoint base_point(double x, double y, double z) {
  return core::FramedPoint{core::Frame::kBase, core::Vec3(x, y, z)};
}

MeasureDoorPlane plane_at_yaw(double yaw_rad) {
  MeasureDoorPlane p;
  p.count = 3;
  const double t = std::tan(yaw_rad);
  p.points[0] = base_point(1.5 + 0.3 * t, 0.3, 0.8);
  p.points[1] = base_point(1.5 - 0.3 * t, -0.3, 0.8);
  p.points[2] = base_point(1.5, 0.0, 1.4);
  return p;
}

ProcedureState state_of(const Message& m) {
  if (const auto* a = std::get_if<Ack>(&m)) return a->state;
  if (const auto* s = std::get_if<protocol::Status>(&m)) return s->state;
  return ProcedureState::kFault;
}

// One full procedure up to an aligned base; returns false if it ended in a fault (then reset).
bool align_once(Conn& c, double yaw_rad) {
  (void)c.request(Reset{true});
  (void)c.request(MeasureDoorWidth{base_point(1.5, 0.40, 1.0), base_point(1.5, -0.45, 1.0)});
  (void)c.request(MeasureHandle{base_point(1.45, -0.30, 1.0), base_point(1.45, -0.42, 1.0)});
  (void)c.request(plane_at_yaw(yaw_rad));
  if (state_of(c.request(AlignBase{})) != ProcedureState::kAligning) return false;
  const std::int64_t give_up = now_ns() + 30'000'000'000;
  while (now_ns() < give_up) {
    const auto st = state_of(c.request(GetStatus{}));
    if (st == ProcedureState::kAligned) return true;
    if (st != ProcedureState::kAligning) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  fail("alignment did not finish within 30 s");
}

// The loop's timing since start (protocol 1.1 LoopTiming.all).
protocol::TimingWindow loop_timing(Conn& c) {
  const auto m = c.request(GetStatus{});
  if (const auto* s = std::get_if<protocol::Status>(&m)) return s->timing.all;
  fail("GetStatus not answered with Status");
}

// Reads telemetry on many connections at once and records each connection's inter-arrival times,
// per block: take_block() hands over the gaps since the previous call and restarts every
// connection's clock (a gap never spans two blocks).
class Observers {
 public:
  void add(Conn c) { conns_.push_back(std::move(c)); }
  std::size_t size() const { return conns_.size(); }
  std::vector<Conn>& conns() { return conns_; }

  void start() {
    thread_ = std::thread([this] { run(); });
  }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::vector<std::int64_t> take_block() {
    std::lock_guard lock(mutex_);
    ++block_;
    return std::exchange(gaps_, {});
  }
  int dropped() const { return dropped_; }
  std::uint64_t frames() const { return frames_; }

 private:
  void run() {
    const int ep = ::epoll_create1(EPOLL_CLOEXEC);
    for (std::size_t i = 0; i < conns_.size(); ++i) {
      epoll_event ev{};
      ev.events = EPOLLIN;
      ev.data.u64 = i;
      ::epoll_ctl(ep, EPOLL_CTL_ADD, conns_[i].fd(), &ev);
    }
    std::vector<std::int64_t> last(conns_.size(), -1);
    std::vector<bool> closed(conns_.size(), false);
    std::uint64_t block = 0;
    epoll_event events[64];
    while (!stop_) {
      const int n = ::epoll_wait(ep, events, 64, 50);
      const std::int64_t t = now_ns();
      std::lock_guard lock(mutex_);
      if (block != block_) {
        block = block_;
        std::fill(last.begin(), last.end(), -1);
      }
      for (int k = 0; k < n; ++k) {
        const auto i = static_cast<std::size_t>(events[k].data.u64);
        if (!conns_[i].read_some()) {
          if (!closed[i]) ++dropped_;
          closed[i] = true;
          ::epoll_ctl(ep, EPOLL_CTL_DEL, conns_[i].fd(), nullptr);
          continue;
        }
        while (auto e = conns_[i].next_buffered()) {
          if (!std::holds_alternative<Telemetry>(e->message)) continue;  // e.g. Subscribe's Ack
          ++frames_;
          if (last[i] >= 0) gaps_.push_back(t - last[i]);
          last[i] = t;
        }
      }
    }
    ::close(ep);
  }

  std::vector<Conn> conns_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::uint64_t block_ = 0;  // under mutex_
  std::vector<std::int64_t> gaps_;
  std::atomic<int> dropped_{0};
  std::atomic<std::uint64_t> frames_{0};
};

// The baseline: accepts kObservers connections, then writes one Telemetry frame to each every
// 10 ms (absolute deadlines), in one thread, until stopped.
class BareFanout {
 public:
  BareFanout() {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listen_fd_, kObservers + 8) != 0)
      fail("bare fan-out: bind/listen");
    socklen_t len = sizeof a;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
  }
  ~BareFanout() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    for (int fd : fds_)
      ::close(fd);
    ::close(listen_fd_);
  }
  std::uint16_t port() const { return port_; }
  void accept_all() {
    while (fds_.size() < static_cast<std::size_t>(kObservers)) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd < 0) fail("bare fan-out: accept");
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      fds_.push_back(fd);
    }
  }
  void set_active(bool on) { active_ = on; }
  void start() {
    thread_ = std::thread([this] {
      std::uint8_t frame[kMaxFrameSize];
      const std::int64_t period =
          static_cast<std::int64_t>(1e9 / static_cast<double>(kTelemetryHz));
      std::int64_t deadline = now_ns();
      while (!stop_) {
        Telemetry t;
        t.daemon_time_ns = static_cast<std::uint64_t>(now_ns());
        const std::size_t n = encode(Envelope{0, 0, t}, frame);
        if (active_.load(std::memory_order_relaxed))
          for (int fd : fds_)
            (void)::send(fd, frame, n, MSG_NOSIGNAL);
        deadline += period;
        timespec ts{static_cast<time_t>(deadline / 1'000'000'000),
                    static_cast<long>(deadline % 1'000'000'000)};
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
        }
      }
    });
  }

 private:
  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
  std::vector<int> fds_;
  std::thread thread_;
  std::atomic<bool> stop_{false}, active_{false};
};

// Subscribe (or unsubscribe: 0 Hz) every observer without waiting for the Acks (their reader
// thread owns the sockets and skips the Acks).
void subscribe_all(std::vector<Conn>& conns, float hz) {
  std::uint32_t id = 1'000'000;
  for (auto& c : conns)
    c.send(Envelope{++id, 0, Subscribe{hz}});
}

// The controller: runs the procedure and AlignBase over and over while active; set_active(false)
// returns once the alignment under way has ended (a block boundary never cuts one).
class Controller {
 public:
  explicit Controller(Conn& c) : c_(c) {
    thread_ = std::thread([this] { run(); });
  }
  ~Controller() {
    stop_ = true;
    thread_.join();
  }
  void set_active(bool on) {
    active_ = on;
    while (!on && busy_.load())
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  int aligns() const { return aligns_.load(); }

 private:
  void run() {
    double yaw = 0.05;
    while (!stop_) {
      if (!active_) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        continue;
      }
      busy_ = true;
      if (active_ && align_once(c_, yaw)) ++aligns_;
      busy_ = false;
      yaw = -yaw;
    }
  }
  Conn& c_;
  std::thread thread_;
  std::atomic<bool> stop_{false}, active_{false}, busy_{false};
  std::atomic<int> aligns_{0};
};

// The command line: --fifo and --no-controller, then the harnesses' own options.
struct FanoutOptions {
  Options common;
  bool fifo = false;
  bool with_controller = true;
};
FanoutOptions parse_fanout_options(int argc, char** argv) {
  FanoutOptions f;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::string(argv[i]) == "--fifo")
      f.fifo = true;
    else if (std::string(argv[i]) == "--no-controller")  // diagnosis: observers only
      f.with_controller = false;
    else
      rest.push_back(argv[i]);
  }
  f.common = Options::parse(static_cast<int>(rest.size()), rest.data());
  return f;
}

// The daemon's config: --config as it is, or with --fifo a copy with control.realtime and
// lock_memory on.
std::string daemon_config(const Options& o, bool fifo) {
  if (!fifo) return o.config;
  const std::string config = o.dir + "/fifo.yaml";
  write_config(
      o.config, config,
      {{"realtime: false", "realtime: true"}, {"lock_memory: false", "lock_memory: true"}});
  return config;
}

// `observers` greeted observers of ajard (on `daemon_port`), and kObservers connections to the
// bare server, accepted by it.
void connect_observers(Observers& on_daemon, Observers& on_bare, std::uint16_t daemon_port,
                       BareFanout& bare, int observers) {
  for (int i = 0; i < observers; ++i) {
    Conn c(daemon_port);
    (void)c.hello(Role::kObserver, "bench-observer");
    on_daemon.add(std::move(c));
  }
  std::thread connector([&] {
    for (int i = 0; i < kObservers; ++i)
      on_bare.add(Conn(bare.port()));
  });
  bare.accept_all();
  connector.join();
}

void sleep_block(double block_s) {
  std::this_thread::sleep_for(std::chrono::duration<double>(block_s));
}

// Idle: nobody subscribed, controller paused, bare server paused. The loop's timing over the block
// (its statistics reset at the start); what the observers got meanwhile is dropped.
TimingWindow idle_block(Conn& control, Observers& on_daemon, Observers& on_bare, double block_s) {
  (void)control.request(ResetLoopStatistics{});
  sleep_block(block_s);
  TimingWindow idle = loop_timing(control);
  (void)on_daemon.take_block();
  (void)on_bare.take_block();
  return idle;
}

// Bare: the bare fan-out server alone. The telemetry inter-arrival at its observers.
Quantiles bare_block(BareFanout& bare, Observers& on_bare, Observers& on_daemon, double block_s) {
  (void)on_bare.take_block();
  bare.set_active(true);
  sleep_block(block_s);
  bare.set_active(false);
  const auto bare_gaps = quantiles(on_bare.take_block());
  (void)on_daemon.take_block();
  return bare_gaps;
}

// The figures of the run, one pair per cycle: the loop's timing loaded vs idle, the telemetry
// inter-arrival on ajard vs the bare server; the daemon's CPU over the loaded blocks.
struct Figures {
  Paired lat_p99, lat_p999, lat_max, period_p99, exec_p99, gap_p999, gap_max;
  double cpu_s = 0, loaded_s = 0;

  void add_cycle(const TimingWindow& idle, const TimingWindow& loaded, const Quantiles& bare_gaps,
                 const Quantiles& daemon_gaps) {
    lat_p99.add(idle.latency.p99_ns / 1e3, loaded.latency.p99_ns / 1e3);
    lat_p999.add(idle.latency.p999_ns / 1e3, loaded.latency.p999_ns / 1e3);
    lat_max.add(idle.latency.max_ns / 1e3, loaded.latency.max_ns / 1e3);
    period_p99.add(idle.period.p99_ns / 1e3, loaded.period.p99_ns / 1e3);
    exec_p99.add(idle.execution.p99_ns / 1e3, loaded.execution.p99_ns / 1e3);
    gap_p999.add(bare_gaps.p999 / 1e6, daemon_gaps.p999 / 1e6);
    gap_max.add(bare_gaps.max / 1e6, daemon_gaps.max / 1e6);
  }
  void print(int observers, const std::string& mode, bool fifo, int aligns, int dropped) const {
    const std::string load = std::to_string(observers) + " observers, " + mode;
    compare_row("loop wake-up latency p99 with " + load, lat_p99, "us", fifo ? "<= 1.1x" : "",
                "vs idle blocks; " + std::to_string(aligns) + " aligns meanwhile");
    compare_row("loop wake-up latency p99.9 with " + load, lat_p999, "us", "", "vs idle blocks");
    compare_row("loop wake-up latency max with " + load, lat_max, "us", "", "vs idle blocks",
                Over::kMax);
    compare_row("loop period p99 with " + load, period_p99, "us", "", "vs idle blocks");
    compare_row("loop cycle execution p99 with " + load, exec_p99, "us", "", "vs idle blocks");
    compare_row("telemetry inter-arrival p99.9, " + mode, gap_p999, "ms", "",
                "vs bare fan-out server blocks");
    compare_row("telemetry inter-arrival max, " + mode, gap_max, "ms", "<= 1.2x",
                "vs bare fan-out server blocks", Over::kMax);
    row("sessions dropped, " + mode, dropped, "", std::nullopt, "0");
    row("daemon CPU under fan-out, " + mode, loaded_s > 0 ? 100 * cpu_s / loaded_s : 0,
        "% of a core", std::nullopt, "", "loaded blocks only");
  }
};

}  // namespace
}  // namespace ajar::bench

int main(int argc, char** argv) {
  using namespace ajar::bench;
  using namespace ajar::protocol;
  const FanoutOptions fo = parse_fanout_options(argc, argv);
  const Options& o = fo.common;
  const bool fifo = fo.fifo;
  if (o.ajard.empty() || o.config.empty()) fail("--ajard and --config are required");
  const int cycles = o.smoke ? 2 : kMinBlocks;
  const double block_s = o.smoke ? 0.5 : 2.0;
  const int observers = o.smoke ? 16 : kObservers;
  const std::string mode = fifo ? "SCHED_FIFO" : "SCHED_OTHER";
  const std::string config = daemon_config(o, fifo);
  const Placement where = placement();
  pin_this_thread(where.client);  // this thread, the observers' readers, the controller
  info("fan-out (" + mode + "): load average " + load_average() + " at start; " +
       std::to_string(observers) +
       " observers at 100 Hz on ajard and as many on a bare fan-out "
       "server; " +
       std::to_string(cycles) + " cycles of three " + format_number(block_s) +
       " s blocks: idle (nobody subscribed, controller paused), loaded (observers subscribed, "
       "controller aligning), bare (the bare server sending, ajard idle); " +
       where.describe());

  Daemon d(o.ajard, config, o.dir + "/fanout", where.server);
  auto bare = created_on(where.server, [] { return std::make_unique<BareFanout>(); });
  Observers on_daemon, on_bare;
  connect_observers(on_daemon, on_bare, d.port(), *bare, observers);
  Conn control(d.port());
  if (control.hello(Role::kController, "bench-controller").granted_role != Role::kController)
    fail("controller role not granted");
  on_daemon.start();
  on_bare.start();
  created_on(where.server, [&] {
    bare->start();
    return 0;
  });
  Controller controller(control);  // its thread on the client CPU; uses `control` only when active

  Figures figures;
  for (int c = 0; c < cycles; ++c) {
    const TimingWindow idle = idle_block(control, on_daemon, on_bare, block_s);

    // Loaded: every observer subscribed, the controller aligning.
    (void)control.request(ResetLoopStatistics{});
    subscribe_all(on_daemon.conns(), kTelemetryHz);
    const double cpu0 = d.cpu_s();
    const std::int64_t t0 = now_ns();
    controller.set_active(fo.with_controller);
    sleep_block(block_s);
    controller.set_active(false);  // waits for the alignment under way
    figures.cpu_s += d.cpu_s() - cpu0;
    figures.loaded_s += static_cast<double>(now_ns() - t0) * 1e-9;
    const TimingWindow loaded = loop_timing(control);
    const auto daemon_gaps = quantiles(on_daemon.take_block());
    subscribe_all(on_daemon.conns(), 0);

    const auto bare_gaps = bare_block(*bare, on_bare, on_daemon, block_s);

    figures.add_cycle(idle, loaded, bare_gaps, daemon_gaps);
  }
  const int aligns = controller.aligns();
  on_daemon.stop();
  on_bare.stop();
  const int dropped = on_daemon.dropped();

  figures.print(observers, mode, fifo, aligns, dropped);
  info("fan-out (" + mode + "): load average " + load_average() + " at the end");
  return dropped == 0 ? 0 : 1;
}
