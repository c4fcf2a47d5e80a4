// Shared pieces of the benchmark harnesses (tests/bench/*_harness.cpp): a blocking wire client, an
// ajard child process, percentiles, and the result rows scripts/bench turns into one table.
// Timing is measured and printed here, never asserted: a harness fails only when something does
// not work (daemon does not start, a reply never comes, a session is dropped).
#pragma once

#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "ajar/protocol/codec.hpp"

extern char** environ;

namespace ajar::bench {

inline std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

[[noreturn]] inline void fail(const std::string& what) {
  std::fprintf(stderr, "bench: FAILED: %s\n", what.c_str());
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

// One row of the table: "ROW|figure|value|unit|baseline|ratio|target|note" on stdout.
// baseline/ratio/target may be empty. scripts/bench collects the rows of every harness.
inline void row(const std::string& figure, double value, const std::string& unit,
                std::optional<double> baseline = std::nullopt, const std::string& target = "",
                const std::string& note = "") {
  const auto format = [](char* out, std::size_t size, double x) {
    std::snprintf(out, size, std::abs(x) >= 1000 ? "%.0f" : "%.3g", x);
  };
  char v[64], b[64] = "", r[64] = "";
  format(v, sizeof v, value);
  if (baseline) {
    format(b, sizeof b, *baseline);
    if (*baseline > 0) std::snprintf(r, sizeof r, "%.2fx", value / *baseline);
  }
  std::printf("ROW|%s|%s|%s|%s|%s|%s|%s\n", figure.c_str(), v, unit.c_str(), b, r, target.c_str(),
              note.c_str());
  std::fflush(stdout);
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

class Daemon {
 public:
  // Starts `ajard --config config --listen 127.0.0.1:0 --port-file ... --state-dir ...` with its
  // log in dir/ajard.log; returns once it serves (port file written and a Hello answered).
  Daemon(const std::string& ajard, const std::string& config, const std::string& dir) : dir_(dir) {
    std::filesystem::create_directories(dir + "/state");
    const std::string port_file = dir + "/port";
    std::filesystem::remove(port_file);
    std::vector<std::string> args = {ajard,      "--config",    config,
                                     "--listen", "127.0.0.1:0", "--port-file",
                                     port_file,  "--state-dir", dir + "/state"};
    std::vector<char*> argv;
    for (auto& a : args)
      argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 2, (dir + "/ajard.log").c_str(),
                                     O_WRONLY | O_CREAT | O_APPEND, 0644);
    const std::int64_t t0 = now_ns();
    if (posix_spawn(&pid_, ajard.c_str(), &actions, nullptr, argv.data(), environ) != 0)
      fail("cannot start " + ajard);
    posix_spawn_file_actions_destroy(&actions);
    // Serving = the port file exists and a client gets its Welcome.
    for (;;) {
      std::ifstream f(port_file);
      unsigned p = 0;
      if (f >> p && p != 0) {
        port_ = static_cast<std::uint16_t>(p);
        break;
      }
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        fail("ajard exited during start; log: " + dir + "/ajard.log");
      }
      if (now_ns() - t0 > 20'000'000'000) fail("ajard did not serve within 20 s");
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    Conn c(port_);
    (void)c.hello(protocol::Role::kObserver, "bench-probe");
    exec_to_serving_ns_ = now_ns() - t0;
  }
  ~Daemon() { stop(); }
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }
  std::uint16_t port() const { return port_; }
  pid_t pid() const { return pid_; }
  std::int64_t exec_to_serving_ns() const { return exec_to_serving_ns_; }

  // VmRSS in KiB.
  long rss_kib() const { return status_field("VmRSS:"); }
  // User + system CPU time of the daemon so far, in seconds.
  double cpu_s() const {
    std::ifstream f("/proc/" + std::to_string(pid_) + "/stat");
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
    std::ifstream f("/proc/" + std::to_string(pid_) + "/status");
    std::string line;
    while (std::getline(f, line))
      if (line.rfind(name, 0) == 0)
        return std::strtol(line.c_str() + std::strlen(name), nullptr, 10);
    return -1;
  }

  std::string dir_;
  pid_t pid_ = -1;
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
