#include "client_impl.hpp"  // first: includes <utility> before Asio

#include <future>

#include <openssl/x509.h>

#include "ajar/security/tls_files.hpp"

namespace ajar::client {

namespace {

// Empty when `path` may be used (the rule ajard applies too: ajar/security/tls_files.hpp).
std::string file_problem(const std::string& path, const char* what, bool secret) {
  const std::string problem = security::tls_file_problem(path, secret);
  return problem.empty() ? problem : std::string(what) + ": " + problem;
}

// The client's TLS context, or an error message.
std::string make_tls_context(const TlsOptions& o, std::shared_ptr<ssl::context>& out) {
  if (auto e = file_problem(o.ca, "CA certificate (--ca)", false); !e.empty()) return e;
  const bool has_certificate = !o.certificate.empty() || !o.private_key.empty();
  if (has_certificate) {
    if (o.certificate.empty() || o.private_key.empty())
      return "TLS: a client certificate needs both --cert and --key";
    if (auto e = file_problem(o.certificate, "certificate (--cert)", false); !e.empty()) return e;
    if (auto e = file_problem(o.private_key, "private key (--key)", true); !e.empty()) return e;
  }
  auto ctx = std::make_shared<ssl::context>(ssl::context::tls_client);
  if (SSL_CTX_set_min_proto_version(ctx->native_handle(), TLS1_3_VERSION) != 1)
    return "TLS: this OpenSSL cannot restrict to TLS 1.3";
  boost::system::error_code ec;
  ctx->load_verify_file(o.ca, ec);
  if (ec) return "cannot load CA certificate '" + o.ca + "': " + ec.message();
  if (has_certificate) {
    ctx->use_certificate_chain_file(o.certificate, ec);
    if (ec) return "cannot load certificate '" + o.certificate + "': " + ec.message();
    ctx->use_private_key_file(o.private_key, ssl::context::pem, ec);
    if (ec) return "cannot load private key '" + o.private_key + "': " + ec.message();
    if (SSL_CTX_check_private_key(ctx->native_handle()) != 1)
      return "private key '" + o.private_key + "' does not match certificate '" + o.certificate +
             "'";
  }
  ctx->set_verify_mode(ssl::verify_peer);
  out = std::move(ctx);
  return {};
}

// ErrorCode has no value for a transport failure (the wire never carries one): kDriverError, the
// generic "see the message", with `field` saying where to look.
Error connect_error(std::string field, std::string message) {
  return make_error(ErrorCode::kDriverError, std::move(field), std::move(message));
}

}  // namespace

Outcome Client::connect(const Endpoint& endpoint) {
  return connect(endpoint, options_.connect_timeout);
}

// Resolve, connect, the TLS handshake when TLS is on, all bounded by one timer; the promise gets
// "" once connected (the Impl then reads and heartbeats on the new socket), else why not. Each
// pending handler holds the attempt; after the first outcome (`done_`) the others are ignored.
class Client::Impl::Connecting : public std::enable_shared_from_this<Client::Impl::Connecting> {
 public:
  Connecting(Impl* impl, const Endpoint& endpoint, Milliseconds timeout,
             std::shared_ptr<std::promise<std::string>> promise,
             std::shared_ptr<ssl::context> tls_context, std::string server_name)
      : impl_(impl),
        endpoint_(endpoint),
        where_(endpoint.host + ":" + std::to_string(endpoint.port)),
        sock_(std::make_shared<tcp::socket>(impl->io)),
        timer_(impl->io, timeout),
        resolver_(impl->io),
        promise_(std::move(promise)),
        tls_context_(std::move(tls_context)),
        server_name_(std::move(server_name)) {}

  void start() {
    timer_.async_wait(
        [self = shared_from_this()](boost::system::error_code ec) { self->timed_out(ec); });
    resolver_.async_resolve(endpoint_.host, std::to_string(endpoint_.port),
                            [self = shared_from_this()](boost::system::error_code ec,
                                                        tcp::resolver::results_type results) {
                              self->resolved(ec, results);
                            });
  }

 private:
  void timed_out(boost::system::error_code ec) {
    if (ec || done_) return;
    done_ = true;
    resolver_.cancel();
    boost::system::error_code ignored;
    sock_->close(ignored);
    promise_->set_value("timed out connecting to " + where_);
  }

  // The attempt failed: `why`.
  void fail(std::string why) {
    done_ = true;
    timer_.cancel();
    promise_->set_value(std::move(why));
  }

