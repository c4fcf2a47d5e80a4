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
//   new connections use them; on error the running policy stays and reload() throws.
// - Files: the private key is refused when group/world accessible; certificate, CA and CRL when
//   group/world writable.
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
  PeerAccess access;
};
Admission admit(const TlsConfig& policy, const CertificateIdentity& certificate);

// Refuses a secret (private key) that is group/world accessible, or another file that is
// group/world writable; throws StartupError naming `key` (the config key) and the path.
void check_file_permissions(const std::string& path, std::string_view key, bool secret);

class TlsAcceptor {
 public:
  using Done = std::function<void(TlsStream stream, PeerAccess access)>;

  // Loads certificate, key, CA, CRL. Throws StartupError naming the config key and file.
  explicit TlsAcceptor(const TlsConfig& config);
  ~TlsAcceptor();
  TlsAcceptor(const TlsAcceptor&) = delete;
  TlsAcceptor& operator=(const TlsAcceptor&) = delete;

  // Throws StartupError (the running policy stays).
  void reload(const TlsConfig& config);

  // Runs the server handshake on `socket`; `done` is called (on the I/O thread) only on success.
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
