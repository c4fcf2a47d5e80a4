// Connected TLS sessions (issue 13): a reload (SIGHUP) that revokes, denies or demotes a connected
// peer closes its session (an Error naming the identity and the reason first); an expired CRL is
// a warning at start and on reload; both ends close with close_notify.
#include <utility>  // before Asio (asio issue 944)

#include <ctime>
#include <memory>
#include <mutex>
#include <string>

#include <gtest/gtest.h>

#include "tls_support.hpp"

namespace ajar::test {
namespace {

using client::Client;
using protocol::Role;

// "YYYYMMDDHHMMSSZ", `offset_s` from now (openssl's time format).
std::string openssl_time(long offset_s) {
  const std::time_t t = std::time(nullptr) + offset_s;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d%H%M%SZ", &tm);
  return text;
}

// Records why a Client was disconnected (the callback runs on the client's I/O thread).
class Disconnects {
 public:
  explicit Disconnects(Client& c) {
    c.on_disconnect([this](const std::string& why) {
      std::lock_guard lock(mutex_);
      why_ = why;
    });
  }
  std::string why() const {
    std::lock_guard lock(mutex_);
    return why_;
  }

 private:
  mutable std::mutex mutex_;
  std::string why_;
};

class TlsSessions : public ::testing::Test {
 protected:
  LogCapture log_;
  Pki pki_;
  FakeEngine engine_;
  std::unique_ptr<TlsServer> server_ = std::make_unique<TlsServer>(engine_, server_options(pki_));

  std::unique_ptr<Client> greeted(const std::string& name, Role role) {
    auto c = std::make_unique<Client>(options_with(pki_.client_tls(name), name));
    EXPECT_TRUE(c->connect({"127.0.0.1", server_->port()}).ok());
    EXPECT_TRUE(c->hello(role).ok());
    return c;
  }

