// "Certificate changes at any instant" (issue 22): a randomized campaign against the in-process
// TLS server. Each trial is one client (SteppedTlsClient) that goes through its connection one step
// at a time — connect, ClientHello, read the daemon's flight, each record of its second flight
// (ChangeCipherSpec, Certificate, CertificateVerify, Finished), Hello (controller or observer),
// Drive, Stop — and between any two steps the test may change the policy for that client's
// certificate and reload it (SIGHUP's reload_tls, on the server's I/O thread): revoke the
// certificate (a new CRL, or one without it again), change its role (controller, observer, observer
// that may not stop, not listed), deny it, remove its CA (only another CA trusted) or put it back,
// switch `unlisted`, or reload an unchanged policy; sometimes after the daemon has handled the last
// step, sometimes racing it. Half the trials change the policy once, at one random instant; the
// others at any step with some probability.
//
// Invariants, checked at every reply (no reload happens while a reply is awaited, so the policy in
// force is known):
// - safety: a Welcome grants at most what the policy in force grants (controller only if it may
//   control); a Drive is acknowledged only if the policy in force grants control, a Stop only if it
//   admits the certificate and grants stopping; the engine executed exactly the commands the client
//   saw acknowledged; a refusal is an alert, an Error or a close — never silence (a wedge);
// - liveness: while no reload of the trial changed what the policy grants the certificate (a
//   reload that changes nothing for it, or changes and restores it at once), the client is
//   welcomed as it asks if the policy grants it, and its Drive and Stop are acknowledged if it
//   grants them. (After a change, closing the session is a valid answer: a session admitted with
//   more than the policy now grants is closed, docs/security.md.)
// Counters of what was reached are printed and, over a CI run, asserted.
//
//   AJAR_SEED=<n>    replay one trial (prints its trace)
//   AJAR_SEEDS=<n>   number of trials (default 200, 60 under sanitizers)
#include <utility>  // before Asio (asio issue 944)

#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <openssl/pem.h>
#include <openssl/x509.h>

#include <cstdio>
#include <ctime>

#include <gtest/gtest.h>

#include "ajar/daemon/logging.hpp"
#include "campaign_seeds.hpp"
#include "tls_stepped_client.hpp"
#include "tls_support.hpp"

namespace ajar::test {
namespace {

using protocol::MessageType;
using protocol::Role;

constexpr std::uint64_t kCiTrials = ci_size(200, 60);

// Writes `path`: a CRL of the test CA (ca.crt, ca.key) revoking the certificates (PEM files) in
// `revoked`. The OpenSSL API rather than make-certs: its `revoke` runs two openssl processes, too
// slow for hundreds of revocations, and cannot take one back.
void write_crl(const Pki& pki, const std::vector<std::string>& revoked, const std::string& path) {
  auto read_certificate = [](const std::string& file) {
    std::FILE* f = std::fopen(file.c_str(), "r");
    X509* x = f != nullptr ? PEM_read_X509(f, nullptr, nullptr, nullptr) : nullptr;
    if (f != nullptr) std::fclose(f);
    return x;
  };
  X509* ca = read_certificate(pki.path("ca.crt"));
  std::FILE* key_file = std::fopen(pki.path("ca.key").c_str(), "r");
  EVP_PKEY* key =
      key_file != nullptr ? PEM_read_PrivateKey(key_file, nullptr, nullptr, nullptr) : nullptr;
  if (key_file != nullptr) std::fclose(key_file);
  ASSERT_TRUE(ca != nullptr && key != nullptr) << "test bug: cannot read the CA";
  X509_CRL* crl = X509_CRL_new();
  X509_CRL_set_version(crl, 1);  // v2
  X509_CRL_set_issuer_name(crl, X509_get_subject_name(ca));
  ASN1_TIME* last = ASN1_TIME_set(nullptr, std::time(nullptr) - 60);
  ASN1_TIME* next = ASN1_TIME_set(nullptr, std::time(nullptr) + 86400);
  X509_CRL_set1_lastUpdate(crl, last);
  X509_CRL_set1_nextUpdate(crl, next);
  for (const auto& file : revoked) {
    X509* x = read_certificate(file);
    ASSERT_NE(x, nullptr) << file;
    X509_REVOKED* r = X509_REVOKED_new();
    X509_REVOKED_set_serialNumber(r, X509_get_serialNumber(x));
    X509_REVOKED_set_revocationDate(r, last);
    X509_CRL_add0_revoked(crl, r);
    X509_free(x);
  }
  X509_CRL_sort(crl);
  ASSERT_GT(X509_CRL_sign(crl, key, EVP_sha256()), 0);
  const std::string temporary = path + ".new";
  std::FILE* out = std::fopen(temporary.c_str(), "w");
  ASSERT_NE(out, nullptr);
  PEM_write_X509_CRL(out, crl);
  std::fclose(out);
  ASSERT_EQ(std::rename(temporary.c_str(), path.c_str()), 0);
  ASN1_TIME_free(last);
  ASN1_TIME_free(next);
  X509_CRL_free(crl);
  EVP_PKEY_free(key);
  X509_free(ca);
}

// What the policy in force says of the trial's certificate.
struct Grant {
  bool admitted = false;
  bool may_control = false;
  bool may_stop = false;
  bool operator==(const Grant&) const = default;
};

// The policy's view of the trial's certificate ("opN"), changed by the mutations.
struct CertificatePolicy {
  enum class Listed { kController, kObserver, kObserverNoStop, kUnlisted };
  Listed listed = Listed::kController;
  bool revoked = false;
  bool denied = false;
  bool ca_removed = false;
  bool unlisted_may_observe = false;

