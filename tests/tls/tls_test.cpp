// Mutual TLS between ajar_client and the server (issue 13), over loopback with certificates made
// by scripts/make-certs at test time: who gets in (and why not, in the log), what each identity
// may do, revocation and its reload, plaintext rules, and handshake slowloris.
#include <utility>  // before Asio (asio issue 944)

#include <sys/stat.h>

#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/ip/tcp.hpp>
#include <gtest/gtest.h>

#include "ajar/daemon/engine.hpp"
#include "tls_support.hpp"

namespace ajar::test {
namespace {

using client::CallOutcome;
using client::Client;
using client::ClientOptions;
using protocol::MessageType;
using protocol::Role;

class Tls : public ::testing::Test {
 protected:
  LogCapture log_;
  Pki pki_;
  FakeEngine engine_;
  std::unique_ptr<TlsServer> server_ = std::make_unique<TlsServer>(engine_, server_options(pki_));

  // A greeted observer that must not notice what happens to others.
  std::unique_ptr<Client> bystander() {
    auto c = std::make_unique<Client>(options_with(pki_.client_tls("bob"), "bystander"));
    EXPECT_TRUE(c->connect({"127.0.0.1", server_->port()}).ok());
    EXPECT_TRUE(c->hello(Role::kObserver).ok());
    return c;
  }
};

TEST_F(Tls, AControllerCertificateTakesControlAndItsCommandsReachTheEngine) {
  Client c(options_with(pki_.client_tls("alice")));
  ASSERT_TRUE(c.connect({"127.0.0.1", server_->port()}).ok());
  const auto hello = c.hello(Role::kController);
  ASSERT_TRUE(hello.ok()) << hello.transport_error << hello.error.message.view();
  EXPECT_EQ(hello.get<protocol::Welcome>()->granted_role, Role::kController);
  EXPECT_TRUE(c.request(ajar::testing::good_width()).ok());
  EXPECT_TRUE(c.request(protocol::Ping{7}).ok());
  EXPECT_EQ(engine_.count(MessageType::kMeasureDoorWidth), 1U);
  EXPECT_TRUE(log_.contains("authenticated as cn:alice", "controller"));
}

// A peer that must be refused at the handshake, and the reason the daemon's log must give.
struct Refusal {
  const char* name;
  std::string certificate;  // operator name; "" none
  bool other_ca;
  bool tls;
  const char* logged;
};

class TlsRefused : public Tls, public ::testing::WithParamInterface<Refusal> {};

TEST_P(TlsRefused, BeforeAnyFrameNothingMovesAndOthersAreUnaffected) {
  const Refusal& r = GetParam();
  auto other = bystander();
  client::TlsOptions tls = pki_.client_tls(r.certificate, r.other_ca);
  if (!r.tls) tls = {};
  Client c(options_with(tls, r.name));
  if (c.connect({"127.0.0.1", server_->port()}).ok()) {
    // TLS 1.3: the client's side of the handshake may finish before the daemon checked the
    // certificate; then the daemon's alert ends the connection. Stop is executed from any
    // session that reached the hub, even un-greeted: it must not get that far.
    c.send_envelope(protocol::Envelope{1, 0, protocol::Stop{}});
    const auto hello = c.hello(Role::kController, true);
    EXPECT_FALSE(hello.ok());
    EXPECT_EQ(hello.outcome, CallOutcome::kDisconnected) << hello.transport_error;
  }
  EXPECT_TRUE(eventually([&] { return log_.contains("TLS handshake with 127.0.0.1:", r.logged); }))
      << "log:\n"
      << log_.all();
  EXPECT_TRUE(engine_.commands().empty()) << "a frame of a refused peer reached the engine";
  EXPECT_TRUE(other->request(protocol::Ping{1}).ok());
  EXPECT_TRUE(eventually([&] { return server_->session_count() == 1; }));
}

INSTANTIATE_TEST_SUITE_P(
    Peers, TlsRefused,
    ::testing::Values(Refusal{"NoCertificate", "", false, true, "did not return a certificate"},
                      Refusal{"AnotherCa", "mallory", true, true, "unable to get local issuer"},
                      Refusal{"Expired", "old", false, true, "certificate has expired"},
                      Refusal{"RevokedByTheCrl", "eve", false, true, "certificate revoked"},
                      Refusal{"DeniedByTheConfig", "dave", false, true, "network.tls.deny"},
                      Refusal{"PlaintextClient", "", false, false, "plaintext client"}),
    [](const auto& p) { return std::string(p.param.name); });

TEST_F(Tls, AnObserverCertificateCannotTakeControlNorCommand) {
  Client c(options_with(pki_.client_tls("bob")));
  ASSERT_TRUE(c.connect({"127.0.0.1", server_->port()}).ok());
  const auto refused = c.hello(Role::kController, true);
  ASSERT_NE(error_of(refused), nullptr);
  EXPECT_EQ(refused.error.code, ErrorCode::kNotController);
  EXPECT_EQ(refused.error.field.view(), "requested_role");
  EXPECT_NE(refused.error.message.view().find("cn:bob"), std::string_view::npos)
      << refused.error.message.view();
  ASSERT_TRUE(c.hello(Role::kObserver).ok());
  const auto command = c.request(ajar::testing::good_width());
  ASSERT_NE(error_of(command), nullptr);
  EXPECT_EQ(command.error.code, ErrorCode::kNotController);
  EXPECT_TRUE(c.request(protocol::GetStatus{}).ok());
  EXPECT_EQ(engine_.count(MessageType::kMeasureDoorWidth), 0U);
}

TEST_F(Tls, EmergencyStopWorksFromAnObserverButNotFromAnIdentityThatMayNotStop) {
  Client observer(options_with(pki_.client_tls("bob")));
  ASSERT_TRUE(observer.connect({"127.0.0.1", server_->port()}).ok());
  ASSERT_TRUE(observer.hello(Role::kObserver).ok());
  EXPECT_TRUE(observer.request(protocol::EmergencyStop{}).ok());
  EXPECT_EQ(engine_.count(MessageType::kEmergencyStop), 1U);

  Client carol(options_with(pki_.client_tls("carol")));
  ASSERT_TRUE(carol.connect({"127.0.0.1", server_->port()}).ok());
  const auto refused = carol.request(protocol::EmergencyStop{});
  ASSERT_NE(error_of(refused), nullptr);
  EXPECT_EQ(refused.error.code, ErrorCode::kNotController);
  EXPECT_NE(refused.error.message.view().find("cn:carol"), std::string_view::npos);
  EXPECT_EQ(engine_.count(MessageType::kEmergencyStop), 1U);
}

TEST_F(Tls, ARevocationReloadedAtRuntimeRefusesTheNextConnection) {
  {
    Client alice(options_with(pki_.client_tls("alice")));
    ASSERT_TRUE(alice.connect({"127.0.0.1", server_->port()}).ok());
    ASSERT_TRUE(alice.hello(Role::kController).ok());
  }
  auto policy = pki_.server_config();
  policy.deny.push_back({daemon::TlsIdentity::Kind::kCommonName, "alice"});
  reload(*server_, policy);
  Client alice(options_with(pki_.client_tls("alice")));
  if (alice.connect({"127.0.0.1", server_->port()}).ok()) {
    EXPECT_FALSE(alice.hello(Role::kController).ok());
  }
  EXPECT_TRUE(eventually([&] {
    return log_.contains("cn:alice", "denied by network.tls.deny (cn:alice)");
  })) << log_.all();
}

TEST_F(Tls, HandshakeSlowlorisDoesNotStarveARealClient) {
  // Far more silent connections than max_clients (8) and max_pending_handshakes: none of them
  // ever finishes its handshake (the deadline is 10 s, longer than the client waits).
  boost::asio::io_context io;
  std::vector<boost::asio::ip::tcp::socket> silent;
  for (int i = 0; i < 40; ++i) {
    silent.emplace_back(io);
    silent.back().connect({boost::asio::ip::make_address("127.0.0.1"), server_->port()});
    if (i % 2 == 0) {  // half of them start a ClientHello record and stall
      const std::uint8_t start[] = {0x16, 0x03, 0x01, 0x02, 0x00, 0x01};
      boost::asio::write(silent.back(), boost::asio::buffer(start));
    }
  }
  Client c(options_with(pki_.client_tls("alice")));
  ASSERT_TRUE(c.connect({"127.0.0.1", server_->port()}).ok());
  ASSERT_TRUE(c.hello(Role::kController).ok());
  EXPECT_TRUE(c.request(protocol::Ping{1}).ok());
  EXPECT_TRUE(log_.contains("TLS handshake with", "dropped unfinished"));
}

TEST_F(Tls, ATlsClientOnAPlaintextPortGetsNoSession) {
  FakeEngine plain_engine;
  TlsServer plain(plain_engine, daemon::ServerOptions{});
  Client c(options_with(pki_.client_tls("alice")));
  const auto connected = c.connect({"127.0.0.1", plain.port()});
  ASSERT_FALSE(connected.ok());
  EXPECT_EQ(connected.error().field, "endpoint");
  const std::string& why = connected.error().message;
  EXPECT_NE(why.find("TLS handshake"), std::string::npos) << why;
  EXPECT_TRUE(plain_engine.commands().empty());
  Client bystander(options_with({}));
  ASSERT_TRUE(bystander.connect({"127.0.0.1", plain.port()}).ok());
  EXPECT_TRUE(bystander.hello(Role::kObserver).ok());
}

TEST_F(Tls, TheDaemonVerifiesItsNameForTheClient) {
  auto tls = pki_.client_tls("alice");
  tls.server_name = "robot.elsewhere";  // not in ajard.crt's subjectAltName
  Client c(options_with(tls));
  const auto connected = c.connect({"127.0.0.1", server_->port()});
  ASSERT_FALSE(connected.ok());
  const std::string& why = connected.error().message;
  EXPECT_NE(why.find("TLS handshake"), std::string::npos) << why;
  EXPECT_TRUE(engine_.commands().empty());
}

TEST_F(Tls, KeysReadableByOthersAreRefusedAtBothEnds) {
  const std::string key = pki_.path("alice.key");
  ASSERT_EQ(::chmod(key.c_str(), 0644), 0);
  Client c(options_with(pki_.client_tls("alice")));
  const auto connected = c.connect({"127.0.0.1", server_->port()});
  ASSERT_FALSE(connected.ok());
  EXPECT_EQ(connected.error().field, "tls") << "refused before anything was sent";
  const std::string& why = connected.error().message;
  EXPECT_NE(why.find("accessible to group or others"), std::string::npos) << why;

  auto config = pki_.server_config();
  config.private_key = key;
  try {
    daemon::TlsAcceptor acceptor(config);
    ADD_FAILURE() << "a world-readable daemon key was accepted";
  } catch (const daemon::StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("network.tls.private_key"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("0644"), std::string::npos) << e.what();
  }
}

TEST(TlsPolicy, DenyWinsThenTheFirstListedIdentityThenUnlisted) {
  using K = daemon::TlsIdentity::Kind;
  daemon::TlsConfig policy;
  policy.identities = {{{K::kSubjectAltName, "console.site"}, true, true},
                       {{K::kCommonName, "alice"}, false, false}};
  daemon::CertificateIdentity alice{"alice", {"console.site"}, std::string(64, 'A')};
  auto a = daemon::admit(policy, alice);
  EXPECT_TRUE(a.admitted && a.access.may_control && a.access.may_stop);

  policy.deny = {{K::kSha256, std::string(64, 'A')}};
  a = daemon::admit(policy, alice);
  EXPECT_FALSE(a.admitted);
  EXPECT_NE(a.refusal.find("network.tls.deny"), std::string::npos);

  daemon::CertificateIdentity stranger{"zed", {}, std::string(64, 'B')};
  a = daemon::admit(policy, stranger);
  EXPECT_TRUE(a.admitted);
  EXPECT_FALSE(a.access.may_control);
  EXPECT_TRUE(a.access.may_stop);
  policy.unlisted_may_observe = false;
  EXPECT_FALSE(daemon::admit(policy, stranger).admitted);
}

// The plaintext rule lives in the config loader: an operator sees it before anything starts.
TEST(TlsConfig, PlaintextOffLoopbackNeedsInsecurePlaintextAndTlsNeedsItsFiles) {
  TempDir dir;
  auto load = [&](const std::string& network) {
    const std::string path = dir.path() + "/ajard.yaml";
    std::ofstream(path) << "network:\n" << network;
    return daemon::load_config(path);
  };
  EXPECT_NO_THROW(load("  bind_address: 127.0.0.1\n"));
  try {
    load("  bind_address: 0.0.0.0\n");
    ADD_FAILURE() << "plaintext on 0.0.0.0 was accepted";
  } catch (const daemon::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("network.bind_address"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("insecure_plaintext"), std::string::npos);
  }
  EXPECT_TRUE(
      load("  bind_address: 0.0.0.0\n  insecure_plaintext: true\n").network.insecure_plaintext);
  try {
    load("  bind_address: 0.0.0.0\n  tls: {enabled: true, certificate: a.crt, ca: ca.crt}\n");
    ADD_FAILURE() << "tls without a private key was accepted";
  } catch (const daemon::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("network.tls.private_key"), std::string::npos) << e.what();
  }
  const auto c = load(
      "  bind_address: 0.0.0.0\n  tls:\n    enabled: true\n    certificate: a.crt\n"
      "    private_key: a.key\n    ca: ca.crt\n    identities:\n"
      "      - {cn: alice, role: controller}\n      - {sha256: 'ab:" +
      std::string(62, 'c') + "', role: observer, may_stop: false}\n    deny: [{san: lost.site}]\n");
  ASSERT_EQ(c.network.tls.identities.size(), 2U);
  EXPECT_TRUE(c.network.tls.identities[0].may_control);
  EXPECT_EQ(c.network.tls.identities[1].identity.value, "AB" + std::string(62, 'C'));
  EXPECT_FALSE(c.network.tls.identities[1].may_stop);
  EXPECT_EQ(c.network.tls.deny.at(0).text(), "san:lost.site");
  EXPECT_THROW(load("  tls:\n    identities: [{cn: a, san: b, role: observer}]\n"),
               daemon::ConfigError);
  EXPECT_THROW(load("  tls:\n    identities: [{cn: a}]\n"), daemon::ConfigError);
}

}  // namespace
}  // namespace ajar::test
