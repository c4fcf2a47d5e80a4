// The end-to-end tests' common setup (tests/daemon/e2e_*_test.cpp, tests/tls/tls_e2e_test.cpp):
// ajard in process (the real engine behind the real server on 127.0.0.1 and a free port, over TLS
// when the config sets network.tls), a temporary directory for the state file and configs, and the
// fixtures that run a test once per driver kind (mock and simulated) or on mock drivers only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "ajar/daemon/engine.hpp"
#include "test_client_e2e.hpp"
#include "test_client_harness.hpp"

namespace ajar::test {

// The real engine on the config's drivers, served by ServerThread (test_client_harness.hpp).
class InProcessDaemon {
 public:
  explicit InProcessDaemon(const daemon::Config& config)
      : engine_(daemon::make_engine(config)),
        server_(std::make_unique<ServerThread>(*engine_,
                                               daemon::ServerOptions::from(config.network))) {}
  ~InProcessDaemon() { stop(); }
  InProcessDaemon(const InProcessDaemon&) = delete;
  InProcessDaemon& operator=(const InProcessDaemon&) = delete;

  // Stops the server and shuts the engine down (it persists its state); only the engine remains.
  void stop() { server_.reset(); }
  std::uint16_t port() const { return server_->port(); }
  daemon::Engine& engine() { return *engine_; }
  ServerThread& server() { return *server_; }
  std::size_t session_count() { return server_->session_count(); }

 private:
  std::unique_ptr<daemon::Engine> engine_;
  std::unique_ptr<ServerThread> server_;
};

// A test run once per driver kind: INSTANTIATE_TEST_SUITE_P(Drivers, Suite, kE2eDriverKinds,
// driver_name) names the runs ".../mock" and ".../sim".
class EndToEndTest : public ::testing::TestWithParam<drivers::DriverKind> {
 protected:
  daemon::Config config(double speedup = 10.0) {
    return e2e_config(GetParam(), dir_.path(), speedup);
  }
  TempDir dir_;
};

inline const auto kE2eDriverKinds =
    ::testing::Values(drivers::DriverKind::kMock, drivers::DriverKind::kSim);

inline std::string driver_name(const ::testing::TestParamInfo<drivers::DriverKind>& p) {
  return kind_name(p.param);
}

// A test on mock drivers only (what it proves does not depend on the driver kind), in process or
// against the ajard binary (write_config).
class EndToEndOnMock : public ::testing::Test {
 protected:
  daemon::Config config(double speedup) {
    return e2e_config(drivers::DriverKind::kMock, dir_.path(), speedup);
  }
  // config(speedup) as a YAML file in the test's directory, for ajard --config; returns its path.
  std::string write_config(double speedup, const std::string& name = "ajard.yaml") {
    const std::string path = dir_.path() + "/" + name;
    std::ofstream(path) << daemon::to_yaml(config(speedup));
    return path;
  }
  TempDir dir_;
};

}  // namespace ajar::test
