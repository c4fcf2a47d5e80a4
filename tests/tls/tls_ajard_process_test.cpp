// The real ajard binary with network.tls (issue 13): SIGHUP with a CRL that revokes a connected
// operator closes that session; an expired CRL is warned about on SIGHUP and at the next start.
#include <utility>  // before Asio (asio issue 944)

#include <signal.h>

#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "ajard_process.hpp"
#include "test_client_e2e.hpp"
#include "tls_support.hpp"

namespace ajar::test {
namespace {

using client::Client;
using protocol::Role;

TEST(TlsAjard, SighupClosesARevokedSessionAndAnExpiredCrlIsWarnedOnReloadAndAtStart) {
  Pki pki;
  TempDir dir;
  const std::string config = dir.path() + "/ajard.yaml";
  const std::string port_file = dir.path() + "/port";
  daemon::Config c = e2e_config(drivers::DriverKind::kMock, dir.path(), 20.0);
  c.network.tls = pki.server_config();
  std::ofstream(config) << daemon::to_yaml(c);
  const std::vector<std::string> args{"--config",    config,    "--listen",    "127.0.0.1:0",
                                      "--port-file", port_file, "--state-dir", dir.path() + "/s"};
  {
    AjardProcess ajard(args, dir.path(), "first");
    const auto port = wait_for_port_file(port_file, ajard);
    ASSERT_TRUE(port) << ajard.err();
    EXPECT_EQ(ajard.err().find("EXPIRED"), std::string::npos) << ajard.err();
    Client alice(options_with(pki.client_tls("alice"), "alice"));
    ASSERT_EQ(alice.connect({"127.0.0.1", *port}), "");
    ASSERT_TRUE(alice.hello(Role::kController).ok());
    Client bob(options_with(pki.client_tls("bob"), "bob"));
    ASSERT_EQ(bob.connect({"127.0.0.1", *port}), "");
    ASSERT_TRUE(bob.hello(Role::kObserver).ok());

    pki.run("revoke alice");
    ajard.signal(SIGHUP);
    EXPECT_TRUE(alice.wait_closed(20s));
    EXPECT_TRUE(eventually([&] {
      return ajard.err().find("TLS: closing session") != std::string::npos &&
             ajard.err().find("cn:alice") != std::string::npos &&
             ajard.err().find("certificate revoked") != std::string::npos;
    })) << ajard.err();
    EXPECT_TRUE(bob.request(protocol::Ping{1}).ok());

    pki.run("--valid 20200101000000Z 20200102000000Z crl");
    ajard.signal(SIGHUP);
    EXPECT_TRUE(eventually([&] {
      return ajard.err().find("EXPIRED at 2020-01-02 00:00:00 UTC") != std::string::npos;
    })) << ajard.err();
    ajard.signal(SIGTERM);
    EXPECT_EQ(ajard.wait_exit(), 0) << ajard.err();
  }
  std::remove(port_file.c_str());
  AjardProcess ajard(args, dir.path(), "second");
  ASSERT_TRUE(wait_for_port_file(port_file, ajard)) << ajard.err();
  const std::string log = ajard.err();
  const auto warned = log.find("EXPIRED at 2020-01-02");
  EXPECT_NE(warned, std::string::npos) << log;
  EXPECT_LT(warned, log.find("ajard ready")) << "not a start-up warning:\n" << log;
  ajard.signal(SIGTERM);
  EXPECT_EQ(ajard.wait_exit(), 0) << ajard.err();
}

}  // namespace
}  // namespace ajar::test
