// Mutual TLS 1.3 on the server's accept path (docs/security.md). The Server hands each accepted
// socket to TlsAcceptor::handshake(); only a peer whose certificate chains to network.tls.ca, is
// not revoked (CRL) nor denied, and is admitted by network.tls.identities/unlisted reaches a
// Session (Session<TlsStream>), with the PeerAccess its certificate grants. Nothing of the
// protocol is read before that: a failed handshake is logged (peer address and reason) and closed.
//
// - Only TLS 1.3; no session resumption (tickets, cache): every connection verifies the
//   certificate against the current CA, CRL and deny list.
// - Handshake deadline network.tls.handshake_timeout_s; at most max_pending_handshakes at once:
//   beyond, the OLDEST unfinished handshake is dropped, so sockets that never finish (slowloris)
//   cannot keep a real client out. The Server counts pending() against max_clients.
// - reload() (SIGHUP) re-reads the CRL, deny list, identities and unlisted (and the files):
//   new connections use them, and the Server re-checks every connected TLS session with
//   recheck() (server.hpp); on error the running policy stays and reload() throws.
// - A PENDING handshake is judged by the policy running when its certificate is verified and
//   again when it completes, not by the one running when it was accepted: a client that withholds
//   its certificate across a revoking reload is refused like a fresh connection (a TLS alert), and
//   one whose Finished arrives after the reload is refused at completion (Done with
//   admitted == false). Its grants are the running policy's.
// - An expired CRL (nextUpdate passed) is a warning at start and on every reload (warnings()).
// - Files: the rule of ajar/security/tls_files.hpp (shared with ajar_client): the private key is
//   refused when group/world accessible; certificate, CA and CRL when group/world writable.
//
// Threading: I/O thread only (the thread running the io_context).
#pragma once

#include <utility>  // before Asio (asio issue 944)

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/buffer.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/stream.hpp>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/session.hpp"

namespace ajar::daemon {

// A handshaken TLS stream for Session<TlsStream>: the ssl::stream lives on the heap so that the
// handle can be moved into the session; several buffers of one gather-write go out as one TLS
// record (ssl::stream writes only the first buffer of a sequence per call).
class TlsStream {
 public:
  using Ssl = boost::asio::ssl::stream<boost::asio::ip::tcp::socket>;
  using executor_type = Ssl::executor_type;
  using lowest_layer_type = Ssl::lowest_layer_type;

  explicit TlsStream(std::unique_ptr<Ssl> stream) : state_(std::make_unique<State>()) {
    state_->ssl = std::move(stream);
  }

  executor_type get_executor() { return state_->ssl->get_executor(); }
  lowest_layer_type& lowest_layer() { return state_->ssl->lowest_layer(); }

  template <typename Buffers, typename Handler>
  auto async_read_some(const Buffers& buffers, Handler&& handler) {
    return state_->ssl->async_read_some(buffers, std::forward<Handler>(handler));
  }

  // Clean close (Session::half_close, once everything queued is written): sends the TLS
  // close_notify alert now. Not asio's async_shutdown, which would read the peer's close_notify
  // while the session's own read is pending on the same stream: the session keeps reading until
  // the peer closes (its close_notify reads as eof) or its linger ends - that is the deadline. The
  // socket is non-blocking for this call, so a peer that does not read cannot hold it (the alert
  // is then lost; the FIN and the linger follow as without TLS).
  void close_notify() {
    boost::system::error_code ec;
    state_->ssl->next_layer().non_blocking(true, ec);
    if (!ec) state_->ssl->shutdown(ec);  // "would block" waiting for the peer's: expected
  }

  template <typename Buffers, typename Handler>
  auto async_write_some(const Buffers& buffers, Handler&& handler) {
    auto& joined = state_->write_buffer;
    joined.clear();
    for (auto it = boost::asio::buffer_sequence_begin(buffers);
         it != boost::asio::buffer_sequence_end(buffers); ++it) {
      const boost::asio::const_buffer b(*it);
      const auto* bytes = static_cast<const std::uint8_t*>(b.data());
      joined.insert(joined.end(), bytes, bytes + b.size());
    }
    return state_->ssl->async_write_some(boost::asio::buffer(joined),
                                         std::forward<Handler>(handler));
  }

 private:
  struct State {
    std::unique_ptr<Ssl> ssl;
    std::vector<std::uint8_t> write_buffer;  // alive while a write is pending
  };
  std::unique_ptr<State> state_;
};

using TlsSession = Session<TlsStream>;

// What a peer certificate says about its holder.
struct CertificateIdentity {
  std::string common_name;
  std::vector<std::string> subject_alt_names;  // DNS, IP (text), email, URI
  std::string sha256;                          // upper-case hex, no colons
  std::string text() const;                    // "cn:alice (sha256:AB12CD34...)"
};
bool matches(const TlsIdentity& id, const CertificateIdentity& certificate);

// The decision for one certificate under one policy (pure; tested directly).
struct Admission {
  bool admitted = false;
  std::string refusal;  // when not admitted: why ("denied by network.tls.deny: cn:bob")
  PeerAccess access;    // the grants; none when not admitted (identity still named)
};
Admission admit(const TlsConfig& policy, const CertificateIdentity& certificate);

// The certificate chain a session authenticated with, kept by the Server to re-check the session
// when the policy is reloaded (TlsAcceptor::recheck). Cheap to copy (shared, immutable).
class PeerCertificate {
 public:
  const CertificateIdentity& identity() const noexcept { return identity_; }

 private:
  friend class TlsAcceptor;
  struct Chain;  // the OpenSSL objects (tls.cpp)
  std::shared_ptr<const Chain> chain_;
  CertificateIdentity identity_;
};

class TlsAcceptor {
 public:
  // Called when the TLS handshake succeeded. `admission` is the running policy's decision at that
  // moment: when not admitted (the policy was reloaded after the certificate was verified), the
  // caller must tell the peer admission.refusal and close without handling anything it sends.
  using Done = std::function<void(TlsStream stream, Admission admission, PeerCertificate peer)>;

  // Loads certificate, key, CA, CRL. Throws StartupError naming the config key and file.
  explicit TlsAcceptor(const TlsConfig& config);
  ~TlsAcceptor();
  TlsAcceptor(const TlsAcceptor&) = delete;
  TlsAcceptor& operator=(const TlsAcceptor&) = delete;

  // Throws StartupError (the running policy stays).
  void reload(const TlsConfig& config);
  // Of the running policy, logged (warn) at construction and on every reload(): a CRL whose
  // nextUpdate has passed (every certificate of its CA is refused: fail closed) or comes within
  // 7 days.
  const std::vector<std::string>& warnings() const noexcept;

  // A connected session under the running policy, as if it connected now: why it must be closed
  // (its certificate revoked by the CRL, expired, denied, no longer admitted, or `granted` more
  // than the policy now grants it), or "" when it may stay.
  std::string recheck(const PeerCertificate& peer, const PeerAccess& granted) const;

  // Runs the server handshake on `socket`; `done` is called (on the I/O thread) only when the TLS
  // handshake succeeded (failures are logged and closed here).
  // First drops the oldest pending handshake when max_pending_handshakes are running.
  void handshake(boost::asio::ip::tcp::socket socket, std::string peer, Done done);

  std::size_t pending() const noexcept;
  // Drops the oldest unfinished handshake (logged with `reason`). False when there is none.
  bool drop_oldest(std::string_view reason);
  // Drops every unfinished handshake (shutdown).
  void close_all();

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;  // handlers hold a weak_ptr
};

}  // namespace ajar::daemon
