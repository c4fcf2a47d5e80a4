// A server of the Foxglove WebSocket protocol (subprotocol `foxglove.websocket.v1`, the public
// specification of foxglove/ws-protocol, docs/spec.md): Foxglove Studio, or any client of that
// protocol, connects and subscribes to the channels the server advertises. Read-only: no client
// publishing, parameters or services (a client that asks gets a status message saying so).
//
// What it speaks: on connect, serverInfo then advertise (every channel, with its JSON Schema); the
// client's subscribe / unsubscribe (JSON text); messageData (binary: opcode 0x01, uint32
// subscription id, uint64 log time in ns since the Unix epoch, both little-endian, then the
// payload). A channel marked `latched` gives a new subscriber its last message at once.
//
// Threads: one thread of its own (own io_context) owns the listening socket and every client, so a
// slow or busy Foxglove client never delays the caller. publish() never blocks: it does nothing
// while nobody subscribes to the channel (one atomic load), otherwise it posts the payload's
// builder to that thread, which builds it once and queues it for each subscriber.
//
// Bounds (slow or many clients): at most max_clients connections at once, counting those still in
// their HTTP/WebSocket upgrade — a connection beyond is refused at once with HTTP 503 (its request
// is not read; at most max_clients such refusals are in flight, more are closed unanswered); an
// upgrade not done within upgrade_timeout (a client that connects and sends nothing, or half a
// request) is closed, counted in `upgrades_timed_out`; per client at most max_queued_messages /
// max_queued_bytes of data waiting — a new message pushes out the oldest, counted in
// `messages_dropped`; a client whose write has made no progress for stalled_write_timeout is
// disconnected, counted in `clients_disconnected_slow`.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace ajar::console::foxglove {

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

struct Channel {
  std::uint32_t id = 0;  // unique, > 0
  std::string topic;
  std::string encoding = "json";
  std::string schema_name;
  std::string schema_encoding = "jsonschema";
  std::string schema;    // the JSON Schema, as text
  bool latched = false;  // a new subscriber gets the last message at once
};

struct ServerOptions {
  std::string host = "127.0.0.1";  // loopback only: listen() refuses any other address
  std::uint16_t port = 8765;       // 0: any free port
  std::string name = "ajar-console";
  std::size_t max_clients = 8;
  std::size_t max_queued_messages = 64;      // per client, data waiting to be written
  std::size_t max_queued_bytes = 16u << 20;  // per client
  std::chrono::milliseconds stalled_write_timeout{5000};
  std::chrono::milliseconds upgrade_timeout{5000};  // connect -> WebSocket open, or closed
};

struct ServerStats {
  std::uint64_t clients = 0;   // connected now
  std::uint64_t upgrades = 0;  // connections in their HTTP/WebSocket upgrade now
  std::uint64_t clients_total = 0;
  std::uint64_t clients_refused = 0;     // beyond max_clients, a bad Host/Origin, no subprotocol
  std::uint64_t upgrades_timed_out = 0;  // closed: not upgraded within upgrade_timeout
  std::uint64_t clients_disconnected_slow = 0;
  std::uint64_t messages_sent = 0;
  std::uint64_t messages_dropped = 0;  // pushed out of a full client queue
};

// True for 127.0.0.0/8 and ::1 (what listen() accepts).
bool is_loopback_address(const std::string& host);

class Server {
 public:
  Server(ServerOptions options, std::vector<Channel> channels);
  ~Server();  // stop() and join
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds and listens. Throws std::runtime_error naming the address: not a loopback address, or
  // it cannot be bound. Returns the bound port.
  std::uint16_t listen();
  void start();  // the server's thread
  void stop();   // thread-safe; closes every client

  // Whether any client subscribes to the channel now (an atomic load: callers skip building).
  bool subscribed(std::uint32_t channel_id) const;
  // Sends `build()` on the channel to its subscribers, stamped `log_time_ns` (Unix epoch). Never
  // blocks; `build` runs once, on the server's thread, and only when someone subscribes (or the
  // channel is latched).
  void publish(std::uint32_t channel_id, std::uint64_t log_time_ns,
               std::function<std::string()> build);
  ServerStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Nanoseconds since the Unix epoch now (Foxglove's time base).
std::uint64_t unix_time_ns();

}  // namespace ajar::console::foxglove