  void resolved(boost::system::error_code ec, const tcp::resolver::results_type& results) {
    if (done_) return;
    if (ec) return fail("cannot resolve " + where_ + ": " + ec.message());
    asio::async_connect(
        *sock_, results,
        [self = shared_from_this()](boost::system::error_code cec, const tcp::endpoint&) {
          self->connected(cec);
        });
  }

  void connected(boost::system::error_code ec) {
    if (done_) return;
    if (ec) return fail("cannot connect to " + where_ + ": " + ec.message());
    boost::system::error_code ignored;
    sock_->set_option(tcp::no_delay(true), ignored);
    if (!tls_context_) return established(nullptr);
    start_handshake();
  }

  // TLS: verify the daemon's certificate for `server_name` (DNS name or IP).
  void start_handshake() {
    auto tls = std::make_shared<TlsSocket>(*sock_, *tls_context_);
    boost::system::error_code addr_ec;
    asio::ip::make_address(server_name_, addr_ec);
    if (addr_ec)  // a name, not an address: send it (SNI)
      SSL_ctrl(tls->native_handle(), SSL_CTRL_SET_TLSEXT_HOSTNAME, TLSEXT_NAMETYPE_host_name,
               const_cast<char*>(server_name_.c_str()));
    tls->set_verify_callback(ssl::host_name_verification(server_name_));
    tls->async_handshake(ssl::stream_base::client,
                         [self = shared_from_this(), tls](boost::system::error_code hec) {
                           self->handshaken(hec, tls);
                         });
  }

  void handshaken(boost::system::error_code ec, const std::shared_ptr<TlsSocket>& tls) {
    if (done_) return;
    if (!ec) return established(tls);
    std::string why = "TLS handshake with " + where_ + " failed: " + ec.message();
    const long verify = SSL_get_verify_result(tls->native_handle());
    if (verify != X509_V_OK)
      why += std::string(" (daemon certificate: ") + X509_verify_cert_error_string(verify) + ")";
    boost::system::error_code ignored_ec;
    sock_->close(ignored_ec);
    fail(std::move(why));
  }

  // Connected (over `tls` when TLS is on): the Impl takes the socket, forgets the old
  // connection's replies and starts reading and the heartbeat.
  void established(std::shared_ptr<TlsSocket> tls) {
    done_ = true;
    timer_.cancel();
    impl_->socket = sock_;
    impl_->tls = std::move(tls);
    impl_->tls_context = tls_context_;
    {
      std::lock_guard lock(impl_->mutex);
      impl_->is_connected = true;
      impl_->replies.clear();
      impl_->stale.clear();  // the old connection's replies never come
      impl_->welcome.reset();
    }
    impl_->start_read(sock_);
    impl_->schedule_heartbeat();
    promise_->set_value("");
  }

  Impl* impl_;
  const Endpoint endpoint_;
  const std::string where_;
  std::shared_ptr<tcp::socket> sock_;
  asio::steady_timer timer_;
  tcp::resolver resolver_;
  std::shared_ptr<std::promise<std::string>> promise_;
  std::shared_ptr<ssl::context> tls_context_;  // null: plain TCP
  const std::string server_name_;
  bool done_ = false;
};

Outcome Client::connect(const Endpoint& endpoint, Milliseconds timeout) {
  std::shared_ptr<ssl::context> tls_context;
  if (options_.tls.enabled()) {
    if (auto e = make_tls_context(options_.tls, tls_context); !e.empty())
      return connect_error("tls", std::move(e));
  }
  const std::string server_name =
      options_.tls.server_name.empty() ? endpoint.host : options_.tls.server_name;
  auto promise = std::make_shared<std::promise<std::string>>();
  auto future = promise->get_future();
  Impl* impl = impl_.get();
  asio::post(impl->io, [impl, endpoint, timeout, promise, tls_context, server_name] {
    impl->on_closed("");
    impl->decoder.reset();
    impl->track_filled = 0;
    impl->track_skip = 0;
    std::make_shared<Impl::Connecting>(impl, endpoint, timeout, promise, tls_context, server_name)
        ->start();
  });
  if (future.wait_for(timeout + Milliseconds{2000}) != std::future_status::ready) {
    return connect_error("endpoint", "timed out connecting to " + endpoint.host + ":" +
                                         std::to_string(endpoint.port));
  }
  if (std::string why = future.get(); !why.empty())
    return connect_error("endpoint", std::move(why));
  return Ok{};
}

}  // namespace ajar::client
