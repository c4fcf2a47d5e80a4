// A TLS handshake pending across a reload (SIGHUP) is judged by the policy running when its
// certificate is verified and when it completes, not by the one of its accept (issue 22, item 3):
// a client that withholds its second flight, or only its Finished, across a revoking reload is
// refused; a role taken away or granted meanwhile applies; reloads while handshakes are pending
// neither crash nor wedge the server.
#include <utility>  // before Asio (asio issue 944)

#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tls_stepped_client.hpp"
#include "tls_support.hpp"

namespace ajar::test {
namespace {

using client::Client;
using protocol::Role;

class PendingHandshake : public ::testing::Test {
 protected:
  LogCapture log_;
  Pki pki_;
  FakeEngine engine_;
  std::unique_ptr<TlsServer> server_ = std::make_unique<TlsServer>(engine_, server_options(pki_));

  std::unique_ptr<SteppedTlsClient> stepped(const std::string& name) {
    return std::make_unique<SteppedTlsClient>(server_->port(), pki_.path("ca.crt"),
                                              pki_.path(name + ".crt"), pki_.path(name + ".key"));
  }

  // ClientHello sent and the daemon's flight read: the client's second flight is withheld.
  std::unique_ptr<SteppedTlsClient> withholding(const std::string& name) {
    auto c = stepped(name);
    EXPECT_TRUE(c->send_client_hello()) << c->failure();
    EXPECT_TRUE(c->read_daemon_flight()) << c->failure();
    EXPECT_EQ(c->records_left(), 4U)
        << "ChangeCipherSpec, Certificate, CertificateVerify, Finished";
    return c;
  }

  // Waits until the daemon has read and handled everything `c` sent: its socket holds nothing
  // unread, then two round trips through its I/O thread (the read's handler ran before them).
  void settle(const SteppedTlsClient& c) {
    ASSERT_TRUE(eventually([&] { return c.unread_at_daemon() == 0L; }));
    server_->call([] { return 0; });
    server_->call([] { return 0; });
  }

