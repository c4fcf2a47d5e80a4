// Server: the TCP listener on the single I/O thread. Accepts connections (TCP_NODELAY), runs one
// Session per connection under the SessionHub (session_hub.hpp), and drives the engine:
// Engine::poll(), due telemetry, settled held replies and the Hello deadline every `poll_period`
// on a steady timer; engine events fan out to every session.
//
// A full table never refuses a stop: at max_clients a newcomer makes room (the hub closes the
// idlest un-greeted session, else the idlest observer); when there is none (only the controller),
// the newcomer gets ERROR TOO_MANY_CLIENTS, its frames are still read for `refused_read_window`
// (its Stop/EmergencyStop executed and acknowledged), then it is closed.
//
// Lifecycle, all on the I/O thread (the thread running `io`):
//   constructor      installs the engine's event sink (so: before engine.start());
//   bind()           loads TLS (throws StartupError naming the TLS key or file), refuses plaintext
//                    off loopback unless insecure_plaintext (warns then), and binds the address
//                    (throws StartupError naming it: a busy port fails before
//                    the engine starts); not listening yet, so a connect is refused;
//   start()          listens, accepts and polls (call once the engine serves: a TCP connect then
//                    means the daemon serves);
//   begin_shutdown() stops accepting (pending TLS handshakes dropped); sessions stay open and are
//                    still served by the poll timer (engine reports and events, held replies,
//                    telemetry), but every request except Stop and EmergencyStop — which are
//                    executed and acknowledged — gets SHUTTING_DOWN (SessionHub::begin_shutdown);
//                    the daemon's SIGTERM path, while the engine's stop runs (Engine steps);
//   stop_accepting() begin_shutdown() and stops polling (a caller that runs Engine::shutdown()
//                    in one blocking call: its motion_stopped still reaches the sessions);
//   stop()           stop_accepting(), sends every held reply, closes every session gracefully
//                    (queued frames flushed first, no further request read), detaches the event
//                    sink. Idempotent.
// TLS (options.tls.enabled, tls.hpp): every accepted socket first completes the mutual TLS
// handshake; only then is it a session (or a refused connection, as above, over TLS). Handshakes
// in progress count against max_clients: at sessions + handshakes >= max_clients the oldest
// unfinished handshake is dropped; at most tls.max_pending_handshakes run at once.
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

class Recordings;
class SessionHub;

struct ServerOptions {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 7450;  // 0: any free port (see Server::port())
  int max_clients = 300;
  SessionOptions session;
  RequestLedger::Limits ledger;
  std::chrono::steady_clock::duration poll_period = std::chrono::milliseconds(2);
  std::chrono::steady_clock::duration hello_timeout = std::chrono::seconds(5);  // 0 = none
  std::chrono::steady_clock::duration refused_read_window = std::chrono::seconds(1);
  TlsConfig tls;                    // tls.enabled: mutual TLS 1.3 on every connection
  bool insecure_plaintext = false;  // plaintext off loopback: warned at bind()
  Recordings* recordings =
      nullptr;  // the recorder for protocol 1.2 (null: off); outlives the server

  static ServerOptions from(const NetworkConfig& network);
};

class Server {
 public:
  Server(boost::asio::io_context& io, Engine& engine, ServerOptions options);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds (not listening yet). Returns the bound port. Throws StartupError.
  std::uint16_t bind();
  // Listens, starts accepting and the poll timer. Throws StartupError when listen() fails.
  void start();
  void begin_shutdown();
  void stop_accepting();
  void stop();
  // Re-reads network.tls (SIGHUP): files, CRL, deny list, identities; new connections use it, and
  // every connected TLS session is re-checked as if it connected now (TlsAcceptor::recheck): one
  // the new policy refuses or grants less gets ERROR NOT_CONTROLLER (field "certificate", the
  // message names the identity and why) and is closed after it (Session::close_after_flush).
  // Throws StartupError (the running policy and sessions stay). Nothing to do without TLS.
  void reload_tls(const TlsConfig& tls);

  std::uint16_t port() const noexcept;
  std::size_t session_count() const noexcept;
  const SessionHub& hub() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ajar::daemon
