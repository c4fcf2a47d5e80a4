// Support of the TLS tests (issue 13): certificates made by scripts/make-certs at test time, the
// in-process server (ServerThread of tests/daemon), the daemon's log lines, client options.
#pragma once

#include <utility>  // before Asio (asio issue 944)

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include "ajar/client/client.hpp"
#include "ajar/daemon/config.hpp"
#include "ajar/daemon/tls.hpp"
#include "fake_door.hpp"
#include "test_client_harness.hpp"

namespace ajar::test {

using namespace std::chrono_literals;
using ajar::testing::TempDir;

// The certificates of one test: a CA (with a CRL revoking "eve"), the daemon's certificate for
// 127.0.0.1, operators, an expired one, and an operator of another CA.
class Pki {
 public:
  Pki() {
    const std::string& d = dir_.path();
    run("ca");
    run("daemon 127.0.0.1 localhost");
    for (const char* op : {"alice controller", "bob observer", "carol observer", "dave controller",
                           "eve controller"}) {
      run(std::string("operator ") + op);
    }
    run("--valid 20200101000000Z 20200102000000Z operator old controller");
    run("revoke eve");
    other_ = d + "/other";
    run("ca --name Other", other_);
    run("operator mallory controller", other_);
  }

  std::string path(const std::string& file) const { return dir_.path() + "/" + file; }

  // The daemon's TLS policy of these tests.
  daemon::TlsConfig server_config() const {
    daemon::TlsConfig t;
    t.enabled = true;
    t.certificate = path("ajard.crt");
    t.private_key = path("ajard.key");
    t.ca = path("ca.crt");
    t.crl = path("ca.crl");
    t.handshake_timeout_s = 10;
    using K = daemon::TlsIdentity::Kind;
    t.identities = {{{K::kCommonName, "alice"}, true, true},
                    {{K::kCommonName, "bob"}, false, true},
                    {{K::kCommonName, "carol"}, false, false}};
    t.deny = {{K::kCommonName, "dave"}};
    t.unlisted_may_observe = false;
    return t;
  }

  // Client options presenting NAME's certificate ("" = none; other CA's names with `other`).
  client::TlsOptions client_tls(const std::string& name, bool other_ca = false) const {
    client::TlsOptions o;
    o.ca = path("ca.crt");
    if (!name.empty()) {
      const std::string base = other_ca ? other_ + "/" + name : path(name);
      o.certificate = base + ".crt";
      o.private_key = base + ".key";
    }
    return o;
  }

  // scripts/make-certs ARGS on this PKI (or `dir`'s), e.g. "revoke bob".
  void run(const std::string& args, const std::string& dir = "") {
    const std::string command = std::string(AJAR_SOURCE_DIR "/scripts/make-certs --dir ") +
                                (dir.empty() ? dir_.path() : dir) + " " + args + " >/dev/null";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
  }

 private:
  TempDir dir_;
  std::string other_;
};

using TlsServer = ServerThread;

// SIGHUP's reload of network.tls, on the server's I/O thread.
inline void reload(TlsServer& server, const daemon::TlsConfig& tls) {
  server.call([&] {
    server.server().reload_tls(tls);
    return 0;
  });
}

// The daemon's log lines, to check that a refusal names the peer and the reason.
class LogCapture {
 public:
  LogCapture() : sink_(std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(512)) {
    spdlog::default_logger()->sinks().push_back(sink_);
  }
  ~LogCapture() {
    auto& sinks = spdlog::default_logger()->sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink_), sinks.end());
  }
  bool contains(const std::string& a, const std::string& b = "") const {
    for (const auto& line : sink_->last_formatted()) {
      if (line.find(a) != std::string::npos && line.find(b) != std::string::npos) return true;
    }
    return false;
  }
  std::string all() const {
    std::string text;
    for (const auto& line : sink_->last_formatted())
      text += line;
    return text;
  }

 private:
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_;
};

inline client::ClientOptions options_with(const client::TlsOptions& tls,
                                          const std::string& name = "tls-test") {
  client::ClientOptions o;
  o.connect_timeout = 5000ms;
  o.request_timeout = 5000ms;
  o.retries = 0;
  o.client_name = name;
  o.tls = tls;
  return o;
}

inline daemon::ServerOptions server_options(const Pki& pki) {
  daemon::ServerOptions o;
  o.max_clients = 8;
  o.session.linger = 500ms;
  o.tls = pki.server_config();
  return o;
}

inline const protocol::ErrorReply* error_of(const client::Response& r) {
  return r.outcome == client::CallOutcome::kRefused ? &r.error : nullptr;
}

}  // namespace ajar::test