  void reload_with(const daemon::TlsConfig& policy) { reload(*server_, policy); }
};

TEST_F(PendingHandshake, ACertificateWithheldAcrossARevokingReloadIsRefusedLikeAFreshConnection) {
  auto alice = withholding("alice");
  pki_.run("revoke alice");
  reload_with(pki_.server_config());
  while (alice->records_left() > 0)
    alice->send_next_record();
  EXPECT_FALSE(alice->next().has_value()) << "admitted with a certificate revoked meanwhile";
  EXPECT_NE(alice->failure().find("certificate revoked"), std::string::npos) << alice->failure();
  EXPECT_TRUE(eventually([&] {
    return log_.contains("TLS handshake with", "cn:alice") &&
           log_.contains("certificate revoked", "reloaded during the handshake");
  })) << log_.all();
  EXPECT_TRUE(engine_.commands().empty());
  EXPECT_EQ(server_->session_count(), 0U);
}

TEST_F(PendingHandshake, AFinishedWithheldAcrossARevokingReloadIsRefusedAtCompletion) {
  auto alice = withholding("alice");
  for (int i = 0; i < 3; ++i)
    alice->send_next_record();  // the certificate is verified (under the old policy)
  settle(*alice);
  pki_.run("revoke alice");
  reload_with(pki_.server_config());
  alice->send_next_record();  // Finished
  ASSERT_TRUE(alice->send(hello_as(Role::kController, 0, true), 1)) << alice->failure();
  const auto reply = alice->reply_to(1);
  ASSERT_TRUE(reply.has_value()) << alice->failure();
  const auto* error = std::get_if<protocol::ErrorReply>(&*reply);
  ASSERT_NE(error, nullptr) << "not refused: " << protocol::to_string(protocol::type_of(*reply));
  EXPECT_EQ(error->code, ErrorCode::kNotController);
  EXPECT_EQ(error->field.view(), "certificate");
  EXPECT_NE(error->message.view().find("cn:alice"), std::string_view::npos);
  EXPECT_NE(error->message.view().find("certificate revoked"), std::string_view::npos)
      << error->message.view();
  // Nothing it sends is handled; the daemon closes.
  alice->send(protocol::Drive{0.1, 0.0}, 2);
  alice->send(protocol::Stop{}, 3);
  EXPECT_FALSE(alice->reply_to(2).has_value());
  EXPECT_TRUE(engine_.commands().empty());
  EXPECT_TRUE(log_.contains("refused at its completion", "reloaded during the handshake"))
      << log_.all();
  EXPECT_EQ(server_->session_count(), 0U);
}

TEST_F(PendingHandshake, AControllerGrantTakenAwayMidHandshakeIsNotGiven) {
  auto policy = pki_.server_config();
  policy.identities[0].may_control = false;  // alice: observer from now on
  for (const int withheld : {4, 1}) {        // the whole second flight; only the Finished
    SCOPED_TRACE(withheld);
    reload_with(pki_.server_config());
    auto alice = withholding("alice");
    while (alice->records_left() > static_cast<std::size_t>(withheld))
      alice->send_next_record();
    settle(*alice);
    reload_with(policy);
    while (alice->records_left() > 0)
      alice->send_next_record();
    ASSERT_TRUE(alice->send(hello_as(Role::kController, 0, true), 1));
    const auto reply = alice->reply_to(1);
    ASSERT_TRUE(reply.has_value()) << alice->failure();
    const auto* error = std::get_if<protocol::ErrorReply>(&*reply);
    ASSERT_NE(error, nullptr) << "granted " << protocol::to_string(protocol::type_of(*reply));
    EXPECT_EQ(error->code, ErrorCode::kNotController);
    EXPECT_NE(error->message.view().find("may only observe"), std::string_view::npos)
        << error->message.view();
    // What the new policy grants it: an observer may stop.
    ASSERT_TRUE(alice->send(protocol::Stop{}, 2));
    const auto stopped = alice->reply_to(2);
    ASSERT_TRUE(stopped.has_value()) << alice->failure();
    EXPECT_TRUE(std::holds_alternative<protocol::Ack>(*stopped));
  }
  EXPECT_EQ(engine_.commands(), (std::vector<protocol::MessageType>{protocol::MessageType::kStop,
                                                                    protocol::MessageType::kStop}));
}

TEST_F(PendingHandshake, AControllerGrantGivenMidHandshakeApplies) {
  auto bob = withholding("bob");  // an observer at accept
  auto policy = pki_.server_config();
  policy.identities[1].may_control = true;
  reload_with(policy);
  while (bob->records_left() > 0)
    bob->send_next_record();
  ASSERT_TRUE(bob->send(hello_as(Role::kController), 1));
  const auto reply = bob->reply_to(1);
  ASSERT_TRUE(reply.has_value()) << bob->failure();
  ASSERT_TRUE(std::holds_alternative<protocol::Welcome>(*reply));
  EXPECT_EQ(std::get<protocol::Welcome>(*reply).granted_role, Role::kController);
}

TEST_F(PendingHandshake, ACaRemovedOrAnIdentityDeniedMidHandshakeIsRefused) {
  auto without_ca = pki_.server_config();
  without_ca.ca = pki_.path("other/ca.crt");  // only the other CA is trusted now
  auto denied = pki_.server_config();
  denied.deny.push_back({daemon::TlsIdentity::Kind::kCommonName, "bob"});
  struct Case {
    daemon::TlsConfig policy;
    std::string why;  // the client sends its CA with its certificate (OpenSSL builds the chain)
  };
  for (const auto& [policy, why] :
       {Case{without_ca, "self-signed certificate in certificate chain"},
        Case{denied, "denied by network.tls.deny"}}) {
    for (const int withheld : {4, 1}) {
      SCOPED_TRACE(why + " " + std::to_string(withheld));
      reload_with(pki_.server_config());
      auto bob = withholding("bob");
      while (bob->records_left() > static_cast<std::size_t>(withheld))
        bob->send_next_record();
      settle(*bob);
      reload_with(policy);
      while (bob->records_left() > 0)
        bob->send_next_record();
      bob->send(hello_as(Role::kObserver), 1);
      const auto reply = bob->reply_to(1);
      if (reply) {  // refused at completion: the Error names why
        const auto* error = std::get_if<protocol::ErrorReply>(&*reply);
        ASSERT_NE(error, nullptr) << "admitted: " << protocol::to_string(protocol::type_of(*reply));
        EXPECT_EQ(error->field.view(), "certificate");
        EXPECT_NE(error->message.view().find(why), std::string_view::npos) << error->message.view();
        EXPECT_EQ(withheld, 1) << "the certificate came after the reload: a TLS alert expected";
      } else {
        EXPECT_EQ(withheld, 4) << "refused by an alert: " << bob->failure();
      }
      EXPECT_TRUE(eventually([&] { return log_.contains("cn:bob", why); })) << log_.all();
    }
  }
  EXPECT_TRUE(engine_.commands().empty());
}

// The lead's attack: SIGHUP while handshakes are pending at every stage, also reloads that fail;
// the server stays up, completes what the running policy admits and serves a newcomer.
TEST_F(PendingHandshake, ReloadsWhileHandshakesArePendingNeitherCrashNorWedge) {
  auto broken = pki_.server_config();
  broken.crl = pki_.path("missing.crl");
  auto stricter = pki_.server_config();
  stricter.deny.push_back({daemon::TlsIdentity::Kind::kCommonName, "carol"});
  std::vector<std::unique_ptr<SteppedTlsClient>> clients;
  std::vector<std::size_t> stage;  // 0: nothing sent yet, 1: ClientHello, 2: flight read, 3+...
  int failed_reloads = 0;
  for (int round = 0; round < 12; ++round) {
    for (auto* name : {"alice", "bob", "carol"}) {
      clients.push_back(stepped(name));
      stage.push_back(0);
    }
    for (std::size_t i = 0; i < clients.size(); ++i) {  // advance each by one step
      auto& c = *clients[i];
      if (stage[i] == 0) c.send_client_hello();
      if (stage[i] == 1) c.read_daemon_flight();
      if (stage[i] >= 2 && c.records_left() > 0) c.send_next_record();
      ++stage[i];
    }
    try {
      reload(*server_, round % 3 == 0 ? broken : round % 3 == 1 ? stricter : pki_.server_config());
    } catch (const daemon::StartupError& e) {  // the broken one: the running policy stays
      EXPECT_NE(std::string(e.what()).find("missing.crl"), std::string::npos) << e.what();
      ++failed_reloads;
    }
  }
  EXPECT_EQ(failed_reloads, 4);
  // Finish them all under the last policy (the test's own); the server's limit of pending
  // handshakes may have dropped the oldest.
  int welcomed = 0;
  for (std::size_t i = 0; i < clients.size(); ++i) {
    auto& c = *clients[i];
    if (stage[i] == 0) c.send_client_hello();
    if (stage[i] <= 1) c.read_daemon_flight();
    while (c.records_left() > 0)
      c.send_next_record();
    if (!c.send(hello_as(Role::kObserver), 1)) continue;
    const auto reply = c.reply_to(1);
    welcomed += reply && std::holds_alternative<protocol::Welcome>(*reply) ? 1 : 0;
  }
  EXPECT_GT(welcomed, 0);
  Client fresh(options_with(pki_.client_tls("bob"), "fresh"));
  ASSERT_TRUE(fresh.connect({"127.0.0.1", server_->port()}).ok());
  EXPECT_TRUE(fresh.hello(Role::kObserver).ok());
  clients.clear();
  EXPECT_TRUE(eventually([&] { return server_->session_count() == 1U; }));
}

}  // namespace
}  // namespace ajar::test