  Grant grant() const {
    if (revoked || denied || ca_removed) return {};
    switch (listed) {
      case Listed::kController:
        return {true, true, true};
      case Listed::kObserver:
        return {true, false, true};
      case Listed::kObserverNoStop:
        return {true, false, false};
      case Listed::kUnlisted:
        break;
    }
    return unlisted_may_observe ? Grant{true, false, true} : Grant{};
  }

  daemon::TlsConfig config(const Pki& pki, const std::string& name) const {
    daemon::TlsConfig c = pki.server_config();
    c.crl = pki.path("campaign.crl");
    using K = daemon::TlsIdentity::Kind;
    if (listed != Listed::kUnlisted) {
      c.identities.push_back({{K::kCommonName, name},
                              listed == Listed::kController,
                              listed != Listed::kObserverNoStop});
    }
    if (denied) c.deny.push_back({K::kCommonName, name});
    if (ca_removed) c.ca = pki.path("other/ca.crt");
    c.unlisted_may_observe = unlisted_may_observe;
    return c;
  }

  std::string text() const {
    static constexpr const char* kListed[] = {"controller", "observer", "observer/no-stop",
                                              "unlisted"};
    std::string t = kListed[static_cast<int>(listed)];
    if (revoked) t += " revoked";
    if (denied) t += " denied";
    if (ca_removed) t += " ca-removed";
    if (unlisted_may_observe) t += " unlisted:observer";
    return t;
  }
};

class Campaign {
 public:
  static constexpr const char* kName = "op";

  Campaign() {
    pki_.run("operator " + std::string(kName) + " controller");
    write_crl(pki_, {}, pki_.path("campaign.crl"));
    daemon::ServerOptions options = server_options(pki_);
    options.session.linger = std::chrono::milliseconds(200);
    server_ = std::make_unique<TlsServer>(engine_, std::move(options));
  }

  std::map<std::string, int>& counters() { return counters_; }

