// The real ajard binary as a subprocess: command line and exit codes, serving on a kernel-chosen
// port (--listen 127.0.0.1:0 --port-file), SIGTERM exits 0 after persisting, a restart restores the
// parameters with nothing moving.
#include <fstream>

#include <gtest/gtest.h>

#include "ajard_process.hpp"
#include "e2e_fixture.hpp"

namespace ajar::test {
namespace {

using protocol::ProcedureState;
using protocol::Role;

class AjardBinary : public EndToEndOnMock {
 protected:
  std::string path(const std::string& name) const { return dir_.path() + "/" + name; }
};

TEST_F(AjardBinary, HelpDescribesEveryOptionAndVersionPrintsTheVersion) {
  AjardProcess help({"--help"}, dir_.path(), "help");
  ASSERT_EQ(help.wait_exit(), 0);
  for (const char* option : {"--config", "--check-config", "--listen", "--port-file", "--state-dir",
                             "--version", "--help", "SIGTERM", "SIGHUP"}) {
    EXPECT_NE(help.out().find(option), std::string::npos) << option;
  }
  AjardProcess version({"--version"}, dir_.path(), "version");
  ASSERT_EQ(version.wait_exit(), 0);
  EXPECT_TRUE(version.out().starts_with("ajard "));
}

TEST_F(AjardBinary, UsageErrorsExitTwo) {
  AjardProcess none({}, dir_.path(), "none");
  EXPECT_EQ(none.wait_exit(), 2);
  AjardProcess unknown({"--frobnicate"}, dir_.path(), "unknown");
  EXPECT_EQ(unknown.wait_exit(), 2);
  EXPECT_NE(unknown.err().find("--frobnicate"), std::string::npos);
  AjardProcess bad_listen({"--config", write_config(20.0), "--listen", "localhost"}, dir_.path(),
                          "listen");
  EXPECT_EQ(bad_listen.wait_exit(), 2);
  EXPECT_NE(bad_listen.err().find("--listen"), std::string::npos);
}

TEST_F(AjardBinary, CheckConfigPrintsTheEffectiveConfig) {
  AjardProcess check({"--check-config", write_config(20.0), "--listen", "127.0.0.1:9999"},
                     dir_.path(), "check");
  ASSERT_EQ(check.wait_exit(), 0) << check.err();
  EXPECT_NE(check.out().find("network"), std::string::npos);
  EXPECT_NE(check.out().find("9999"), std::string::npos);  // overrides are applied
}

TEST_F(AjardBinary, ABadConfigExitsTwoNamingTheFileAndKey) {
  const std::string bad = path("bad.yaml");
  std::ofstream(bad) << "network:\n  port: seventy\n";
  AjardProcess check({"--check-config", bad}, dir_.path(), "bad-check");
  EXPECT_EQ(check.wait_exit(), 2);
  EXPECT_NE(check.err().find("bad.yaml"), std::string::npos) << check.err();
  EXPECT_NE(check.err().find("port"), std::string::npos) << check.err();
  AjardProcess run({"--config", bad}, dir_.path(), "bad-run");
  EXPECT_EQ(run.wait_exit(), 2);
  AjardProcess missing({"--config", path("does-not-exist.yaml")}, dir_.path(), "missing");
  EXPECT_EQ(missing.wait_exit(), 2);
}

TEST_F(AjardBinary, AStartUpFailureExitsOneNamingWhatFailed) {
  // Take a port, then ask ajard to listen on it.
  boost::asio::io_context io;
  boost::asio::ip::tcp::acceptor taken(io, {boost::asio::ip::make_address("127.0.0.1"), 0});
  const auto port = taken.local_endpoint().port();
  AjardProcess busy({"--config", write_config(20.0), "--listen",
                     "127.0.0.1:" + std::to_string(port), "--state-dir", path("state")},
                    dir_.path(), "busy");
  EXPECT_EQ(busy.wait_exit(), 1);
  EXPECT_NE(busy.err().find("cannot listen on 127.0.0.1:" + std::to_string(port)),
            std::string::npos)
      << busy.err();
}

TEST_F(AjardBinary, ServesPersistsOnSigtermAndRestoresAfterARestart) {
  const std::string config = write_config(20.0);
  const std::vector<std::string> args{"--config",    config,       "--listen",    "127.0.0.1:0",
                                      "--port-file", path("port"), "--state-dir", path("state")};
  {
    AjardProcess ajard(args, dir_.path(), "first");
    const auto port = wait_for_port_file(path("port"), ajard);
    ASSERT_TRUE(port) << ajard.err();
    TestClient controller(*port);
    EXPECT_EQ(controller.hello(Role::kController, 0x77).granted_role, Role::kController);
    measure_door(controller);
    ajard.signal(SIGTERM);
    EXPECT_EQ(ajard.wait_exit(), 0) << ajard.err();
    EXPECT_TRUE(controller.wait_closed());
  }
  std::remove(path("port").c_str());
  AjardProcess ajard(args, dir_.path(), "second");
  const auto port = wait_for_port_file(path("port"), ajard);
  ASSERT_TRUE(port) << ajard.err();
  TestClient observer(*port);
  observer.hello(Role::kObserver);
  const auto status = observer.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_TRUE(status.restored_from_disk);
  EXPECT_TRUE(status.has_width && status.has_handle && status.has_plane);
  EXPECT_EQ(status.state, ProcedureState::kReadyToAlign);
  observer.request_as<protocol::Ack>(protocol::Subscribe{50});
  ASSERT_TRUE(observer.wait_telemetry(2));
  EXPECT_FALSE(observer.last_telemetry()->moving);
  ajard.signal(SIGINT);
  EXPECT_EQ(ajard.wait_exit(), 0) << ajard.err();
}

TEST_F(AjardBinary, SighupReloadsTheLoggingLevelAndKeepsServing) {
  const std::string config = write_config(20.0);
  AjardProcess ajard({"--config", config, "--listen", "127.0.0.1:0", "--port-file", path("port"),
                      "--state-dir", path("state")},
                     dir_.path(), "hup");
  const auto port = wait_for_port_file(path("port"), ajard);
  ASSERT_TRUE(port) << ajard.err();
  {
    auto c = e2e_config(drivers::DriverKind::kMock, dir_.path(), 20.0);
    c.logging.level = daemon::LogLevel::kDebug;
    c.network.max_clients = 7;  // not reloadable: named as needing a restart
    std::ofstream(config) << daemon::to_yaml(c);
  }
  ajard.signal(SIGHUP);
  ASSERT_TRUE(eventually([&] {
    return ajard.err().find(
               "SIGHUP: applied logging.level (now debug); not applied, restart ajard "
               "to apply: network.max_clients") != std::string::npos;
  })) << ajard.err();
  TestClient client(*port);
  EXPECT_EQ(client.hello(Role::kObserver).granted_role, Role::kObserver);
  ajard.signal(SIGTERM);
  EXPECT_EQ(ajard.wait_exit(), 0);
}

}  // namespace
}  // namespace ajar::test
