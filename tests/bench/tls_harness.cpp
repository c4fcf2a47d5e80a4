// TLS cost: one ajar_client's Ping -> Pong round trip through the server over mutual TLS 1.3 vs
// the same over plaintext, in one run, interleaved in batches (plaintext, TLS, plaintext, ...) so
// both see the same machine load. Certificates are made by scripts/make-certs in a temporary
// directory. Prints p50/p99 of each and the TLS/plaintext ratio (target p99 <= 1.3x,
// docs/performance.md), and the ROW lines scripts/bench puts in its table (harness.hpp).
// --smoke: a few hundred samples (ctest), --samples N otherwise (default 20000).
#include <utility>  // before Asio (asio issue 944)

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "ajar/client/client.hpp"
#include "harness.hpp"
#include "test_client_harness.hpp"

namespace {

using namespace std::chrono_literals;

int fail(const std::string& what) {
  std::fprintf(stderr, "tls_harness: %s\n", what.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  int samples = 20000;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--smoke") {
      samples = 400;
    } else if (a == "--samples" && i + 1 < argc) {
      samples = std::max(100, std::atoi(argv[++i]));
    }
  }
  std::string pattern = (std::filesystem::temp_directory_path() / "ajar-tls-bench-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) return fail("mkdtemp");
  const std::string dir = pattern;
  const std::string make = std::string(AJAR_SOURCE_DIR "/scripts/make-certs --dir ") + dir;
  for (const char* step : {" ca", " daemon 127.0.0.1", " operator bench controller"}) {
    if (std::system((make + step + " >/dev/null").c_str()) != 0) return fail("make-certs failed");
  }
  spdlog::set_level(spdlog::level::warn);

  ajar::test::FakeEngine plain_engine;
  ajar::test::FakeEngine tls_engine;
  ajar::daemon::ServerOptions tls_options;
  tls_options.tls.enabled = true;
  tls_options.tls.certificate = dir + "/ajard.crt";
  tls_options.tls.private_key = dir + "/ajard.key";
  tls_options.tls.ca = dir + "/ca.crt";
  ajar::test::ServerThread plain_server(plain_engine, ajar::daemon::ServerOptions{});
  ajar::test::ServerThread tls_server(tls_engine, tls_options);

  ajar::client::ClientOptions options;
  options.retries = 0;
  ajar::client::Client plain(options);
  options.tls.ca = dir + "/ca.crt";
  options.tls.certificate = dir + "/bench.crt";
  options.tls.private_key = dir + "/bench.key";
  ajar::client::Client tls(options);
  if (auto c = plain.connect({"127.0.0.1", plain_server.port()}); !c)
    return fail(c.error().message);
  if (auto c = tls.connect({"127.0.0.1", tls_server.port()}); !c) return fail(c.error().message);
  if (!plain.hello(ajar::protocol::Role::kObserver).ok() ||
      !tls.hello(ajar::protocol::Role::kObserver).ok())
    return fail("Hello refused");

  std::vector<std::int64_t> plain_ns;
  std::vector<std::int64_t> tls_ns;
  constexpr int kBatch = 100;
  auto run = [](ajar::client::Client& c, std::vector<std::int64_t>& out, int n) {
    for (int i = 0; i < n; ++i) {
      const auto start = ajar::bench::now_ns();
      const auto r = c.request(ajar::protocol::Ping{static_cast<std::uint64_t>(i)});
      const auto ns = ajar::bench::now_ns() - start;
      if (!r.ok()) return false;
      out.push_back(ns);
    }
    return true;
  };
  run(plain, plain_ns, kBatch);  // warm-up, discarded
  run(tls, tls_ns, kBatch);
  plain_ns.clear();
  tls_ns.clear();
  for (int done = 0; done < samples; done += kBatch) {
    if (!run(plain, plain_ns, kBatch) || !run(tls, tls_ns, kBatch)) return fail("Ping failed");
  }
  const auto plain_q = ajar::bench::quantiles(plain_ns);
  const auto tls_q = ajar::bench::quantiles(tls_ns);
  const double p50_plain = plain_q.p50 / 1e3;
  const double p99_plain = plain_q.p99 / 1e3;
  const double p50_tls = tls_q.p50 / 1e3;
  const double p99_tls = tls_q.p99 / 1e3;
  std::printf("# Ping round trip through the server (ajar_client, loopback), %zu samples each\n",
              plain_ns.size());
  std::printf("# %-10s %10s %10s\n", "transport", "p50 us", "p99 us");
  std::printf("# %-10s %10.1f %10.1f\n", "plaintext", p50_plain, p99_plain);
  std::printf("# %-10s %10.1f %10.1f\n", "TLS 1.3", p50_tls, p99_tls);
  std::printf("# TLS/plaintext: p50 %.2fx, p99 %.2fx (target p99 <= 1.3x)\n", p50_tls / p50_plain,
              p99_tls / p99_plain);
  const std::string note = "vs plaintext, same run (" + std::to_string(plain_ns.size()) +
                           " Pings each, ajar_client, in-process server)";
  ajar::bench::row("Ping RTT over mutual TLS 1.3, p50", p50_tls, "us", p50_plain, "", note);
  ajar::bench::row("Ping RTT over mutual TLS 1.3, p99", p99_tls, "us", p99_plain, "<= 1.3x", note);
  std::error_code ignored;
  std::filesystem::remove_all(dir, ignored);
  return 0;
}