  // One trial; "" or the violated invariant. `trace` gets the steps.
  std::string run(std::uint64_t seed, std::vector<std::string>& trace) {
    std::mt19937_64 rng(seed);
    trace_ = &trace;
    const std::string name = kName;
    policy_ = CertificatePolicy{};
    write_crl(pki_, {}, pki_.path("campaign.crl"));
    // Half the trials: one change, before step `only_change_before_` (1..9); the others: at any.
    only_change_before_ = pick(rng, 2) == 0 ? static_cast<int>(1 + pick(rng, 9)) : 0;
    step_ = 0;
    policy_.listed = pick(rng, 3) == 0 ? CertificatePolicy::Listed::kObserver
                                       : CertificatePolicy::Listed::kController;
    always_ = start_ = policy_.grant();
    reload(*server_, policy_.config(pki_, name));
    log("start: " + name + " " + policy_.text());
    const std::size_t commands_before = engine_.commands().size();

    auto client = std::make_unique<SteppedTlsClient>(
        server_->port(), pki_.path("ca.crt"), pki_.path(name + ".crt"), pki_.path(name + ".key"));
    std::string violation = steps(rng, *client, name);
    client.reset();  // closes; the server forgets the session

    // The engine executed exactly what the client saw acknowledged.
    const auto commands = engine_.commands();
    std::vector<MessageType> executed(commands.begin() + static_cast<long>(commands_before),
                                      commands.end());
    if (violation.empty() && executed != acknowledged_) {
      violation = "the engine executed " + std::to_string(executed.size()) +
                  " commands, the client saw " + std::to_string(acknowledged_.size()) +
                  " acknowledged";
    }
    acknowledged_.clear();
    if (!eventually([&] { return server_->session_count() == 0U; })) {
      if (violation.empty()) violation = "the trial's session did not close";
    }
    return violation;
  }

 private:
  static std::size_t pick(std::mt19937_64& rng, std::size_t n) {
    return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
  }

  void log(const std::string& line) { trace_->push_back(line); }

  // Between two steps: maybe change the policy and reload, after the daemon has handled the last
  // step or racing it.
  void maybe_change(std::mt19937_64& rng, SteppedTlsClient& client, const std::string& name) {
    ++step_;
    if (only_change_before_ > 0 ? step_ != only_change_before_ : pick(rng, 4) != 0) return;
    if (pick(rng, 2) == 0) {
      eventually([&] { return client.unread_at_daemon().value_or(0) == 0; });
      server_->call([] { return 0; });
      server_->call([] { return 0; });
    }
    const int changes = pick(rng, 5) == 0 ? 2 : 1;
    for (int i = 0; i < changes; ++i) {
      switch (pick(rng, 8)) {
        case 0:
        case 1:
          policy_.revoked = !policy_.revoked;
          write_crl(pki_,
                    policy_.revoked ? std::vector<std::string>{pki_.path(name + ".crt")}
                                    : std::vector<std::string>{},
                    pki_.path("campaign.crl"));
          ++counters_[policy_.revoked ? "change: revoke" : "change: a CRL without it"];
          break;
        case 2:
        case 3:
          policy_.listed = static_cast<CertificatePolicy::Listed>(pick(rng, 4));
          ++counters_["change: role"];
          break;
        case 4:
          policy_.denied = !policy_.denied;
          ++counters_["change: deny"];
          break;
        case 5:
          policy_.ca_removed = !policy_.ca_removed;
          ++counters_["change: CA"];
          break;
        case 6:
          policy_.unlisted_may_observe = !policy_.unlisted_may_observe;
          ++counters_["change: unlisted"];
          break;
        default:
          ++counters_["change: none"];
          break;
      }
    }
    reload(*server_, policy_.config(pki_, name));
    if (policy_.grant() != start_) always_ = Grant{};  // no more liveness expectations
    log("reload: " + policy_.text());
  }

  // How a refusal looked, for the counters; "" when it is silence (a wedge).
  std::string refusal_of(const std::optional<protocol::Message>& reply,
                         const SteppedTlsClient& client) {
    if (reply) {
      const auto* error = std::get_if<protocol::ErrorReply>(&*reply);
      if (error == nullptr) return "";
      const std::string message(error->message.view());
      if (error->field.view() == "certificate") {
        return message.find("no longer admitted") != std::string::npos
                   ? "closed on reload (Error certificate)"
                   : "refused at completion (Error certificate)";
      }
      return "refused: " + std::string(to_string(error->code));
    }
    if (client.failure().find("alert") != std::string::npos) return "refused by a TLS alert";
    if (client.failure().find("deadline") != std::string::npos) return "";
    return "closed";
  }

