#include <utility>  // before Asio (asio issue 944)

#include "ajar/daemon/tls.hpp"

#include <arpa/inet.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <map>

#include <boost/asio/ssl/context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <spdlog/spdlog.h>

#include "ajar/security/tls_files.hpp"

namespace ajar::daemon {
namespace {

namespace asio = boost::asio;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;

std::string text_of(const ASN1_STRING* s) {
  unsigned char* utf8 = nullptr;
  const int n = ASN1_STRING_to_UTF8(&utf8, s);
  if (n < 0) return {};
  std::string out(reinterpret_cast<const char*>(utf8), static_cast<std::size_t>(n));
  OPENSSL_free(utf8);
  return out;
}

CertificateIdentity identity_of(X509* cert) {
  CertificateIdentity id;
  if (cert == nullptr) return id;
  const X509_NAME* subject = X509_get_subject_name(cert);
  const int cn = X509_NAME_get_index_by_NID(subject, NID_commonName, -1);
  if (cn >= 0) id.common_name = text_of(X509_NAME_ENTRY_get_data(X509_NAME_get_entry(subject, cn)));
  auto* names =
      static_cast<GENERAL_NAMES*>(X509_get_ext_d2i(cert, NID_subject_alt_name, nullptr, nullptr));
  if (names != nullptr) {
    for (int i = 0; i < sk_GENERAL_NAME_num(names); ++i) {
      const GENERAL_NAME* name = sk_GENERAL_NAME_value(names, i);
      if (name->type == GEN_DNS || name->type == GEN_EMAIL || name->type == GEN_URI) {
        id.subject_alt_names.push_back(text_of(name->d.ia5));
      } else if (name->type == GEN_IPADD) {
        const ASN1_OCTET_STRING* ip = name->d.iPAddress;
        char buffer[INET6_ADDRSTRLEN] = {};
        const int family = ip->length == 4 ? AF_INET : ip->length == 16 ? AF_INET6 : -1;
        if (family > 0 && inet_ntop(family, ip->data, buffer, sizeof buffer) != nullptr)
          id.subject_alt_names.emplace_back(buffer);
      }
    }
    GENERAL_NAMES_free(names);
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (X509_digest(cert, EVP_sha256(), digest, &length) == 1) {
    static constexpr char kHex[] = "0123456789ABCDEF";
    for (unsigned int i = 0; i < length; ++i) {
      id.sha256 += kHex[digest[i] >> 4];
      id.sha256 += kHex[digest[i] & 0xF];
    }
  }
  return id;
}

std::string openssl_error() {
  const unsigned long e = ERR_get_error();
  ERR_clear_error();
  if (e == 0) return "unknown error";
  char buffer[256];
  ERR_error_string_n(e, buffer, sizeof buffer);
  return buffer;
}

// One loaded configuration: the SSL context (its store: CA, CRL, flags) and the identities. Kept
// alive by every handshake that started with it (OpenSSL runs the handshake in its context); a
// reload makes a new one. A handshake is admitted under the generation RUNNING when its
// certificate is verified and again when it completes, not under the one it started with.
struct Generation {
  explicit Generation(const TlsConfig& c) : config(c) {}
  TlsConfig config;
  ssl::context context{ssl::context::tls_server};
  std::vector<std::string> warnings;  // logged at start and on every reload
};

// The running generation: replaced by reload(); every pending handshake holds this cell, so its
// verify callback and its completion read the policy current at that moment.
struct Running {
  std::shared_ptr<Generation> generation;
};

std::string utc_text(const ASN1_TIME* t) {
  std::tm tm{};
  if (t == nullptr || ASN1_TIME_to_tm(t, &tm) != 1) return "(unreadable time)";
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return text;
}

// The CRLs of `path` whose nextUpdate has passed (OpenSSL then refuses every certificate of that
// CA: "CRL has expired") or comes within kCrlWarningDays.
constexpr int kCrlWarningDays = 7;
std::vector<std::string> crl_warnings(const std::string& path) {
  std::vector<std::string> out;
  std::FILE* file = std::fopen(path.c_str(), "r");
  if (file == nullptr) return out;  // load() has just read it; a race is reported by OpenSSL
  while (X509_CRL* crl = PEM_read_X509_CRL(file, nullptr, nullptr, nullptr)) {
    const ASN1_TIME* next = X509_CRL_get0_nextUpdate(crl);
    std::string issuer = "(no CN)";
    const X509_NAME* name = X509_CRL_get_issuer(crl);
    if (const int cn = X509_NAME_get_index_by_NID(name, NID_commonName, -1); cn >= 0)
      issuer = text_of(X509_NAME_ENTRY_get_data(X509_NAME_get_entry(name, cn)));
    int days = 0;
    int seconds = 0;
    if (next != nullptr && ASN1_TIME_diff(&days, &seconds, nullptr, next) == 1) {
      const std::string what = "network.tls.crl: '" + path + "': the CRL of '" + issuer + "' ";
      if (days < 0 || seconds < 0) {
        out.push_back(what + "EXPIRED at " + utc_text(next) +
                      " (nextUpdate): every client certificate of that CA is refused until a "
                      "fresh CRL is installed (scripts/make-certs crl, then SIGHUP)");
      } else if (days < kCrlWarningDays) {
        out.push_back(what + "expires at " + utc_text(next) +
                      " (nextUpdate): then every client certificate of that CA is refused; "
                      "install a fresh CRL before (scripts/make-certs crl, then SIGHUP)");
      }
    }
    X509_CRL_free(crl);
  }
  ERR_clear_error();  // the end of the file reads as a PEM "no start line"
  std::fclose(file);
  return out;
}

// The handshake's scratch pad, reachable from the verify callback through the SSL's ex data.
constexpr int kExIndex = 0;
struct Scratch {
  std::string refused;                     // the identity and reason of a refused certificate
  std::shared_ptr<const Running> running;  // the policy current now (see Generation)
};

// What `g` says of the chain `leaf` + `untrusted` (what the peer sent), as a handshake under `g`
// verifies it: the store's CA, CRL and flags, validity dates, purpose ssl_client. "" when valid,
// else the reason ("certificate revoked (depth 0)"); `error` gets the X509_V_ERR code.
std::string chain_problem(Generation& g, X509* leaf, STACK_OF(X509) * untrusted, int& error) {
  std::string problem;
  error = X509_V_OK;
  X509_STORE_CTX* verify = X509_STORE_CTX_new();
  if (verify == nullptr ||
      X509_STORE_CTX_init(verify, SSL_CTX_get_cert_store(g.context.native_handle()), leaf,
                          untrusted) != 1) {
    error = X509_V_ERR_UNSPECIFIED;
    problem = "cannot verify: " + openssl_error();
  } else {
    X509_STORE_CTX_set_default(verify, "ssl_client");
    if (X509_verify_cert(verify) != 1) {
      error = X509_STORE_CTX_get_error(verify);
      if (error == X509_V_OK) error = X509_V_ERR_UNSPECIFIED;
      problem = std::string(X509_verify_cert_error_string(error)) + " (depth " +
                std::to_string(X509_STORE_CTX_get_error_depth(verify)) + ")";
    }
  }
  X509_STORE_CTX_free(verify);
  ERR_clear_error();
  return problem;
}

// The whole decision under `g`: the chain (chain_problem), then deny list and identities.
Admission admit_chain(Generation& g, X509* leaf, STACK_OF(X509) * untrusted,
                      const CertificateIdentity& id, int& error) {
  Admission a;
  a.access.identity = id.text();
  a.access.may_control = false;
  a.access.may_stop = false;
  if (leaf == nullptr) {
    error = X509_V_ERR_UNSPECIFIED;
    a.refusal = "no certificate";
    return a;
  }
  a.refusal = chain_problem(g, leaf, untrusted, error);
  if (!a.refusal.empty()) return a;
  a = admit(g.config, id);
  if (!a.admitted) error = X509_V_ERR_CERT_REJECTED;
  return a;
}

// The file rule shared with ajar_client (ajar/security/tls_files.hpp), as a StartupError naming
// `key`.
void check_file(const std::string& path, std::string_view key, bool secret) {
  if (const std::string problem = security::tls_file_problem(path, secret); !problem.empty())
    throw StartupError(std::string(key) + ": " + problem);
}

std::shared_ptr<Generation> load(const TlsConfig& config) {
  check_file(config.private_key, "network.tls.private_key", true);
  check_file(config.certificate, "network.tls.certificate", false);
  check_file(config.ca, "network.tls.ca", false);
  if (!config.crl.empty()) check_file(config.crl, "network.tls.crl", false);

  auto g = std::make_shared<Generation>(config);
  SSL_CTX* ctx = g->context.native_handle();
  auto fail = [](const std::string& key, const std::string& path, const std::string& why) {
    throw StartupError(key + ": cannot load '" + path + "': " + why);
  };
  if (SSL_CTX_set_min_proto_version(ctx, TLS1_3_VERSION) != 1)
    throw StartupError("network.tls: this OpenSSL cannot restrict to TLS 1.3: " + openssl_error());
  // No resumption: every connection is verified against the current CA, CRL and deny list.
  SSL_CTX_set_session_cache_mode(ctx, SSL_SESS_CACHE_OFF);
  SSL_CTX_set_options(ctx, SSL_OP_NO_TICKET);
  SSL_CTX_set_num_tickets(ctx, 0);

  boost::system::error_code ec;
  g->context.use_certificate_chain_file(config.certificate, ec);
  if (ec) fail("network.tls.certificate", config.certificate, ec.message());
  g->context.use_private_key_file(config.private_key, ssl::context::pem, ec);
  if (ec) fail("network.tls.private_key", config.private_key, ec.message());
  if (SSL_CTX_check_private_key(ctx) != 1)
    fail("network.tls.private_key", config.private_key,
         "does not match network.tls.certificate: " + openssl_error());
  g->context.load_verify_file(config.ca, ec);
  if (ec) fail("network.tls.ca", config.ca, ec.message());
  if (STACK_OF(X509_NAME)* names = SSL_load_client_CA_file(config.ca.c_str()))
    SSL_CTX_set_client_CA_list(ctx, names);  // tells clients which CA to pick a certificate for
  if (!config.crl.empty()) {
    X509_STORE* store = SSL_CTX_get_cert_store(ctx);
    X509_LOOKUP* lookup = X509_STORE_add_lookup(store, X509_LOOKUP_file());
    if (lookup == nullptr || X509_load_crl_file(lookup, config.crl.c_str(), X509_FILETYPE_PEM) <= 0)
      fail("network.tls.crl", config.crl, "not a PEM CRL: " + openssl_error());
    X509_STORE_set_flags(store, X509_V_FLAG_CRL_CHECK);
    g->warnings = crl_warnings(config.crl);
  }
  g->context.set_verify_mode(ssl::verify_peer | ssl::verify_fail_if_no_peer_cert);
  Generation* self = g.get();  // the callback lives in g's context: never dangles
  g->context.set_verify_callback([self](bool preverified, ssl::verify_context& v) {
    X509_STORE_CTX* store = v.native_handle();
    auto* ssl_handle =
        static_cast<SSL*>(X509_STORE_CTX_get_ex_data(store, SSL_get_ex_data_X509_STORE_CTX_idx()));
    auto* scratch =
        ssl_handle ? static_cast<Scratch*>(SSL_get_ex_data(ssl_handle, kExIndex)) : nullptr;
    X509* cert = X509_STORE_CTX_get_current_cert(store);
    if (!preverified) {
      if (scratch != nullptr && scratch->refused.empty()) {
        scratch->refused = identity_of(cert).text() + ": " +
                           X509_verify_cert_error_string(X509_STORE_CTX_get_error(store)) +
                           " (depth " + std::to_string(X509_STORE_CTX_get_error_depth(store)) + ")";
      }
      return false;
    }
    if (X509_STORE_CTX_get_error_depth(store) != 0) return true;
    const CertificateIdentity id = identity_of(cert);
    // The policy current now, not the one this handshake started under: a reload (SIGHUP) while
    // the client withheld its certificate applies to it, and the client gets the alert a fresh
    // handshake would (certificate revoked, unknown CA...). The leaf was verified under `self`.
    Generation* now = self;
    if (scratch != nullptr && scratch->running && scratch->running->generation)
      now = scratch->running->generation.get();
    int error = X509_V_OK;
    Admission a;
    if (now == self) {
      a = admit(self->config, id);
      if (!a.admitted) error = X509_V_ERR_CERT_REJECTED;
    } else {
      a = admit_chain(*now, X509_STORE_CTX_get0_cert(store), X509_STORE_CTX_get0_untrusted(store),
                      id, error);
      if (!a.admitted) a.refusal += " (under the policy reloaded during the handshake)";
    }
    if (a.admitted) return true;
    X509_STORE_CTX_set_error(store, error);
    if (scratch != nullptr) scratch->refused = id.text() + ": " + a.refusal;
    return false;
  });
  return g;
}

}  // namespace

struct PeerCertificate::Chain {
  X509* leaf = nullptr;
  STACK_OF(X509) * untrusted = nullptr;  // what the peer sent besides the leaf
  Chain() = default;
  Chain(const Chain&) = delete;
  Chain& operator=(const Chain&) = delete;
  ~Chain() {
    X509_free(leaf);
    sk_X509_pop_free(untrusted, X509_free);
  }
};

std::string CertificateIdentity::text() const {
  std::string t = common_name.empty() ? std::string("(no CN)") : "cn:" + common_name;
  if (!sha256.empty()) t += " (sha256:" + sha256.substr(0, 16) + "...)";
  return t;
}

bool matches(const TlsIdentity& id, const CertificateIdentity& c) {
  switch (id.kind) {
    case TlsIdentity::Kind::kCommonName:
      return !c.common_name.empty() && c.common_name == id.value;
    case TlsIdentity::Kind::kSubjectAltName:
      return std::find(c.subject_alt_names.begin(), c.subject_alt_names.end(), id.value) !=
             c.subject_alt_names.end();
    case TlsIdentity::Kind::kSha256:
      return c.sha256 == id.value;
  }
  return false;
}

Admission admit(const TlsConfig& policy, const CertificateIdentity& certificate) {
  Admission a;
  a.access.identity = certificate.text();
  a.access.may_control = false;  // a refusal grants nothing
  a.access.may_stop = false;
  for (const auto& denied : policy.deny) {
    if (matches(denied, certificate)) {
      a.refusal = "denied by network.tls.deny (" + denied.text() + ")";
      return a;
    }
  }
  for (const auto& grant : policy.identities) {
    if (matches(grant.identity, certificate)) {
      a.admitted = true;
      a.access.may_control = grant.may_control;
      a.access.may_stop = grant.may_stop;
      return a;
    }
  }
  if (!policy.unlisted_may_observe) {
    a.refusal = "not listed in network.tls.identities (unlisted: refuse)";
    return a;
  }
  a.admitted = true;
  a.access.may_control = false;
  a.access.may_stop = true;
  return a;
}

struct TlsAcceptor::Impl {
  struct Pending {
    std::uint64_t seq = 0;
    std::shared_ptr<Generation> generation;
    std::unique_ptr<TlsStream::Ssl> stream;
    std::unique_ptr<asio::steady_timer> timer;
    std::string peer;
    std::string dropped;  // why we closed it ourselves
    Scratch scratch;
    Done done;
  };

