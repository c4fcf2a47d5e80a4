// Server: the TCP listener on the single I/O thread. Accepts connections (TCP_NODELAY), refuses
// politely above max_clients (ERROR TOO_MANY_CLIENTS, then close), runs one Session per connection
// under the SessionHub (session_hub.hpp), and drives the engine: Engine::poll() and due telemetry
// every `poll_period` on a steady timer; engine events fan out to every session.
//
// Lifecycle, all on the I/O thread (the thread running `io`):
//   constructor installs the engine's event sink (so: before engine.start());
//   listen()  loads TLS (tls.enabled, see tls.hpp), binds and listens (throws StartupError naming
//             the address or the TLS file);
//   start()   accepts and polls (call after engine.start());
//   stop()    stops accepting and polling, closes every session gracefully. Idempotent.
// With TLS, every accepted socket first goes through the TLS handshake (tls.hpp); handshakes in
// progress count against max_clients (when full, the oldest unfinished handshake is dropped, else
// the connection is closed: a refusal frame cannot be sent before the handshake).
// The engine must outlive the server.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/request_ledger.hpp"
#include "ajar/daemon/session.hpp"

namespace boost::asio {
class io_context;
}

namespace ajar::daemon {

class SessionHub;

struct ServerOptions {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 7450;  // 0: any free port (see Server::port())
  int max_clients = 300;
  SessionOptions session;
  RequestLedger::Limits ledger;
  std::chrono::steady_clock::duration poll_period = std::chrono::milliseconds(2);
  TlsConfig tls;                    // tls.enabled: mutual TLS 1.3 on every connection
  bool insecure_plaintext = false;  // plaintext off loopback: warned at listen()

  static ServerOptions from(const NetworkConfig& network);
};

class Server {
 public:
  Server(boost::asio::io_context& io, Engine& engine, ServerOptions options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds and listens. Returns the bound port. Throws StartupError.
  std::uint16_t listen();
  // Starts accepting and the poll timer.
  void start();
  // Re-reads the TLS policy files (SIGHUP): CRL, deny list, identities. Throws StartupError
  // (the running policy stays). Nothing to do without TLS.
  void reload_tls(const TlsConfig& tls);
  void stop();

  std::uint16_t port() const noexcept;
  std::size_t session_count() const noexcept;
  const SessionHub& hub() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ajar::daemon
