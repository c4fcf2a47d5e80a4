// TLS cost: one ajar_client's Ping -> Pong round trip through the server over mutual TLS 1.3 vs
// the same over plaintext, in one run, in alternating blocks (plaintext, TLS, plaintext, ...;
// harness.hpp: the median of the block ratios, threads pinned the same way for both).
// Certificates are made by scripts/make-certs in a temporary directory. Prints the ROW lines
// scripts/bench puts in its table (target p99 <= 1.3x, docs/performance.md).
// --smoke: 3 blocks of 100 (ctest); --blocks N otherwise (default 20 blocks of 1000 each).
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
  int blocks = 2 * ajar::bench::kMinBlocks, per_block = 1000;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--smoke") {
      blocks = 3;
      per_block = 100;
    } else if (a == "--blocks" && i + 1 < argc) {
      blocks = std::max(1, std::atoi(argv[++i]));
    }
  }
  const ajar::bench::Placement where = ajar::bench::placement();
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
  // Both servers' I/O threads on the server CPU, both clients' I/O threads and this thread on
  // the client CPU (created while pinned there): the same placement for plaintext and TLS.
  ajar::bench::pin_this_thread(where.server);
  ajar::test::ServerThread plain_server(plain_engine, ajar::daemon::ServerOptions{});
  ajar::test::ServerThread tls_server(tls_engine, tls_options);
  ajar::bench::pin_this_thread(where.client);

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

  auto run = [](ajar::client::Client& c, int n) {
    std::vector<std::int64_t> out;
    for (int i = 0; i < n; ++i) {
      const auto start = ajar::bench::now_ns();
      const auto r = c.request(ajar::protocol::Ping{static_cast<std::uint64_t>(i)});
      const auto ns = ajar::bench::now_ns() - start;
      if (!r.ok()) return std::vector<std::int64_t>{};
      out.push_back(ns);
    }
    return out;
  };
  (void)run(plain, per_block);  // warm-up, discarded
  (void)run(tls, per_block);
  ajar::bench::SampleBlocks b;  // A (plaintext) B (TLS) A B ...
  for (int i = 0; i < blocks; ++i) {
    auto base = run(plain, per_block);
    auto subject = run(tls, per_block);
    if (base.empty() || subject.empty()) return fail("Ping failed");
    b.add(base, subject);
  }
  ajar::bench::info("TLS vs plaintext Ping: " + std::to_string(blocks) + " blocks of " +
                    std::to_string(per_block) + " per side (ajar_client, in-process server); " +
                    where.describe() + "; load average " + ajar::bench::load_average());
  ajar::bench::latency_rows("Ping RTT over mutual TLS 1.3", b, "plaintext", "", "<= 1.3x");
  std::error_code ignored;
  std::filesystem::remove_all(dir, ignored);
  return 0;
}