  explicit Impl(const TlsConfig& config) : running(std::make_shared<Running>()) {
    running->generation = load(config);
  }
  Generation& current() const { return *running->generation; }

  void finish(const std::shared_ptr<Pending>& p, const boost::system::error_code& ec) {
    pending.erase(p->seq);  // no-op when dropped
    p->timer->cancel();
    SSL* handle = p->stream->native_handle();
    SSL_set_ex_data(handle, kExIndex, nullptr);
    boost::system::error_code ignored;
    if (ec || !p->dropped.empty()) {
      std::string reason = p->dropped;
      if (reason.empty()) reason = p->scratch.refused;
      if (reason.empty()) {
        reason = ec.message();
        const long verify = SSL_get_verify_result(handle);
        if (verify != X509_V_OK)
          reason += std::string(": ") + X509_verify_cert_error_string(verify);
        if (ec == asio::ssl::error::make_error_code(asio::ssl::error::stream_truncated)) {
          reason = "the peer closed during the handshake";
        } else if (reason.find("wrong version number") != std::string::npos ||
                   reason.find("http request") != std::string::npos) {
          reason += " (not TLS: a plaintext client on the TLS port?)";
        }
      }
      spdlog::warn("TLS handshake with {} failed: {}", p->peer, reason);
      p->stream->lowest_layer().close(ignored);
      return;
    }
    // Admitted by the verify callback. Admitted now, under the policy running at completion: a
    // reload may have come after the verify callback (a client that withholds its Finished), and
    // the grants are the running policy's, whatever the handshake started under.
    PeerCertificate certificate;
    auto chain = std::make_shared<PeerCertificate::Chain>();
    chain->leaf = SSL_get1_peer_certificate(handle);
    if (STACK_OF(X509)* sent = SSL_get_peer_cert_chain(handle))
      chain->untrusted = X509_chain_up_ref(sent);
    certificate.identity_ = identity_of(chain->leaf);
    int error = X509_V_OK;
    Admission a =
        admit_chain(current(), chain->leaf, chain->untrusted, certificate.identity_, error);
    certificate.chain_ = std::move(chain);
    if (!a.admitted) {
      const bool reloaded = p->generation != running->generation;
      spdlog::warn("TLS handshake with {} refused at its completion: {}: {}{}", p->peer,
                   a.access.identity, a.refusal,
                   reloaded ? " (network.tls reloaded during the handshake)" : "");
      p->done(TlsStream(std::move(p->stream)), std::move(a), std::move(certificate));
      return;
    }
    spdlog::info("TLS: {} authenticated as {} ({}{})", p->peer, a.access.identity,
                 a.access.may_control ? "controller" : "observer",
                 a.access.may_stop ? "" : ", may not stop");
    p->done(TlsStream(std::move(p->stream)), std::move(a), std::move(certificate));
  }

