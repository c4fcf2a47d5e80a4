// Host-side client of ajard: one TCP connection (plaintext, or mutual TLS 1.3), the Hello
// handshake, request/reply with request ids and timeouts, events and telemetry callbacks, and a
// heartbeat. Linkable by a GUI.
//
// Threading contract:
//  - Every public method is thread-safe and synchronous (it blocks the calling thread until done or
//    its timeout expires). An internal I/O thread (Boost.Asio) owns the socket.
//  - Event, telemetry and disconnect callbacks run ON THE I/O THREAD. They must return quickly and
//    must not call blocking Client methods (request, hello, connect, close): that would deadlock
//    until the call times out. Copy the value and hand it to your own thread (e.g. post to the GUI
//    event loop). Set the callbacks before connect(); setting them later is allowed
//    (mutex-guarded).
//  - The Client must not be destroyed from inside one of its callbacks. Replacing a callback
//    (on_event(nullptr)) does not wait for a call already running: keep what a callback uses alive
//    until the Client is destroyed (the destructor joins the I/O thread).
//
// Retries: a request that times out is re-sent with the SAME request id (flag kFlagRetransmit); the
// daemon de-duplicates by (client_instance_id, request id), so a retried command executes once.
// The daemon answers every frame, so a retried request may be answered more than once: once a
// request is over (answered or timed out), the replies still owed to it are dropped on arrival and
// never handed to a later wait_reply().
// The client_instance_id survives reconnects of one Client object (random per Client unless given),
// and request ids keep increasing across reconnects.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/core/result.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/endpoint.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::client {

using Milliseconds = std::chrono::milliseconds;

// "HOST:PORT" (HOST may be a name, an IPv4 address or "[IPv6]"). Port 1..65535. parse_endpoint
// is protocol::parse_host_port (ajar/protocol/endpoint.hpp) without port 0.
struct Endpoint {
  std::string host = "127.0.0.1";
  std::uint16_t port = 7450;
};
std::optional<Endpoint> parse_endpoint(std::string_view text);

// What a call came back with.
enum class CallOutcome {
  kReply,         // the daemon answered with the expected reply (Ack, Pong, Status, Welcome)
  kRefused,       // the daemon answered with an ErrorReply (see Response::error), or the
                  // request could not be encoded and was not sent (attempts 0; e.g. BAD_COUNT)
  kTimeout,       // no reply within the timeout (after all retries)
  kDisconnected,  // not connected, connection lost or refused
};
std::string_view to_string(CallOutcome outcome) noexcept;

struct Response {
  CallOutcome outcome = CallOutcome::kDisconnected;
  protocol::Message reply;       // kReply / kRefused: the reply message as received
  protocol::ErrorReply error;    // kRefused: a copy of the ErrorReply
  std::string transport_error;   // kTimeout / kDisconnected: what happened, for people
  std::uint32_t request_id = 0;  // the id the request travelled with
  int attempts = 0;              // frames sent (1 + retries used)
  Milliseconds round_trip{0};    // send of the last attempt -> reply
  // The session's protocol minor version (Welcome.version_minor) when the reply came; 0 unknown.
  // The printers show the fields a later minor appended only when the session has them.
  std::uint8_t session_minor = 0;
  bool ok() const { return outcome == CallOutcome::kReply; }
  template <typename T>
  const T* get() const {
    return std::get_if<T>(&reply);
  }
};

// Mutual TLS 1.3 (docs/security.md): on when `ca` is set. The daemon's certificate must chain to
// `ca` and name the host connected to (or `server_name`); the client presents `certificate`.
// Files are checked before use: a private key accessible to group or others is refused.
struct TlsOptions {
  std::string ca;           // CA certificate(s), PEM
  std::string certificate;  // this client's certificate chain, PEM (empty: none; ajard refuses)
  std::string private_key;  // its private key, PEM
  std::string server_name;  // the name to verify the daemon's certificate against (empty: host)
  bool enabled() const { return !ca.empty(); }
};

struct ClientOptions {
  Milliseconds connect_timeout{3000};
  Milliseconds request_timeout{3000};    // per attempt
  int retries = 1;                       // re-sends after the first attempt, same request id
  std::uint64_t client_instance_id = 0;  // 0: random per Client object
  std::string client_name = "ajarctl";
  TlsOptions tls;  // plaintext unless tls.ca is set
};

class Client {
 public:
  using EventHandler = std::function<void(const protocol::Event&)>;
  using TelemetryHandler = std::function<void(const protocol::Telemetry&)>;
  using DisconnectHandler = std::function<void(const std::string& why)>;

  explicit Client(ClientOptions options = {});
  ~Client();  // closes the connection and joins the I/O thread
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Connects (closing any previous connection); timeout: options.connect_timeout unless given.
  // The error's message says why not, for people; its field is "tls" (a TLS file or setting was
  // refused before anything was sent) or "endpoint" (resolving, connecting, the TLS handshake, the
  // timeout). Its code is always ErrorCode::kDriverError: the wire's codes name no transport
  // failure.
  Outcome connect(const Endpoint& endpoint);
  Outcome connect(const Endpoint& endpoint, Milliseconds timeout);
  void close();
  bool connected() const;

  // The Hello handshake. On kReply, Response::get<Welcome>() holds the Welcome (also kept below).
  Response hello(protocol::Role role, bool take_over = false);
  std::optional<protocol::Welcome> welcome() const;

  // Sends `request` with a fresh request id and waits for the reply with that id, retrying on
  // timeout. timeout <= 0 uses options.request_timeout.
  Response request(const protocol::Message& request, Milliseconds timeout = Milliseconds{0});
  Response request(const protocol::Message& request, Milliseconds timeout, int retries);

  // Heartbeat: while enabled, the I/O thread sends a Ping every `interval` (keeps the deadman fed
  // while a controller waits for motion). Their Pongs are swallowed. interval <= 0 disables.
  void set_heartbeat(Milliseconds interval);

  void on_event(EventHandler handler);
  void on_telemetry(TelemetryHandler handler);
  void on_disconnect(DisconnectHandler handler);

  // ---- Low level, for conformance tests --------------------------------------------------------
  std::uint32_t next_request_id();
  std::uint64_t client_instance_id() const { return instance_id_; }
  // Writes raw bytes as they are (no framing). False when not connected.
  bool send_raw(std::span<const std::uint8_t> bytes);
  // Encodes and writes one envelope as it is (no id assignment, no waiting). False when not
  // connected or when the envelope cannot be encoded (see protocol::encode).
  bool send_envelope(const protocol::Envelope& envelope);
  // Waits for a non-event, non-telemetry frame with `request_id` (any id when nullopt).
  std::optional<protocol::Envelope> wait_reply(std::optional<std::uint32_t> request_id,
                                               Milliseconds timeout);
  // Waits until the daemon closes the connection. True if it did within the timeout.
  bool wait_closed(Milliseconds timeout);
  // Drops every queued, unclaimed reply.
  void discard_replies();
  // While on, the header of every frame received (also of frames that fail to decode) is kept in
  // arrival order: which minor version and payload length the daemon wrote. Turning it on clears
  // what was kept.
  void record_headers(bool on);
  std::vector<protocol::FrameHeader> recorded_headers() const;

  const ClientOptions& options() const { return options_; }

 private:
  struct Impl;
  ClientOptions options_;
  std::uint64_t instance_id_;
  std::unique_ptr<Impl> impl_;
};

// Fills a FramedPoint.
protocol::FramedPoint framed(core::Frame frame, double x_m, double y_m, double z_m);

}  // namespace ajar::client
