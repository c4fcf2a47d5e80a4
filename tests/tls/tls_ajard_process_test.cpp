// The real ajard binary with network.tls (issue 13): the whole procedure by the real ajarctl with
// --ca/--cert/--key; SIGHUP with a CRL that revokes a connected operator closes that session; an
// expired CRL is warned about on SIGHUP and at the next start; a handshake pending across a
// revoking SIGHUP is refused (issue 22, item 3).
#include <utility>  // before Asio (asio issue 944)

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "ajard_process.hpp"
#include "test_client_e2e.hpp"
#include "tls_stepped_client.hpp"
#include "tls_support.hpp"

namespace ajar::test {
namespace {

using client::Client;
using protocol::Role;

// A TLS ajard on mock drivers: its config file and command line in `dir`.
std::vector<std::string> tls_ajard_args(const Pki& pki, const TempDir& dir) {
  daemon::Config c = e2e_config(drivers::DriverKind::kMock, dir.path(), 20.0);
  c.network.tls = pki.server_config();
  const std::string config = dir.path() + "/ajard.yaml";
  std::ofstream(config) << daemon::to_yaml(c);
  return {"--config",           config,        "--listen",       "127.0.0.1:0", "--port-file",
          dir.path() + "/port", "--state-dir", dir.path() + "/s"};
}

#ifdef AJARCTL_PATH
// ajarctl ARGS with NAME's certificate; returns the exit code, output in `out`.
int ajarctl(const Pki& pki, const std::string& name, std::uint16_t port, const std::string& args,
            const TempDir& dir, std::string& out) {
  const std::string path = dir.path() + "/ajarctl-" + name + ".out";
  const std::string command =
      std::string(AJARCTL_PATH) + " --connect 127.0.0.1:" + std::to_string(port) + " --ca " +
      pki.path("ca.crt") + " --cert " + pki.path(name + ".crt") + " --key " +
      pki.path(name + ".key") + " " + args + " >" + path + " 2>&1";
  const int status = std::system(command.c_str());
  out = read_text_file(path);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(TlsAjard, AjarctlWithItsCertificateRunsTheWholeProcedure) {
  Pki pki;
  TempDir dir;
  AjardProcess ajard(tls_ajard_args(pki, dir), dir.path(), "ajard");
  const auto port = wait_for_port_file(dir.path() + "/port", ajard);
  ASSERT_TRUE(port) << ajard.err();
  const std::string script = dir.path() + "/procedure.txt";
  std::ofstream(script) << "measure width 1.0 0.45 0.3 1.0 -0.45 0.3\n"
                           "measure handle 0.95 -0.35 0.3 0.95 -0.23 0.3\n"
                           "measure plane 0.985 0.0199 0 0.9957 0.3199 0 0.9932 0.2699 0.7 "
                           "0.98 -0.25 0.6\n"
                           "align\n"
                           "contact 0.8 0.0 0.3\n"
                           "engage\n";
  std::string out;
  ASSERT_EQ(ajarctl(pki, "alice", *port, "--frame base script " + script, dir, out), 0) << out;
  EXPECT_EQ(ajarctl(pki, "bob", *port, "--json status", dir, out), 0) << out;
  EXPECT_NE(out.find("\"state\":\"engaged\""), std::string::npos) << out;
  // An observer certificate cannot command; its emergency stop works.
  EXPECT_NE(ajarctl(pki, "bob", *port, "reset", dir, out), 0);
  EXPECT_NE(out.find("NOT_CONTROLLER"), std::string::npos) << out;
  EXPECT_EQ(ajarctl(pki, "bob", *port, "estop", dir, out), 0) << out;
  // A key readable by others is refused before anything is sent.
  ASSERT_EQ(::chmod(pki.path("alice.key").c_str(), 0644), 0);
  EXPECT_NE(ajarctl(pki, "alice", *port, "status", dir, out), 0);
  EXPECT_NE(out.find("accessible to group or others"), std::string::npos) << out;
  EXPECT_TRUE(ajard.err_shows("authenticated as cn:alice")) << ajard.err();
  ajard.signal(SIGTERM);
  EXPECT_EQ(ajard.wait_exit(), 0) << ajard.err();
}
#endif

TEST(TlsAjard, SighupClosesARevokedSessionAndAnExpiredCrlIsWarnedOnReloadAndAtStart) {
  Pki pki;
  TempDir dir;
  const std::string port_file = dir.path() + "/port";
  const std::vector<std::string> args = tls_ajard_args(pki, dir);
  {
    AjardProcess ajard(args, dir.path(), "first");
    const auto port = wait_for_port_file(port_file, ajard);
    ASSERT_TRUE(port) << ajard.err();
    EXPECT_EQ(ajard.err().find("EXPIRED"), std::string::npos) << ajard.err();
    Client alice(options_with(pki.client_tls("alice"), "alice"));
    ASSERT_TRUE(alice.connect({"127.0.0.1", *port}).ok());
    ASSERT_TRUE(alice.hello(Role::kController).ok());
    Client bob(options_with(pki.client_tls("bob"), "bob"));
    ASSERT_TRUE(bob.connect({"127.0.0.1", *port}).ok());
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

// Issue 22, item 3: a client that withholds its second flight (or only its Finished) until the
// operator has revoked its certificate and sent SIGHUP was verified under the CRL of its accept:
// Welcome(controller), Drive acknowledged. Now both are refused, like a fresh handshake.
TEST(TlsAjard, AHandshakeWithheldAcrossARevokingSighupIsRefused) {
  Pki pki;
  TempDir dir;
  AjardProcess ajard(tls_ajard_args(pki, dir), dir.path(), "ajard");
  const auto port = wait_for_port_file(dir.path() + "/port", ajard);
  ASSERT_TRUE(port) << ajard.err();
  auto alice = [&] {
    auto c = std::make_unique<SteppedTlsClient>(*port, pki.path("ca.crt"), pki.path("alice.crt"),
                                                pki.path("alice.key"));
    EXPECT_TRUE(c->send_client_hello()) << c->failure();
    EXPECT_TRUE(c->read_daemon_flight()) << c->failure();
    EXPECT_EQ(c->records_left(), 4U);
    return c;
  };
  auto whole_flight_withheld = alice();
  auto finished_withheld = alice();
  for (int i = 0; i < 3; ++i)
    finished_withheld->send_next_record();  // ChangeCipherSpec, Certificate, CertificateVerify
  ASSERT_TRUE(eventually([&] { return finished_withheld->unread_at_daemon() == 0L; }));

  pki.run("revoke alice");
  ajard.signal(SIGHUP);
  ASSERT_TRUE(eventually([&] {
    return ajard.err().find("TLS policy reloaded") != std::string::npos;
  })) << ajard.err();

  for (auto* c : {whole_flight_withheld.get(), finished_withheld.get()}) {
    while (c->records_left() > 0)
      c->send_next_record();
    c->send(hello_as(Role::kController, 0, true), 1);
    const auto welcome = c->reply_to(1);
    if (welcome) {
      const auto* error = std::get_if<protocol::ErrorReply>(&*welcome);
      ASSERT_NE(error, nullptr) << "admitted with a revoked certificate: "
                                << protocol::to_string(protocol::type_of(*welcome));
      EXPECT_EQ(error->field.view(), "certificate");
      EXPECT_NE(error->message.view().find("certificate revoked"), std::string_view::npos)
          << error->message.view();
    } else {
      EXPECT_NE(c->failure().find("certificate revoked"), std::string::npos) << c->failure();
    }
    c->send(protocol::Drive{0.05, 0.0}, 2);
    const auto drive = c->reply_to(2);
    EXPECT_FALSE(drive && std::holds_alternative<protocol::Ack>(*drive)) << "Drive acknowledged";
  }
  EXPECT_TRUE(ajard.err_shows("certificate revoked")) << ajard.err();
  EXPECT_EQ(ajard.err().find("authenticated as cn:alice"), std::string::npos) << ajard.err();
  // The others are served as before.
  Client bob(options_with(pki.client_tls("bob"), "bob"));
  ASSERT_TRUE(bob.connect({"127.0.0.1", *port}).ok());
  EXPECT_TRUE(bob.hello(Role::kObserver).ok());
  ajard.signal(SIGTERM);
  EXPECT_EQ(ajard.wait_exit(), 0) << ajard.err();
}

}  // namespace
}  // namespace ajar::test
