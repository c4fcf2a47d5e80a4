// Shared pieces of the benchmark harnesses (tests/bench/*_harness.cpp): a blocking wire client, an
// ajard child process (by the tests' launcher, tests/support/ajard_process.hpp), percentiles, and
// the result rows scripts/bench turns into one table. Timing is measured and printed here, never
// asserted: a harness fails only when something does not work (daemon does not start, a reply never
// comes, a session is dropped).
#pragma once

#include <netinet/in.h>
#include <pthread.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "ajar/protocol/codec.hpp"
#include "ajard_process.hpp"

namespace ajar::bench {

inline std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Whether a thread of this process may run under SCHED_FIFO at `priority` (tried on a thread of
// its own, which ends at once).
inline bool fifo_permitted(int priority) {
  std::atomic<bool> ok{false};
  std::thread t([&] {
    sched_param p{};
    p.sched_priority = priority;
    ok = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0;
  });
  t.join();
  return ok;
}

// The ajard children alive now (Daemon adds and removes its own): a harness that fails exits
// without running destructors, and a daemon left running would load every later measurement.
inline std::vector<pid_t>& live_daemons() {
  static std::vector<pid_t> pids;
  return pids;
}

// Kills the live ajard children and exits 1 with the reason.
[[noreturn]] inline void fail(const std::string& what) {
  std::fprintf(stderr, "bench: FAILED: %s\n", what.c_str());
  for (const pid_t pid : live_daemons())
    ::kill(pid, SIGKILL);
  std::exit(1);
}

// ---- results --------------------------------------------------------------------------------

struct Quantiles {
  double p50 = 0, p99 = 0, p999 = 0, max = 0;
  std::size_t n = 0;
};

inline Quantiles quantiles(std::vector<std::int64_t> v) {
  Quantiles q;
  q.n = v.size();
  if (v.empty()) return q;
  std::sort(v.begin(), v.end());
  const auto at = [&](double f) {
    const auto rank = static_cast<std::size_t>(std::ceil(f * static_cast<double>(v.size())));
    return static_cast<double>(v[std::clamp<std::size_t>(rank, 1, v.size()) - 1]);
  };
  q.p50 = at(0.50);
  q.p99 = at(0.99);
  q.p999 = at(0.999);
  q.max = static_cast<double>(v.back());
  return q;
}

// The verdict of a value (or ratio) against a target written "<= 1.2x", ">= 0.5x", "<= 16 MiB",
// "<= 20 ms" or "0" (equal): "met" / "NOT MET", or "" when the target is empty or not a bound.
// With a spread [lo, hi] (the interquartile range of the block ratios), a bound that falls inside
// it gives "unclear": the blocks do not agree on which side of the target the figure is.
inline std::string verdict(const std::string& target, double value, double lo, double hi) {
  if (target.empty()) return "";
  const bool at_most = target.rfind("<=", 0) == 0, at_least = target.rfind(">=", 0) == 0;
  const char* number = target.c_str() + ((at_most || at_least) ? 2 : 0);
  char* end = nullptr;
  const double bound = std::strtod(number, &end);
  if (end == number) return "";
  if (!at_most && !at_least) return value == bound ? "met" : "NOT MET";
  const auto ok = [&](double x) { return at_most ? x <= bound : x >= bound; };
  if (ok(lo) && ok(hi)) return "met";
  if (!ok(lo) && !ok(hi)) return "NOT MET";
  return ok(value) ? "met, unclear" : "NOT MET, unclear";
}

// One row of the table on stdout, collected by scripts/bench from every harness:
//   ROW|figure|value|unit|baseline|ratio|spread|target|verdict|note
// baseline/ratio/spread/target/verdict may be empty. A plain row (no blocks): the ratio is
// value / baseline; the verdict applies the target to the ratio (an "x" target) or to the value.
inline std::string format_number(double x) {
  char out[64];
  std::snprintf(out, sizeof out, std::abs(x) >= 1000 ? "%.0f" : "%.3g", x);
  return out;
}
inline void emit_row(const std::string& figure, const std::string& value, const std::string& unit,
                     const std::string& baseline, const std::string& ratio,
                     const std::string& spread, const std::string& target,
                     const std::string& verdict_text, const std::string& note) {
  std::printf("ROW|%s|%s|%s|%s|%s|%s|%s|%s|%s\n", figure.c_str(), value.c_str(), unit.c_str(),
              baseline.c_str(), ratio.c_str(), spread.c_str(), target.c_str(), verdict_text.c_str(),
              note.c_str());
  std::fflush(stdout);
}
inline void row(const std::string& figure, double value, const std::string& unit,
                std::optional<double> baseline = std::nullopt, const std::string& target = "",
                const std::string& note = "") {
  std::string b, r, v;
  const bool ratio_target = !target.empty() && target.back() == 'x';
  if (baseline) {
    b = format_number(*baseline);
    if (*baseline > 0) {
      char out[64];
      std::snprintf(out, sizeof out, "%.2fx", value / *baseline);
      r = out;
      if (ratio_target)
        v = verdict(target, value / *baseline, value / *baseline, value / *baseline);
    }
  }
  if (!ratio_target) v = verdict(target, value, value, value);
  emit_row(figure, format_number(value), unit, b, r, "", target, v, note);
}

// A line of conditions printed under the table: "INFO|text".
inline void info(const std::string& text) {
  std::printf("INFO|%s\n", text.c_str());
  std::fflush(stdout);
}

inline std::string load_average() {
  std::ifstream f("/proc/loadavg");
  std::string a, b, c;
  f >> a >> b >> c;
  return a + " " + b + " " + c;
}

// ---- baseline and subject in alternating blocks ---------------------------------------------
//
// A comparison runs baseline and subject in turn, in short blocks, within one run: A B A B ...
// (at least kMinBlocks each in a full run). Each block gives one value per statistic (its median,
// p99, ...); each pair (A_i, B_i) one ratio B_i / A_i. Reported: the median over blocks of each
// side's statistic, the MEDIAN OF THE BLOCK RATIOS (the figure the target applies to) and their
// spread (interquartile range, and min-max), the load average. NOISY: the interquartile range of
// the block ratios is wider than kNoisySpread of their median, i.e. the blocks disagree and the
// figure is not to be trusted (docs/performance.md, "Reading the table").
inline constexpr int kMinBlocks = 10;
inline constexpr double kNoisySpread = 0.20;

// Exact rank statistic of a sample (nearest rank; 0 = min, 1 = max).
inline double rank_stat(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::clamp<std::size_t>(rank, 1, v.size()) - 1];
}
// Median with interpolation between the two middle values (for the few values of a block series).
inline double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
inline double quartile_of(std::vector<double> v, double q) {  // linear interpolation
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double x = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(x);
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (x - static_cast<double>(i)) * (v[i + 1] - v[i]);
}

// One statistic over the blocks: a value per block of each side.
struct Paired {
  std::vector<double> base, subject;
  void add(double b, double s) {
    base.push_back(b);
    subject.push_back(s);
  }
};

// How the per-block values of one side are summarised in the value/baseline columns.
enum class Over { kMedian, kMin, kMax };

inline double summarise(const std::vector<double>& v, Over over) {
  if (v.empty()) return 0;
  if (over == Over::kMin) return *std::min_element(v.begin(), v.end());
  if (over == Over::kMax) return *std::max_element(v.begin(), v.end());
  return median_of(v);
}

// Prints the row of one statistic compared over blocks (see above); returns the median ratio.
inline double compare_row(const std::string& figure, const Paired& p, const std::string& unit,
                          const std::string& target, const std::string& note,
                          Over over = Over::kMedian) {
  std::vector<double> ratios;
  for (std::size_t i = 0; i < p.base.size() && i < p.subject.size(); ++i)
    if (p.base[i] > 0) ratios.push_back(p.subject[i] / p.base[i]);
  const double med = median_of(ratios), q1 = quartile_of(ratios, 0.25),
               q3 = quartile_of(ratios, 0.75);
  const double lo = ratios.empty() ? 0 : *std::min_element(ratios.begin(), ratios.end());
  const double hi = ratios.empty() ? 0 : *std::max_element(ratios.begin(), ratios.end());
  const bool noisy = ratios.size() < 2 || (med > 0 && (q3 - q1) > kNoisySpread * med);
  char ratio[32], spread[96];
  std::snprintf(ratio, sizeof ratio, "%.2fx", med);
  std::snprintf(spread, sizeof spread, "IQR %.2f-%.2f, %.2f-%.2f, %zu blocks", q1, q3, lo, hi,
                ratios.size());
  std::string v = verdict(target, med, q1, q3);
  if (noisy) v += v.empty() ? "NOISY" : ", NOISY";
  emit_row(figure, format_number(summarise(p.subject, over)), unit,
           format_number(summarise(p.base, over)), ratio, spread, target, v, note);
  return med;
}

// Per-block statistics of raw samples (ns), in µs: min, p50, p99, p99.9, max of each block.
struct SampleBlocks {
  Paired min, p50, p99, p999, max;
  std::vector<std::int64_t> all_base, all_subject;
  void add(const std::vector<std::int64_t>& base, const std::vector<std::int64_t>& subject) {
    const auto us = [](const std::vector<std::int64_t>& v) {
      std::vector<double> out;
      out.reserve(v.size());
      for (auto x : v)
        out.push_back(static_cast<double>(x) / 1e3);
      return out;
    };
    const auto b = us(base), s = us(subject);
    min.add(rank_stat(b, 0), rank_stat(s, 0));
    p50.add(rank_stat(b, 0.5), rank_stat(s, 0.5));
    p99.add(rank_stat(b, 0.99), rank_stat(s, 0.99));
    p999.add(rank_stat(b, 0.999), rank_stat(s, 0.999));
    max.add(rank_stat(b, 1), rank_stat(s, 1));
    all_base.insert(all_base.end(), base.begin(), base.end());
    all_subject.insert(all_subject.end(), subject.begin(), subject.end());
  }
  std::size_t blocks() const { return p50.base.size(); }
};

// The usual rows of a latency comparison: p50 (with the per-block medians in an INFO line), p99
// (the target), min; p99.9 and max when `tails`.
inline void latency_rows(const std::string& what, const SampleBlocks& b,
                         const std::string& base_name, const std::string& p50_target,
                         const std::string& p99_target, bool tails = false) {
  const std::string vs = "vs " + base_name;
  compare_row(what + " p50", b.p50, "us", p50_target, vs + "; per-block medians");
  compare_row(what + " p99", b.p99, "us", p99_target, vs);
  if (tails) {
    compare_row(what + " p99.9", b.p999, "us", "", vs);
    compare_row(what + " max", b.max, "us", "", vs, Over::kMax);
  }
  compare_row(what + " min", b.min, "us", "", vs + "; the floor of each side", Over::kMin);
  std::string medians = what + ": per-block p50 (" + base_name + " / subject, us):";
  for (std::size_t i = 0; i < b.blocks(); ++i) {  // append(): GCC 12's -Wrestrict misfires on +
    medians.append(" ").append(format_number(b.p50.base[i]));
    medians.append("/").append(format_number(b.p50.subject[i]));
  }
  std::printf("INFO|%s\n", medians.c_str());
}

// ---- explicit CPU placement ----------------------------------------------------------------
//
// On a 2-vCPU VM a loopback round trip is bimodal: ~12 us when the peer's vCPU is awake, ~40 us
// when the hypervisor must wake it (the guest halts at once: cpuidle haltpoll with
// guest_halt_poll_ns 0). Which mode a run lands in depends on where the scheduler puts the two
// threads, so a baseline and a subject left to the scheduler can be measured in different modes.
// Every harness therefore pins the same way for both: the client side (the measuring thread and
// its helpers) on CPU `client`, the server side (the ajard process with all its threads, the echo
// or bare fan-out server thread, in-process servers) on CPU `server`. AJAR_BENCH_CPUS=c,s
// overrides (e.g. "0,0" puts both on one CPU: no cross-CPU wake-up at all); "none" disables.
struct Placement {
  int client = -1, server = -1;  // -1: not pinned
  bool pinned() const { return client >= 0 && server >= 0; }
  std::string describe() const {
    if (!pinned()) return "not pinned (AJAR_BENCH_CPUS=none or one CPU)";
    return "client threads on CPU " + std::to_string(client) + ", server threads on CPU " +
           std::to_string(server) + " (sched_setaffinity, same for baseline and subject)";
  }
};

inline Placement placement() {
  Placement p;
  const char* env = std::getenv("AJAR_BENCH_CPUS");
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (::sched_getaffinity(0, sizeof allowed, &allowed) != 0) return p;
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(static_cast<std::size_t>(c), &allowed)) cpus.push_back(c);
  if (env != nullptr) {
    if (std::string(env) == "none") return p;
    if (std::sscanf(env, "%d,%d", &p.client, &p.server) != 2) fail("AJAR_BENCH_CPUS: want c,s");
    return p;
  }
  if (cpus.size() >= 2) {
    p.client = cpus[0];
    p.server = cpus[1];
  }
  return p;
}