  // One step of the connection: the policy may change first (maybe_change), then `action`.
  template <typename Action>
  auto step(std::mt19937_64& rng, SteppedTlsClient& client, const std::string& name,
            const std::string& what, Action&& action) {
    maybe_change(rng, client, name);
    log(what);
    return action();
  }

  // The connection step by step, the policy changing between steps; what went against the policy
  // ("" when nothing did).
  std::string steps(std::mt19937_64& rng, SteppedTlsClient& client, const std::string& name) {
    if (!step(rng, client, name, "ClientHello", [&] { return client.send_client_hello(); }) ||
        !step(rng, client, name, "read the daemon's flight",
              [&] { return client.read_daemon_flight(); })) {
      ++counters_["refused in the first flights"];
      return client.failure().find("deadline") != std::string::npos
                 ? "no answer: " + client.failure()
                 : "";
    }
    for (const char* record : {"ChangeCipherSpec", "Certificate", "CertificateVerify", "Finished"})
      step(rng, client, name, std::string("send ") + record,
           [&] { return client.send_next_record(); });
    std::optional<Role> granted;
    if (std::string wrong = hello_step(rng, client, name, granted); !wrong.empty()) return wrong;
    if (std::string wrong = drive_step(rng, client, name, granted); !wrong.empty()) return wrong;
    return stop_step(rng, client, name);
  }

  // Hello: what is granted (into `granted`) is at most what the policy in force grants.
  std::string hello_step(std::mt19937_64& rng, SteppedTlsClient& client, const std::string& name,
                         std::optional<Role>& granted) {
    const Role asked = pick(rng, 4) == 0 ? Role::kObserver : Role::kController;
    const auto welcome = step(
        rng, client, name, asked == Role::kController ? "Hello controller" : "Hello observer", [&] {
          client.send(hello_as(asked, seed_id(rng), true), 1);
          return client.reply_to(1);
        });
    const Grant now = policy_.grant();
    const auto* w = welcome ? std::get_if<protocol::Welcome>(&*welcome) : nullptr;
    if (w != nullptr) {
      granted = w->granted_role;
      log(std::string("Welcome ") + (*granted == Role::kController ? "controller" : "observer"));
      if (!now.admitted) return "welcomed under a policy that refuses the certificate";
      if (*granted == Role::kController && !now.may_control)
        return "welcomed as controller under a policy that does not grant control";
      ++counters_[*granted == Role::kController ? "welcomed controller" : "welcomed observer"];
    } else {
      const std::string how = refusal_of(welcome, client);
      log("Hello refused: " + how + " " + client.failure());
      if (how.empty()) return "Hello: no answer (" + client.failure() + ")";
      ++counters_[how];
      if (always_.admitted && (asked == Role::kObserver || always_.may_control))
        return "refused (" + how + ") though the policy admits it as asked and never changed";
    }
    return "";
  }

  // Drive: acknowledged only under a policy that grants control, to the controller.
  std::string drive_step(std::mt19937_64& rng, SteppedTlsClient& client, const std::string& name,
                         const std::optional<Role>& granted) {
    const auto drive = step(rng, client, name, "Drive", [&] {
      client.send(protocol::Drive{0.05, 0.0}, 2);
      return client.reply_to(2);
    });
    const Grant now = policy_.grant();
    if (drive && std::holds_alternative<protocol::Ack>(*drive)) {
      acknowledged_.push_back(MessageType::kDrive);
      log("Drive acknowledged");
      if (!now.may_control) return "Drive acknowledged under a policy that does not grant control";
      if (granted != Role::kController) return "Drive acknowledged without the controller role";
      ++counters_["Drive acknowledged"];
    } else {
      const std::string how = refusal_of(drive, client);
      log("Drive refused: " + how);
      if (how.empty()) return "Drive: no answer (" + client.failure() + ")";
      if (always_.may_control && granted == Role::kController)
        return "Drive refused (" + how + ") though the policy grants control and never changed";
      ++counters_["Drive refused"];
    }
    return "";
  }

