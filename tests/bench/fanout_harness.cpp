// Fan-out and footprint. 256 observers subscribed to telemetry at 100 Hz while a controller runs
// the procedure and AlignBase over and over: the loop's timing under that load vs the same daemon
// configuration idle (two daemons started in this run: one idle, one loaded, so that each one's
// since-start LoopTiming from Status covers exactly its phase), the telemetry inter-arrival at the
// observers vs a bare fan-out server (one thread writing the same Telemetry frame to 256 sockets
// every 10 ms), sessions dropped, the daemon's CPU. Footprint: RSS idle, after one procedure, with
// 256 sessions; exec -> serving (spawn until a Hello is answered), median of several starts. With
// --fifo the daemons run with control.realtime (SCHED_FIFO) and lock_memory; with
// --no-controller the controller stays connected but idle (to tell its commands' cost apart).
#include <netinet/in.h>
#include <sys/epoll.h>
#include <sys/socket.h>

#include <atomic>
#include <map>

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

// Reads telemetry on many connections at once and records each connection's inter-arrival times.
class Observers {
 public:
  void add(Conn c) { conns_.push_back(std::move(c)); }
  std::size_t size() const { return conns_.size(); }

  void start() {
    thread_ = std::thread([this] { run(); });
  }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::vector<std::int64_t>& gaps() { return gaps_; }
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
    epoll_event events[64];
    while (!stop_) {
      const int n = ::epoll_wait(ep, events, 64, 50);
      const std::int64_t t = now_ns();
      for (int k = 0; k < n; ++k) {
        const auto i = static_cast<std::size_t>(events[k].data.u64);
        if (!conns_[i].read_some()) {
          if (!closed[i]) ++dropped_;
          closed[i] = true;
          ::epoll_ctl(ep, EPOLL_CTL_DEL, conns_[i].fd(), nullptr);
          continue;
        }
        while (auto e = conns_[i].next_buffered()) {
          if (!std::holds_alternative<Telemetry>(e->message)) continue;
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
  std::vector<std::int64_t> gaps_;
  int dropped_ = 0;
  std::uint64_t frames_ = 0;
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
  std::atomic<bool> stop_{false};
};

}  // namespace
}  // namespace ajar::bench

int main(int argc, char** argv) {
  using namespace ajar::bench;
  using namespace ajar::protocol;
  bool fifo = false, with_controller = true;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::string(argv[i]) == "--fifo")
      fifo = true;
    else if (std::string(argv[i]) == "--no-controller")  // diagnosis: observers only
      with_controller = false;
    else
      rest.push_back(argv[i]);
  }
  const Options o = Options::parse(static_cast<int>(rest.size()), rest.data());
  if (o.ajard.empty() || o.config.empty()) fail("--ajard and --config are required");
  const double seconds = o.smoke ? 1.0 : 20.0;
  const int observers = o.smoke ? 16 : kObservers;
  const std::string mode = fifo ? "SCHED_FIFO" : "SCHED_OTHER";
  std::string config = o.config;
  if (fifo) {
    config = o.dir + "/fifo.yaml";
    write_config(
        o.config, config,
        {{"realtime: false", "realtime: true"}, {"lock_memory: false", "lock_memory: true"}});
  }
  info("fan-out (" + mode + "): load average " + load_average() + " at start; " +
       std::to_string(observers) + " observers at 100 Hz; " + std::to_string(seconds) +
       " s per phase");

  // exec -> serving, and RSS idle / after one procedure, on fresh daemons.
  std::vector<std::int64_t> starts;
  long rss_idle = 0, rss_after = 0;
  for (int i = 0; i < (o.smoke ? 1 : 5); ++i) {
    Daemon d(o.ajard, config, o.dir + "/fanout-start");
    starts.push_back(d.exec_to_serving_ns());
    if (i == 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      rss_idle = d.rss_kib();
      Conn c(d.port());
      (void)c.hello(Role::kController, "bench-procedure");
      if (!align_once(c, 0.05)) fail("the procedure did not reach Aligned");
      rss_after = d.rss_kib();
    }
  }
  if (!fifo) {
    row("exec -> serving (median of " + std::to_string(starts.size()) + ")",
        quantiles(starts).p50 / 1e6, "ms", std::nullopt, "<= 20 ms", "spawn until Welcome");
  }
  row("RSS idle, " + mode, static_cast<double>(rss_idle) / 1024.0, "MiB");
  row("RSS after the procedure, " + mode, static_cast<double>(rss_after) / 1024.0, "MiB");

  // Idle phase: a fresh daemon, nobody connected but one Status at the end.
  TimingWindow idle;
  {
    Daemon d(o.ajard, config, o.dir + "/fanout-idle");
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    Conn c(d.port());
    (void)c.hello(Role::kObserver, "bench-idle");
    idle = loop_timing(c);
  }

  // Loaded phase.
  TimingWindow loaded;
  long rss_sessions = 0;
  double cpu = 0;
  int aligns = 0, dropped = 0;
  std::vector<std::int64_t> daemon_gaps;
  {
    Daemon d(o.ajard, config, o.dir + "/fanout-load");
    Observers obs;
    for (int i = 0; i < observers; ++i) {
      Conn c(d.port());
      (void)c.hello(Role::kObserver, "bench-observer");
      if (!std::holds_alternative<Ack>(c.request(Subscribe{kTelemetryHz})))
        fail("Subscribe refused");
      obs.add(std::move(c));
    }
    std::atomic<bool> stop{false};
    std::atomic<int> aligned{0};
    Conn controller(d.port());
    if (controller.hello(Role::kController, "bench-controller").granted_role != Role::kController)
      fail("controller role not granted");
    obs.start();
    const double cpu0 = d.cpu_s();
    const std::int64_t t0 = now_ns();
    std::thread ctl([&] {
      double yaw = 0.05;
      while (!stop && with_controller) {
        if (align_once(controller, yaw)) ++aligned;
        yaw = -yaw;
      }
    });
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    rss_sessions = d.rss_kib();
    stop = true;
    ctl.join();
    cpu = (d.cpu_s() - cpu0) / (static_cast<double>(now_ns() - t0) * 1e-9);
    loaded = loop_timing(controller);
    obs.stop();
    aligns = aligned;
    dropped = obs.dropped();
    daemon_gaps = std::move(obs.gaps());
  }

  // The bare fan-out server, same observers' code.
  std::vector<std::int64_t> bare_gaps;
  {
    BareFanout bare;
    Observers obs;
    std::thread connector([&] {
      for (int i = 0; i < kObservers; ++i)
        obs.add(Conn(bare.port()));
    });
    bare.accept_all();
    connector.join();
    obs.start();
    bare.start();
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    obs.stop();
    bare_gaps = std::move(obs.gaps());
  }

  const auto g = quantiles(daemon_gaps);
  const auto b = quantiles(bare_gaps);
  const std::string load = std::to_string(observers) + " observers, " + mode;
  row("loop wake-up latency p99 with " + load, loaded.latency.p99_ns / 1e3, "us",
      idle.latency.p99_ns / 1e3, fifo ? "<= 1.1x" : "",
      "vs idle daemon; " + std::to_string(aligns) + " aligns meanwhile");
  row("loop wake-up latency p99.9 with " + load, loaded.latency.p999_ns / 1e3, "us",
      idle.latency.p999_ns / 1e3, "", "vs idle daemon");
  row("loop wake-up latency max with " + load, loaded.latency.max_ns / 1e3, "us",
      idle.latency.max_ns / 1e3, "", "vs idle daemon");
  row("loop period p99 with " + load, loaded.period.p99_ns / 1e3, "us", idle.period.p99_ns / 1e3,
      "", "vs idle daemon");
  row("loop cycle execution p99 with " + load, loaded.execution.p99_ns / 1e3, "us",
      idle.execution.p99_ns / 1e3, "", "vs idle daemon");
  row("telemetry inter-arrival p99.9, " + mode, g.p999 / 1e6, "ms", b.p999 / 1e6, "",
      "vs bare fan-out server; " + std::to_string(g.n) + " gaps");
  row("telemetry inter-arrival max, " + mode, g.max / 1e6, "ms", b.max / 1e6, "<= 1.2x",
      "vs bare fan-out server");
  row("sessions dropped, " + mode, dropped, "", std::nullopt, "0");
  row("daemon CPU under fan-out, " + mode, cpu * 100, "% of a core");
  row("RSS with " + std::to_string(observers + 1) + " sessions, " + mode,
      static_cast<double>(rss_sessions) / 1024.0, "MiB", std::nullopt, "<= 16 MiB");
  return dropped == 0 ? 0 : 1;
}