// Pins the calling thread to `cpu` (threads it creates afterwards inherit the mask).
inline void pin_this_thread(int cpu) {
  if (cpu < 0) return;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(static_cast<std::size_t>(cpu), &set);
  if (::sched_setaffinity(0, sizeof set, &set) != 0)
    fail("sched_setaffinity(CPU " + std::to_string(cpu) + "): " + std::strerror(errno));
}
// Runs `make` with the calling thread pinned to `cpu`, so that what it creates (threads, a
// spawned process) inherits that CPU; restores the caller's mask afterwards.
template <class F>
auto created_on(int cpu, F&& make) {
  cpu_set_t saved;
  ::sched_getaffinity(0, sizeof saved, &saved);
  pin_this_thread(cpu);
  struct Restore {
    cpu_set_t set;
    ~Restore() { ::sched_setaffinity(0, sizeof set, &set); }
  } restore{saved};
  return make();
}

// ---- a blocking client ----------------------------------------------------------------------

class Conn {
 public:
  Conn() = default;
  explicit Conn(std::uint16_t port) {
    if (!connect_to(port)) fail("cannot connect to 127.0.0.1:" + std::to_string(port));
  }
  static Conn adopt(int fd) {
    Conn c;
    c.fd_ = fd;
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return c;
  }
  ~Conn() { close(); }
  Conn(Conn&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  Conn& operator=(Conn&&) = delete;

  bool connect_to(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) fail("socket: " + std::string(std::strerror(errno)));
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      close();
      return false;
    }
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return true;
  }
  int fd() const { return fd_; }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  void send(const protocol::Envelope& e) {
    std::uint8_t buf[protocol::kMaxFrameSize];
    const std::size_t n = protocol::encode(e, buf);
    if (n == 0) fail("encode");
    send_bytes(buf, n);
  }
  void send_bytes(const std::uint8_t* p, std::size_t n) {
    while (n > 0) {
      const ssize_t w = ::send(fd_, p, n, MSG_NOSIGNAL);
      if (w < 0 && errno == EINTR) continue;
      if (w <= 0) fail("send: " + std::string(std::strerror(errno)));
      p += w;
      n -= static_cast<std::size_t>(w);
    }
  }

  // The next frame, or nullopt after timeout_ms (or EOF: eof() then says so).
  std::optional<protocol::Envelope> receive(int timeout_ms) {
    for (;;) {
      if (pos_ < len_) {
        protocol::StreamDecoder::Outcome o;
        pos_ += decoder_.feed(std::span(buf_.data() + pos_, len_ - pos_), o);
        if (o.kind == protocol::StreamDecoder::Kind::kMessage) return o.envelope;
        if (o.kind == protocol::StreamDecoder::Kind::kError) fail("bad frame from the server");
        continue;
      }
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, timeout_ms) <= 0) return std::nullopt;
      if (!read_some()) return std::nullopt;
    }
  }
  // Reads what the socket holds now into the decoder's input (non-blocking use after poll()).
  bool read_some() {
    const ssize_t r = ::recv(fd_, buf_.data(), buf_.size(), 0);
    if (r <= 0) {
      eof_ = true;
      return false;
    }
    pos_ = 0;
    len_ = static_cast<std::size_t>(r);
    return true;
  }
  // Frames already read and decodable, without touching the socket.
  std::optional<protocol::Envelope> next_buffered() {
    while (pos_ < len_) {
      protocol::StreamDecoder::Outcome o;
      pos_ += decoder_.feed(std::span(buf_.data() + pos_, len_ - pos_), o);
      if (o.kind == protocol::StreamDecoder::Kind::kMessage) return o.envelope;
      if (o.kind == protocol::StreamDecoder::Kind::kError) fail("bad frame from the server");
    }
    return std::nullopt;
  }
  bool eof() const { return eof_; }

  // Sends `m` with a fresh request id and waits for the reply with that id (frames in between,
  // e.g. telemetry and events, are skipped).
  protocol::Message request(const protocol::Message& m, int timeout_ms = 5000) {
    const std::uint32_t id = ++next_id_;
    send(protocol::Envelope{id, 0, m});
    const std::int64_t give_up = now_ns() + std::int64_t{timeout_ms} * 1'000'000;
    while (now_ns() < give_up) {
      auto e = receive(100);
      if (e && e->request_id == id) return e->message;
      if (eof_) fail("connection closed by the server while waiting for a reply");
    }
    fail("no reply within " + std::to_string(timeout_ms) + " ms");
  }

  protocol::Welcome hello(protocol::Role role, const char* name) {
    protocol::Hello h;
    h.requested_role = role;
    h.client_instance_id = static_cast<std::uint64_t>(now_ns());
    h.client_name.assign(name);
    auto reply = request(h);
    if (auto* w = std::get_if<protocol::Welcome>(&reply)) return *w;
    fail("Hello was not answered with Welcome");
  }

 private:
  int fd_ = -1;
  bool eof_ = false;
  std::uint32_t next_id_ = 0;
  std::vector<std::uint8_t> buf_ = std::vector<std::uint8_t>(64 * 1024);
  std::size_t pos_ = 0, len_ = 0;
  protocol::StreamDecoder decoder_;
};

