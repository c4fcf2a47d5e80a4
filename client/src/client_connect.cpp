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
    auto sock = std::make_shared<tcp::socket>(impl->io);
    auto timer = std::make_shared<asio::steady_timer>(impl->io, timeout);
    auto resolver = std::make_shared<tcp::resolver>(impl->io);
    auto done = std::make_shared<bool>(false);
    const std::string where = endpoint.host + ":" + std::to_string(endpoint.port);
    timer->async_wait([sock, resolver, done, promise, where](boost::system::error_code ec) {
      if (ec || *done) return;
      *done = true;
      resolver->cancel();
      boost::system::error_code ignored;
      sock->close(ignored);
      promise->set_value("timed out connecting to " + where);
    });
    resolver->async_resolve(
        endpoint.host, std::to_string(endpoint.port),
        [impl, sock, timer, resolver, done, promise, where, tls_context, server_name](
            boost::system::error_code ec, tcp::resolver::results_type results) {
          if (*done) return;
          if (ec) {
            *done = true;
            timer->cancel();
            promise->set_value("cannot resolve " + where + ": " + ec.message());
            return;
          }
          asio::async_connect(
              *sock, results,
              [impl, sock, timer, done, promise, where, tls_context, server_name](
                  boost::system::error_code cec, const tcp::endpoint&) {
                if (*done) return;
                if (cec) {
                  *done = true;
                  timer->cancel();
                  promise->set_value("cannot connect to " + where + ": " + cec.message());
                  return;
                }
                boost::system::error_code ignored;
                sock->set_option(tcp::no_delay(true), ignored);
                auto established = [impl, sock, timer, done, promise](
                                       std::shared_ptr<TlsSocket> tls,
                                       std::shared_ptr<ssl::context> context) {
                  *done = true;
                  timer->cancel();
                  impl->socket = sock;
                  impl->tls = std::move(tls);
                  impl->tls_context = std::move(context);
                  {
                    std::lock_guard lock(impl->mutex);
                    impl->is_connected = true;
                    impl->replies.clear();
                    impl->stale.clear();  // the old connection's replies never come
                    impl->welcome.reset();
                  }
                  impl->start_read(sock);
                  impl->schedule_heartbeat();
                  promise->set_value("");
                };
                if (!tls_context) {
                  established(nullptr, nullptr);
                  return;
                }
                // TLS: verify the daemon's certificate for `server_name` (DNS name or IP).
                auto tls = std::make_shared<TlsSocket>(*sock, *tls_context);
                boost::system::error_code addr_ec;
                asio::ip::make_address(server_name, addr_ec);
                if (addr_ec)  // a name, not an address: send it (SNI)
                  SSL_ctrl(tls->native_handle(), SSL_CTRL_SET_TLSEXT_HOSTNAME,
                           TLSEXT_NAMETYPE_host_name, const_cast<char*>(server_name.c_str()));
                tls->set_verify_callback(ssl::host_name_verification(server_name));
                tls->async_handshake(
                    ssl::stream_base::client, [sock, tls, tls_context, done, timer, promise, where,
                                               established](boost::system::error_code hec) {
                      if (*done) return;
                      if (hec) {
                        *done = true;
                        timer->cancel();
                        std::string why =
                            "TLS handshake with " + where + " failed: " + hec.message();
                        const long verify = SSL_get_verify_result(tls->native_handle());
                        if (verify != X509_V_OK)
                          why += std::string(" (daemon certificate: ") +
                                 X509_verify_cert_error_string(verify) + ")";
                        boost::system::error_code ignored_ec;
                        sock->close(ignored_ec);
                        promise->set_value(why);
                        return;
                      }
                      established(tls, tls_context);
                    });
              });
        });
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