  // Stop: acknowledged only under a policy that admits the certificate and lets it stop.
  std::string stop_step(std::mt19937_64& rng, SteppedTlsClient& client, const std::string& name) {
    const auto stop = step(rng, client, name, "Stop", [&] {
      client.send(protocol::Stop{}, 3);
      return client.reply_to(3);
    });
    const Grant now = policy_.grant();
    if (stop && std::holds_alternative<protocol::Ack>(*stop)) {
      acknowledged_.push_back(MessageType::kStop);
      log("Stop acknowledged");
      if (!now.admitted || !now.may_stop)
        return "Stop acknowledged under a policy that refuses the certificate or stopping";
      ++counters_["Stop acknowledged"];
    } else {
      const std::string how = refusal_of(stop, client);
      log("Stop refused: " + how);
      if (how.empty()) return "Stop: no answer (" + client.failure() + ")";
      if (always_.admitted && always_.may_stop)
        return "Stop refused (" + how + ") though the policy grants it and never changed";
      ++counters_["Stop refused"];
    }
    return "";
  }

  static std::uint64_t seed_id(std::mt19937_64& rng) { return rng() | 1U; }

  Pki pki_;
  FakeEngine engine_;
  std::unique_ptr<TlsServer> server_;
  CertificatePolicy policy_;
  Grant start_;   // what the policy granted at the start of the trial
  Grant always_;  // start_ while no reload changed it, then nothing (no liveness expectation)
  std::vector<MessageType> acknowledged_;
  std::vector<std::string>* trace_ = nullptr;
  std::map<std::string, int> counters_;
  int only_change_before_ = 0;
  int step_ = 0;
};

TEST(CertificateCampaign, CertificateChangesAtAnyInstantNeverGrantTheOldRole) {
  const auto [first, count, replay] = seed_range(kCiTrials);
  std::cout << "certificate campaign: seeds " << first << ".." << first + count - 1
            << " (replay one with AJAR_SEED=<seed>)" << std::endl;
  // The daemon's log only when replaying one trial (a reload alone logs a warning).
  daemon::set_log_level(replay ? daemon::LogLevel::kInfo : daemon::LogLevel::kNone);
  Campaign campaign;
  int failures = 0;
  for (std::uint64_t seed = first; seed < first + count && failures < 3; ++seed) {
    std::vector<std::string> trace;
    const std::string violation = campaign.run(seed, trace);
    if (replay || !violation.empty()) {
      std::ostringstream out;
      for (const auto& line : trace)
        out << "  " << line << "\n";
      if (violation.empty()) {
        std::cout << "seed " << seed << ":\n" << out.str();
      } else {
        ++failures;
        ADD_FAILURE() << "seed " << seed << ": " << violation << "\n"
                      << out.str() << "replay with AJAR_SEED=" << seed;
      }
    }
  }
  daemon::set_log_level(daemon::LogLevel::kInfo);
  std::ostringstream counters;
  for (const auto& [k, v] : campaign.counters())
    counters << "  " << k << ": " << v << "\n";
  std::cout << "coverage over " << count << " trials:\n" << counters.str();
  if (replay || count < kCiTrials) return;
  // Every kind of outcome was reached: the campaign is not vacuous.
  for (const char* reached :
       {"welcomed controller", "welcomed observer", "refused by a TLS alert",
        "refused at completion (Error certificate)", "closed on reload (Error certificate)",
        "Drive acknowledged", "Stop acknowledged", "Drive refused", "change: revoke",
        "change: a CRL without it", "change: CA", "change: deny", "change: role"}) {
    EXPECT_GT(campaign.counters()[reached], 0) << reached << " never happened";
  }
}

}  // namespace
}  // namespace ajar::test