// ---- an ajard child -------------------------------------------------------------------------

// Writes `text` of the config at `path` with each (from, to) replaced, into `out`.
inline void write_config(const std::string& path, const std::string& out,
                         const std::vector<std::pair<std::string, std::string>>& replace) {
  std::ifstream in(path);
  if (!in) fail("cannot read config " + path);
  std::stringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  for (const auto& [from, to] : replace) {
    const auto at = text.find(from);
    if (at == std::string::npos) fail("config " + path + " lacks '" + from + "'");
    text.replace(at, from.size(), to);
  }
  std::ofstream(out) << text;
}

// ajard started by the one launcher (tests/support/ajard_process.hpp), serving on a free port.
class Daemon {
 public:
  // Starts `ajard --config config --listen 127.0.0.1:0 --port-file ... --state-dir ...` with its
  // output in dir/ajard.stdout and dir/ajard.stderr (the log); returns once it serves (port file
  // written and a Hello answered). `cpu` >= 0: the daemon and every thread it starts run on that
  // CPU (Placement::server).
  Daemon(const std::string& ajard, const std::string& config, const std::string& dir, int cpu = -1)
      : dir_(dir) {
    std::filesystem::create_directories(dir + "/state");
    const std::string port_file = dir + "/port";
    std::filesystem::remove(port_file);
    const std::int64_t t0 = now_ns();
    process_ = created_on(cpu, [&] {
      return std::make_unique<test::AjardProcess>(
          test::AjardProcess::Program{ajard},
          std::vector<std::string>{"--config", config, "--listen", "127.0.0.1:0", "--port-file",
                                   port_file, "--state-dir", dir + "/state"},
          dir);
    });
    if (!process_->started()) fail("cannot start " + ajard);
    live_daemons().push_back(process_->pid());
    // Serving = the port file holds the port and a client gets its Welcome.
    const auto port = test::wait_for_port_file(port_file, *process_, std::chrono::seconds(20),
                                               std::chrono::microseconds(200));
    if (!port) {
      fail(std::string(process_->running() ? "ajard did not serve within 20 s"
                                           : "ajard exited during start") +
           "; log: " + process_->stderr_path());
    }
    port_ = *port;
    Conn c(port_);
    (void)c.hello(protocol::Role::kObserver, "bench-probe");
    exec_to_serving_ns_ = now_ns() - t0;
  }
  ~Daemon() { stop(); }
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // SIGTERM and waits for the exit (killed after 30 s).
  void stop() {
    if (!process_) return;
    auto& live = live_daemons();
    live.erase(std::remove(live.begin(), live.end(), process_->pid()), live.end());
    process_->stop();
    process_.reset();
  }
  std::uint16_t port() const { return port_; }
  pid_t pid() const { return process_ ? process_->pid() : -1; }
  std::int64_t exec_to_serving_ns() const { return exec_to_serving_ns_; }