  // Closes an unfinished handshake; it completes with an error and finish() logs `reason`.
  void drop(std::uint64_t seq, std::string reason) {
    auto it = pending.find(seq);
    if (it == pending.end()) return;
    const std::shared_ptr<Pending> p = std::move(it->second);
    pending.erase(it);
    p->dropped = std::move(reason);
    boost::system::error_code ignored;
    p->stream->lowest_layer().close(ignored);
  }

  std::shared_ptr<Running> running;  // never null; its generation never null
  std::map<std::uint64_t, std::shared_ptr<Pending>> pending;  // unfinished, oldest first
  std::uint64_t last_seq = 0;
};

TlsAcceptor::TlsAcceptor(const TlsConfig& config) : impl_(std::make_shared<Impl>(config)) {
  spdlog::info("TLS 1.3 with client certificates: CA {}, {} identities, {} denied{}", config.ca,
               config.identities.size(), config.deny.size(),
               config.crl.empty() ? "" : ", CRL " + config.crl);
  for (const auto& w : impl_->current().warnings)
    spdlog::warn("{}", w);
}

const std::vector<std::string>& TlsAcceptor::warnings() const noexcept {
  return impl_->current().warnings;
}

TlsAcceptor::~TlsAcceptor() {
  close_all();
}

void TlsAcceptor::reload(const TlsConfig& config) {
  // Pending handshakes hold the cell: from now on they are verified and admitted under this one.
  impl_->running->generation = load(config);
  spdlog::warn("TLS policy reloaded: {} identities, {} denied{}", config.identities.size(),
               config.deny.size(), config.crl.empty() ? "" : ", CRL " + config.crl);
  for (const auto& w : impl_->current().warnings)
    spdlog::warn("{}", w);
}

void TlsAcceptor::handshake(tcp::socket socket, std::string peer, Done done) {
  auto& d = *impl_;
  const auto limit =
      static_cast<std::size_t>(std::max(d.current().config.max_pending_handshakes, 1));
  while (d.pending.size() >= limit) {
    drop_oldest("dropped unfinished: " + std::to_string(limit) +
                " handshakes pending (network.tls.max_pending_handshakes)");
  }
  auto p = std::make_shared<Impl::Pending>();
  p->seq = ++d.last_seq;
  p->generation = d.running->generation;
  p->scratch.running = d.running;
  p->peer = std::move(peer);
  p->done = std::move(done);
  const auto executor = socket.get_executor();
  p->stream = std::make_unique<TlsStream::Ssl>(std::move(socket), p->generation->context);
  SSL_set_ex_data(p->stream->native_handle(), kExIndex, &p->scratch);
  p->timer = std::make_unique<asio::steady_timer>(executor);
  d.pending.emplace(p->seq, p);

  const double timeout_s = p->generation->config.handshake_timeout_s;
  p->timer->expires_after(std::chrono::duration_cast<asio::steady_timer::duration>(
      std::chrono::duration<double>(timeout_s)));
  std::weak_ptr<Impl> weak = impl_;
  p->timer->async_wait([weak, seq = p->seq, timeout_s](const boost::system::error_code& ec) {
    const auto impl = weak.lock();
    if (ec || !impl) return;
    char text[32];
    std::snprintf(text, sizeof text, "%g", timeout_s);
    impl->drop(seq,
               std::string("not finished within ") + text + " s (network.tls.handshake_timeout_s)");
  });
  // The Pending (stream, scratch, generation) stays alive in this handler until it ran.
  p->stream->async_handshake(ssl::stream_base::server,
                             [weak, p](const boost::system::error_code& ec) {
                               if (const auto impl = weak.lock()) impl->finish(p, ec);
                             });
}

std::string TlsAcceptor::recheck(const PeerCertificate& peer, const PeerAccess& granted) const {
  if (!peer.chain_) return "no certificate";
  // The chain, CRL and validity dates, as the handshake's verification does (same store, flags
  // and purpose); then the identities and the deny list.
  int error = X509_V_OK;
  const Admission a = admit_chain(impl_->current(), peer.chain_->leaf, peer.chain_->untrusted,
                                  peer.identity(), error);
  if (!a.admitted) return a.refusal;
  if (granted.may_control && !a.access.may_control)
    return "no longer granted the controller role (network.tls.identities)";
  if (granted.may_stop && !a.access.may_stop)
    return "no longer granted stopping (network.tls.identities: may_stop false)";
  return {};
}

std::size_t TlsAcceptor::pending() const noexcept {
  return impl_->pending.size();
}

bool TlsAcceptor::drop_oldest(std::string_view reason) {
  auto& d = *impl_;
  if (d.pending.empty()) return false;
  d.drop(d.pending.begin()->first, std::string(reason));
  return true;
}

void TlsAcceptor::close_all() {
  while (drop_oldest("daemon shutting down")) {
  }
}

}  // namespace ajar::daemon
