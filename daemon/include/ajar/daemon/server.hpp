// Server: the TCP listener on the single I/O thread. Accepts connections (TCP_NODELAY), refuses
// politely above max_clients (ERROR TOO_MANY_CLIENTS, then close), runs one Session per connection
// under the SessionHub (session_hub.hpp), and drives the engine: Engine::poll() and due telemetry
// every `poll_period` on a steady timer; engine events fan out to every session.
//
// Lifecycle, all on the I/O thread (the thread running `io`):
//   constructor installs the engine's event sink (so: before engine.start());
//   listen()  binds and listens (throws StartupError naming the address);
//   start()   accepts and polls (call after engine.start());
//   stop()    stops accepting and polling, closes every session gracefully. Idempotent.
// The engine must outlive the server.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/request_ledger.hpp"
#include "ajar/daemon/session.hpp"

namespace boost::asio {
class io_context;
}

namespace ajar::daemon {

struct NetworkConfig;
class SessionHub;

struct ServerOptions {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 7450;  // 0: any free port (see Server::port())
  int max_clients = 300;
  SessionOptions session;
  RequestLedger::Limits ledger;
  std::chrono::steady_clock::duration poll_period = std::chrono::milliseconds(2);

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
  void stop();

  std::uint16_t port() const noexcept;
  std::size_t session_count() const noexcept;
  const SessionHub& hub() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ajar::daemon