  // VmRSS in KiB.
  long rss_kib() const { return status_field("VmRSS:"); }
  // VmLck (mlock'd) in KiB.
  long locked_kib() const { return status_field("VmLck:"); }

  // Where the resident memory is, from /proc/PID/smaps: "binary 1.6 MiB (locked 1.6), libraries
  // ..., thread stacks ..., anonymous ...", plus the largest anonymous mappings. A thread's stack
  // is the mapping holding its stack pointer (/proc/PID/task/TID/syscall; readable by the parent).
  std::string smaps_breakdown() const {
    const std::string proc = "/proc/" + std::to_string(pid());
    std::vector<std::uint64_t> sps;
    for (const auto& t : std::filesystem::directory_iterator(proc + "/task")) {
      std::ifstream f(t.path() / "syscall");
      std::vector<std::string> fields;
      for (std::string w; f >> w;)
        fields.push_back(w);
      if (fields.size() >= 3)
        sps.push_back(std::strtoull(fields[fields.size() - 2].c_str(), nullptr, 16));
    }
    std::error_code ec;
    const std::string exe = std::filesystem::read_symlink(proc + "/exe", ec).string();
    struct Sum {
      double rss = 0, locked = 0;
    };
    std::map<std::string, Sum> by;
    std::vector<std::pair<double, std::string>> anon;
    std::ifstream f(proc + "/smaps");
    std::string line, category, range;
    std::uint64_t lo = 0, hi = 0;
    double size = 0, rss = 0;
    const auto classify = [&](const std::string& name) {
      if (name == exe) return std::string("binary");
      if (name.find(".so") != std::string::npos) return std::string("libraries");
      if (name == "[stack]") return std::string("thread stacks");
      for (auto sp : sps)
        if (sp >= lo && sp < hi) return std::string("thread stacks");
      if (name == "[heap]" || name.empty()) return std::string("anonymous (heap, arenas, mmap)");
      return std::string("other ") + name;
    };
    while (std::getline(f, line)) {
      if (!line.empty() && std::isxdigit(static_cast<unsigned char>(line[0])) &&
          line.find('-') < 17 && line.find(':') > line.find(' ')) {
        std::istringstream l(line);
        std::string perms, off, dev, inode, name;
        l >> range >> perms >> off >> dev >> inode;
        std::getline(l >> std::ws, name);
        lo = std::strtoull(range.c_str(), nullptr, 16);
        hi = std::strtoull(range.c_str() + range.find('-') + 1, nullptr, 16);
        category = classify(name);
      } else if (line.rfind("Size:", 0) == 0) {
        size = std::strtod(line.c_str() + 5, nullptr);
      } else if (line.rfind("Rss:", 0) == 0) {
        rss = std::strtod(line.c_str() + 4, nullptr);
        by[category].rss += rss;
        if (category.rfind("anonymous", 0) == 0)
          anon.emplace_back(rss, format_number(rss / 1024) + " of " + format_number(size / 1024));
      } else if (line.rfind("Locked:", 0) == 0) {
        by[category].locked += std::strtod(line.c_str() + 7, nullptr);
      }
    }
    std::string out;
    for (const auto& [name, sum] : by) {
      if (!out.empty()) out += "; ";
      out += name + " " + format_number(sum.rss / 1024) + " MiB";
      if (sum.locked > 0) out += " (locked " + format_number(sum.locked / 1024) + ")";
    }
    std::sort(anon.rbegin(), anon.rend());
    out += "; largest anonymous mappings (MiB resident of size):";
    for (std::size_t i = 0; i < anon.size() && i < 4; ++i)
      out += " " + anon[i].second;
    out += "; " + std::to_string(sps.size()) + " threads";
    return out;
  }
  // User + system CPU time of the daemon so far, in seconds.
  double cpu_s() const {
    std::ifstream f("/proc/" + std::to_string(pid()) + "/stat");
    std::string all((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const auto close_paren = all.rfind(')');
    std::istringstream rest(all.substr(close_paren + 2));
    std::string field;
    double ticks = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i)
      if (i == 14 || i == 15) ticks += std::stod(field);
    return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
  }

 private:
  long status_field(const char* name) const {
    std::ifstream f("/proc/" + std::to_string(pid()) + "/status");
    std::string line;
    while (std::getline(f, line))
      if (line.rfind(name, 0) == 0)
        return std::strtol(line.c_str() + std::strlen(name), nullptr, 10);
    return -1;
  }

  std::string dir_;
  std::unique_ptr<test::AjardProcess> process_;
  std::uint16_t port_ = 0;
  std::int64_t exec_to_serving_ns_ = 0;
};

// Command-line options shared by the harnesses: --ajard PATH --config FILE --dir DIR --smoke.
struct Options {
  std::string ajard, config, dir = "/tmp/ajar-bench";
  bool smoke = false;
  static Options parse(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const auto value = [&]() -> std::string {
        if (i + 1 >= argc) fail("missing value after " + a);
        return argv[++i];
      };
      if (a == "--ajard")
        o.ajard = value();
      else if (a == "--config")
        o.config = value();
      else if (a == "--dir")
        o.dir = value();
      else if (a == "--smoke")
        o.smoke = true;
      else
        fail("unknown option " + a + " (--ajard PATH --config FILE --dir DIR --smoke)");
    }
    std::filesystem::create_directories(o.dir);
    return o;
  }
};

}  // namespace ajar::bench