  // The unsolicited Error a closed session got before the daemon closed it.
  static protocol::ErrorReply closing_error(Client& c) {
    const auto envelope = c.wait_reply(0U, 10s);
    EXPECT_TRUE(envelope.has_value()) << "no Error before the close";
    const auto* error = envelope ? std::get_if<protocol::ErrorReply>(&envelope->message) : nullptr;
    EXPECT_NE(error, nullptr);
    return error != nullptr ? *error : protocol::ErrorReply{};
  }
};

TEST_F(TlsSessions, ADenyListReloadClosesTheConnectedControllerWithAnErrorFirst) {
  auto alice = greeted("alice", Role::kController);
  Disconnects alice_gone(*alice);
  auto bob = greeted("bob", Role::kObserver);
  auto policy = pki_.server_config();
  policy.deny.push_back({daemon::TlsIdentity::Kind::kCommonName, "alice"});
  reload(*server_, policy);

  const auto error = closing_error(*alice);
  EXPECT_EQ(error.code, ErrorCode::kNotController);
  EXPECT_EQ(error.field.view(), "certificate");
  EXPECT_NE(error.message.view().find("cn:alice"), std::string_view::npos) << error.message.view();
  EXPECT_NE(error.message.view().find("denied by network.tls.deny"), std::string_view::npos)
      << error.message.view();
  EXPECT_TRUE(alice->wait_closed(10s));
  // The daemon ended TLS with close_notify (read as end of stream), not a bare TCP close.
  EXPECT_TRUE(eventually([&] { return alice_gone.why() == "connection closed by the daemon"; }))
      << alice_gone.why();
  EXPECT_TRUE(eventually([&] { return engine_.controller_lost_count() == 1; }))
      << "the controller's close must reach the deadman";
  EXPECT_TRUE(log_.contains("TLS: closing session", "cn:alice"));
  EXPECT_TRUE(bob->request(protocol::Ping{1}).ok()) << "an admitted session was disturbed";
  EXPECT_EQ(server_->session_count(), 1U);
}

TEST_F(TlsSessions, ACrlReloadClosesTheRevokedSessionOnly) {
  auto alice = greeted("alice", Role::kController);
  auto bob = greeted("bob", Role::kObserver);
  pki_.run("revoke bob");
  reload(*server_, pki_.server_config());  // the same config: the CRL file changed under it

  const auto error = closing_error(*bob);
  EXPECT_EQ(error.code, ErrorCode::kNotController);
  EXPECT_NE(error.message.view().find("cn:bob"), std::string_view::npos);
  EXPECT_NE(error.message.view().find("certificate revoked"), std::string_view::npos)
      << error.message.view();
  EXPECT_TRUE(bob->wait_closed(10s));
  EXPECT_TRUE(alice->request(ajar::testing::good_width()).ok());
  EXPECT_EQ(engine_.controller_lost_count(), 0);
}

TEST_F(TlsSessions, AReloadThatTakesTheControllerGrantAwayClosesTheSession) {
  auto alice = greeted("alice", Role::kController);
  auto policy = pki_.server_config();
  policy.identities[0].may_control = false;  // alice: observer from now on
  reload(*server_, policy);
  const auto error = closing_error(*alice);
  EXPECT_NE(error.message.view().find("no longer granted the controller role"),
            std::string_view::npos)
      << error.message.view();
  EXPECT_TRUE(alice->wait_closed(10s));
  // Reconnected, the certificate's new grant applies.
  Client again(options_with(pki_.client_tls("alice")));
  ASSERT_TRUE(again.connect({"127.0.0.1", server_->port()}).ok());
  EXPECT_EQ(again.hello(Role::kController).error.code, ErrorCode::kNotController);
  EXPECT_TRUE(again.hello(Role::kObserver).ok());
}

TEST_F(TlsSessions, AReloadThatChangesNothingForASessionKeepsIt) {
  auto alice = greeted("alice", Role::kController);
  auto bob = greeted("bob", Role::kObserver);
  auto policy = pki_.server_config();
  policy.deny.push_back({daemon::TlsIdentity::Kind::kCommonName, "zed"});
  reload(*server_, policy);
  reload(*server_, policy);
  EXPECT_TRUE(alice->request(ajar::testing::good_width()).ok());
  EXPECT_TRUE(bob->request(protocol::Ping{2}).ok());
  EXPECT_FALSE(alice->wait_reply(0U, 200ms).has_value()) << "an unexpected Error";
  EXPECT_EQ(server_->session_count(), 2U);
}

TEST_F(TlsSessions, AnExpiredCrlIsAWarningAtStartAndOnReloadAndFailsClosed) {
  auto alice = greeted("alice", Role::kController);
  pki_.run("--valid 20200101000000Z 20200102000000Z crl");

  // At start (the acceptor is what ajard builds in Server::bind()).
  {
    const daemon::TlsAcceptor at_start(pki_.server_config());
    ASSERT_EQ(at_start.warnings().size(), 1U);
    EXPECT_NE(at_start.warnings()[0].find("network.tls.crl"), std::string::npos);
    EXPECT_NE(at_start.warnings()[0].find("EXPIRED at 2020-01-02 00:00:00 UTC"), std::string::npos)
        << at_start.warnings()[0];
  }
  EXPECT_TRUE(log_.contains("[warning]", "EXPIRED at 2020-01-02"));

  // On SIGHUP: warned again; OpenSSL now refuses every certificate of that CA, also the
  // connected ones (fail closed, docs/security.md).
  reload(*server_, pki_.server_config());
  int warned = 0;
  for (std::size_t at = 0; (at = log_.all().find("EXPIRED at 2020-01-02", at)) != std::string::npos;
       ++at) {
    ++warned;
  }
  EXPECT_EQ(warned, 2) << log_.all();
  EXPECT_NE(closing_error(*alice).message.view().find("CRL has expired"), std::string_view::npos);
  Client late(options_with(pki_.client_tls("bob")));
  if (late.connect({"127.0.0.1", server_->port()}).ok()) {
    EXPECT_FALSE(late.hello(Role::kObserver).ok());
  }
  EXPECT_TRUE(eventually([&] { return log_.contains("TLS handshake with", "CRL has expired"); }));

  // A fresh CRL: no warning.
  pki_.run("crl");
  EXPECT_TRUE(daemon::TlsAcceptor(pki_.server_config()).warnings().empty());
}

TEST_F(TlsSessions, ACrlThatExpiresWithinAWeekIsAWarningToo) {
  pki_.run("--valid " + openssl_time(-86400) + " " + openssl_time(2 * 86400) + " crl");
  const daemon::TlsAcceptor acceptor(pki_.server_config());
  ASSERT_EQ(acceptor.warnings().size(), 1U);
  EXPECT_NE(acceptor.warnings()[0].find("expires at"), std::string::npos) << acceptor.warnings()[0];
  // Still valid: clients get in.
  EXPECT_TRUE(greeted("bob", Role::kObserver)->request(protocol::Ping{3}).ok());
}

TEST_F(TlsSessions, TheClientLibraryClosesWithCloseNotify) {
  auto alice = greeted("alice", Role::kObserver);
  alice->close();
  // The daemon's read ends with the alert (end of stream), not "stream truncated".
  EXPECT_TRUE(eventually([&] { return log_.contains("(alice) closed: closed by peer"); }))
      << log_.all();
  EXPECT_FALSE(log_.contains("(alice) closed: read failed"));
}

TEST_F(TlsSessions, TheDaemonClosesWithCloseNotifyWhenItStops) {
  auto bob = greeted("bob", Role::kObserver);
  Disconnects gone(*bob);
  server_.reset();  // ajard's shutdown: every session closed gracefully
  EXPECT_TRUE(bob->wait_closed(10s));
  EXPECT_TRUE(eventually([&] { return gone.why() == "connection closed by the daemon"; }))
      << gone.why();
}

}  // namespace
}  // namespace ajar::test
