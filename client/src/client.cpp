#include <utility>  // before Asio (asio issue 944 with GCC 12)

#include "ajar/client/client.hpp"

#include <atomic>
#include <charconv>
#include <condition_variable>
#include <deque>
#include <future>
#include <mutex>
#include <random>
#include <set>
#include <unordered_map>
#include <thread>

#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <openssl/x509.h>

#include "ajar/security/tls_files.hpp"

namespace ajar::client {

namespace asio = boost::asio;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using TlsSocket = ssl::stream<tcp::socket&>;

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

}  // namespace

std::optional<Endpoint> parse_endpoint(std::string_view text) {
  std::string_view host;
  std::string_view port_text;
  if (!text.empty() && text.front() == '[') {
    const auto close = text.find(']');
    if (close == std::string_view::npos || close + 1 >= text.size() || text[close + 1] != ':') {
      return std::nullopt;
    }
    host = text.substr(1, close - 1);
    port_text = text.substr(close + 2);
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string_view::npos) return std::nullopt;
    host = text.substr(0, colon);
    port_text = text.substr(colon + 1);
    if (host.find(':') != std::string_view::npos) return std::nullopt;
  }
  if (host.empty() || port_text.empty()) return std::nullopt;
  unsigned port = 0;
  const auto [end, ec] =
      std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (ec != std::errc{} || end != port_text.data() + port_text.size() || port == 0 ||
      port > 65535) {
    return std::nullopt;
  }
  return Endpoint{std::string(host), static_cast<std::uint16_t>(port)};
}

std::string_view to_string(Outcome outcome) noexcept {
  switch (outcome) {
    case Outcome::kReply:
      return "reply";
    case Outcome::kRefused:
      return "refused";
    case Outcome::kTimeout:
      return "timeout";
    case Outcome::kDisconnected:
      return "disconnected";
  }
  return "unknown";
}

protocol::FramedPoint framed(core::Frame frame, double x_m, double y_m, double z_m) {
  protocol::FramedPoint p;
  p.frame = frame;
  p.position_m = core::Vec3(x_m, y_m, z_m);
  return p;
}

struct Client::Impl {
  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> work{io.get_executor()};
  std::thread thread;

  // Shared with callers; guarded by mutex.
  std::mutex mutex;
  std::condition_variable changed;
  bool is_connected = false;
  std::deque<protocol::Envelope> replies;
  std::optional<protocol::Welcome> welcome;
  // Replies still owed to requests that are over (a retransmitted request gets one reply per frame
  // sent): request id -> how many more to drop when they arrive.
  std::unordered_map<std::uint32_t, int> stale;

  std::mutex handler_mutex;
  EventHandler event_handler;
  TelemetryHandler telemetry_handler;
  DisconnectHandler disconnect_handler;

  std::atomic<std::uint32_t> next_id{1};

  // record_headers(): guarded by `mutex`.
  bool recording_headers = false;
  std::vector<protocol::FrameHeader> headers;
  // I/O thread only: where the frame boundaries are in the received byte stream.
  std::array<std::uint8_t, protocol::kHeaderSize> track_header{};
  std::size_t track_filled = 0;
  std::size_t track_skip = 0;

  // Follows the frame boundaries of the received bytes and keeps each header while recording.
  void track_frames(std::span<const std::uint8_t> in) {
    while (!in.empty()) {
      if (track_skip > 0) {
        const std::size_t k = std::min(track_skip, in.size());
        track_skip -= k;
        in = in.subspan(k);
        continue;
      }
      const std::size_t k = std::min(protocol::kHeaderSize - track_filled, in.size());
      std::copy_n(in.begin(), k, track_header.begin() + static_cast<std::ptrdiff_t>(track_filled));
      track_filled += k;
      in = in.subspan(k);
      if (track_filled < protocol::kHeaderSize) return;
      track_filled = 0;
      const protocol::FrameHeader h = protocol::decode_header(track_header);
      // An oversize length loses the framing: the decoder closes the connection.
      track_skip = h.payload_length <= protocol::kMaxPayloadSize ? h.payload_length : 0;
      std::lock_guard lock(mutex);
      if (recording_headers && headers.size() < kMaxQueuedReplies) headers.push_back(h);
    }
  }

  // I/O thread only.
  std::shared_ptr<tcp::socket> socket;
  std::shared_ptr<TlsSocket> tls;  // over *socket when TLS is on
  std::shared_ptr<ssl::context> tls_context;
  std::array<std::uint8_t, 4096> read_buffer{};
  protocol::StreamDecoder decoder;
  std::deque<std::vector<std::uint8_t>> write_queue;
  bool writing = false;
  asio::steady_timer heartbeat_timer{io};
  Milliseconds heartbeat_interval{0};
  std::set<std::uint32_t> heartbeat_ids;

  static constexpr std::size_t kMaxQueuedReplies = 1024;
  static constexpr std::size_t kMaxStaleIds = 4096;

  // A request is over; `owed` more replies with its id may still arrive: drop them (and any
  // already queued). Caller holds `mutex`.
  void forget_request(std::uint32_t request_id, int owed) {
    std::erase_if(replies, [&](const protocol::Envelope& e) {
      if (e.request_id != request_id || owed <= 0) return false;
      --owed;
      return true;
    });
    if (owed <= 0) return;
    if (stale.size() >= kMaxStaleIds) stale.clear();
    stale[request_id] += owed;
  }

  void on_closed(const std::string& why) {
    if (!socket) return;
    boost::system::error_code ignored;
    if (tls && !writing) {  // close_notify, not waiting for the daemon's (non-blocking: no hang)
      socket->non_blocking(true, ignored);
      tls->shutdown(ignored);
    }
    socket->shutdown(tcp::socket::shutdown_both, ignored);
    socket->close(ignored);
    socket.reset();
    tls.reset();
    write_queue.clear();
    writing = false;
    heartbeat_ids.clear();
    {
      std::lock_guard lock(mutex);
      is_connected = false;
    }
    changed.notify_all();
    DisconnectHandler handler;
    {
      std::lock_guard lock(handler_mutex);
      handler = disconnect_handler;
    }
    if (handler && !why.empty()) handler(why);
  }

  void dispatch(protocol::Envelope&& envelope) {
    if (const auto* event = std::get_if<protocol::Event>(&envelope.message)) {
      EventHandler handler;
      {
        std::lock_guard lock(handler_mutex);
        handler = event_handler;
      }
      if (handler) handler(*event);
      return;
    }
    if (const auto* telemetry = std::get_if<protocol::Telemetry>(&envelope.message)) {
      TelemetryHandler handler;
      {
        std::lock_guard lock(handler_mutex);
        handler = telemetry_handler;
      }
      if (handler) handler(*telemetry);
      return;
    }
    if (envelope.request_id != 0 && heartbeat_ids.erase(envelope.request_id) > 0) return;
    {
      std::lock_guard lock(mutex);
      if (auto it = stale.find(envelope.request_id); it != stale.end()) {
        if (--it->second <= 0) stale.erase(it);
        return;  // a late duplicate of a reply already taken (or given up on)
      }
      replies.push_back(std::move(envelope));
      if (replies.size() > kMaxQueuedReplies) replies.pop_front();
    }
    changed.notify_all();
  }

  // Reads or writes through TLS when it is on.
  template <typename F>
  void with_stream(F&& f) {
    if (tls) {
      f(*tls);
    } else {
      f(*socket);
    }
  }

  void start_read(const std::shared_ptr<tcp::socket>& sock) {
    with_stream([&](auto& stream) {
      stream.async_read_some(
          asio::buffer(read_buffer),
          // keep_tls: the TLS stream outlives every operation on it, also when a read or write
          // failure closes the connection while the other operation is still in flight.
          [this, sock, keep_tls = tls](boost::system::error_code ec, std::size_t n) {
            (void)keep_tls;
            if (sock != socket) return;  // a stale connection
            if (ec) {
              std::string why = ec == asio::error::eof ? "connection closed by the daemon"
                                                       : "connection lost: " + ec.message();
              if (ec.category() == asio::error::get_ssl_category())
                why +=
                    " (the daemon ended the TLS session: is this client's certificate "
                    "accepted? see the daemon's log)";
              on_closed(why);
              return;
            }
            std::span<const std::uint8_t> in(read_buffer.data(), n);
            track_frames(in);
            while (!in.empty()) {
              protocol::StreamDecoder::Outcome outcome;
              const std::size_t used = decoder.feed(in, outcome);
              in = in.subspan(used);
              if (outcome.kind == protocol::StreamDecoder::Kind::kMessage) {
                dispatch(std::move(outcome.envelope));
              } else if (outcome.kind == protocol::StreamDecoder::Kind::kError) {
                if (outcome.error.framing_lost) {
                  on_closed("undecodable data from the daemon (" +
                            std::string(ajar::to_string(outcome.error.code)) + ")");
                  return;
                }
              } else if (used == 0) {
                break;
              }
            }
            start_read(sock);
          });
    });
  }

  void write(std::vector<std::uint8_t> bytes) {
    if (!socket) return;
    write_queue.push_back(std::move(bytes));
    if (!writing) start_write();
  }

  void start_write() {
    if (!socket || write_queue.empty()) {
      writing = false;
      return;
    }
    writing = true;
    auto sock = socket;
    with_stream([&](auto& stream) {
      asio::async_write(stream, asio::buffer(write_queue.front()),
                        [this, sock, keep_tls = tls](boost::system::error_code ec, std::size_t) {
                          (void)keep_tls;  // see start_read
                          if (sock != socket) return;
                          if (ec) {
                            on_closed("cannot send: " + ec.message());
                            return;
                          }
                          write_queue.pop_front();
                          start_write();
                        });
    });
  }

  void schedule_heartbeat() {
    if (heartbeat_interval.count() <= 0) return;
    heartbeat_timer.expires_after(heartbeat_interval);
    heartbeat_timer.async_wait([this](boost::system::error_code ec) {
      if (ec) return;
      if (socket) {
        protocol::Envelope envelope;
        envelope.request_id = next_id.fetch_add(1);
        protocol::Ping ping;
        ping.client_time_ns = static_cast<std::uint64_t>(
            std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
                .count());
        envelope.message = ping;
        if (heartbeat_ids.size() > 4096) heartbeat_ids.clear();
        heartbeat_ids.insert(envelope.request_id);
        std::vector<std::uint8_t> bytes;
        protocol::encode_append(envelope, bytes);
        write(std::move(bytes));
      }
      schedule_heartbeat();
    });
  }
};

namespace {
std::uint64_t random_instance_id() {
  std::random_device device;
  std::uint64_t id = (static_cast<std::uint64_t>(device()) << 32) ^ device();
  id ^= static_cast<std::uint64_t>(Clock::now().time_since_epoch().count());
  return id == 0 ? 1 : id;
}
}  // namespace

Client::Client(ClientOptions options)
    : options_(std::move(options)),
      instance_id_(options_.client_instance_id != 0 ? options_.client_instance_id
                                                    : random_instance_id()),
      impl_(std::make_unique<Impl>()) {
  impl_->thread = std::thread([impl = impl_.get()] { impl->io.run(); });
}

Client::~Client() {
  {
    std::lock_guard lock(impl_->handler_mutex);
    impl_->event_handler = nullptr;
    impl_->telemetry_handler = nullptr;
    impl_->disconnect_handler = nullptr;
  }
  asio::post(impl_->io, [impl = impl_.get()] {
    impl->heartbeat_timer.cancel();
    impl->on_closed("");
    impl->io.stop();
  });
  impl_->work.reset();
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::string Client::connect(const Endpoint& endpoint) {
  return connect(endpoint, options_.connect_timeout);
}

std::string Client::connect(const Endpoint& endpoint, Milliseconds timeout) {
  std::shared_ptr<ssl::context> tls_context;
  if (options_.tls.enabled()) {
    if (auto e = make_tls_context(options_.tls, tls_context); !e.empty()) return e;
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
    return "timed out connecting to " + endpoint.host + ":" + std::to_string(endpoint.port);
  }
  return future.get();
}

void Client::close() {
  auto promise = std::make_shared<std::promise<void>>();
  auto future = promise->get_future();
  asio::post(impl_->io, [impl = impl_.get(), promise] {
    impl->on_closed("");
    promise->set_value();
  });
  future.wait();
}

bool Client::connected() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->is_connected;
}

Response Client::hello(protocol::Role role, bool take_over) {
  protocol::Hello hello;
  hello.requested_role = role;
  hello.take_over = take_over;
  hello.client_instance_id = instance_id_;
  hello.client_name.assign(options_.client_name);
  Response response = request(hello);
  if (const auto* welcome = response.get<protocol::Welcome>()) {
    std::lock_guard lock(impl_->mutex);
    impl_->welcome = *welcome;
  }
  return response;
}

std::optional<protocol::Welcome> Client::welcome() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->welcome;
}

Response Client::request(const protocol::Message& message, Milliseconds timeout) {
  return request(message, timeout, options_.retries);
}

Response Client::request(const protocol::Message& message, Milliseconds timeout, int retries) {
  if (timeout.count() <= 0) timeout = options_.request_timeout;
  Response response;
  protocol::Envelope envelope;
  envelope.request_id = next_request_id();
  envelope.message = message;
  response.request_id = envelope.request_id;
  if (std::vector<std::uint8_t> probe; !protocol::encode_append(envelope, probe)) {
    // Nothing can be sent (e.g. a MeasureDoorPlane count outside 3..16): refuse here, as the
    // daemon would, rather than send nothing and report a timeout.
    const bool plane = std::holds_alternative<protocol::MeasureDoorPlane>(message);
    response.outcome = Outcome::kRefused;
    response.error.code = plane ? ErrorCode::kBadCount : ErrorCode::kInternal;
    response.error.offending_type = protocol::type_of(message);
    response.error.field.assign(plane ? "count" : "");
    response.error.message.assign(
        std::string("not sent: the client cannot encode this ") +
        std::string(protocol::to_string(protocol::type_of(message))) +
        (plane ? " (count must be 3..16, got " +
                     std::to_string(std::get<protocol::MeasureDoorPlane>(message).count) + ")"
               : " request"));
    response.reply = response.error;
    return response;
  }
  for (int attempt = 0; attempt <= std::max(0, retries); ++attempt) {
    envelope.flags = attempt == 0 ? protocol::kFlagNone : protocol::kFlagRetransmit;
    if (!send_envelope(envelope)) {
      response.outcome = Outcome::kDisconnected;
      response.transport_error = "not connected";
      return response;
    }
    ++response.attempts;
    const auto sent = Clock::now();
    auto reply = wait_reply(envelope.request_id, timeout);
    if (reply) {
      if (response.attempts > 1) {  // each earlier attempt may still be answered
        std::lock_guard lock(impl_->mutex);
        impl_->forget_request(envelope.request_id, response.attempts - 1);
      }
      response.round_trip = std::chrono::duration_cast<Milliseconds>(Clock::now() - sent);
      response.reply = std::move(reply->message);
      if (const auto* error = std::get_if<protocol::ErrorReply>(&response.reply)) {
        response.outcome = Outcome::kRefused;
        response.error = *error;
      } else {
        response.outcome = Outcome::kReply;
      }
      return response;
    }
    if (!connected()) {
      response.outcome = Outcome::kDisconnected;
      response.transport_error = "connection lost while waiting for the reply";
      return response;
    }
  }
  {  // every attempt may still be answered later
    std::lock_guard lock(impl_->mutex);
    impl_->forget_request(envelope.request_id, response.attempts);
  }
  response.outcome = Outcome::kTimeout;
  response.transport_error =
      "no reply to " + std::string(protocol::to_string(protocol::type_of(message))) + " within " +
      std::to_string(timeout.count()) + " ms (" + std::to_string(response.attempts) + " attempts)";
  return response;
}

void Client::set_heartbeat(Milliseconds interval) {
  asio::post(impl_->io, [impl = impl_.get(), interval] {
    impl->heartbeat_interval = interval;
    impl->heartbeat_timer.cancel();
    impl->schedule_heartbeat();
  });
}

void Client::on_event(EventHandler handler) {
  std::lock_guard lock(impl_->handler_mutex);
  impl_->event_handler = std::move(handler);
}
void Client::on_telemetry(TelemetryHandler handler) {
  std::lock_guard lock(impl_->handler_mutex);
  impl_->telemetry_handler = std::move(handler);
}
void Client::on_disconnect(DisconnectHandler handler) {
  std::lock_guard lock(impl_->handler_mutex);
  impl_->disconnect_handler = std::move(handler);
}

std::uint32_t Client::next_request_id() {
  std::uint32_t id = impl_->next_id.fetch_add(1);
  if (id == 0) id = impl_->next_id.fetch_add(1);
  return id;
}

bool Client::send_raw(std::span<const std::uint8_t> bytes) {
  if (!connected()) return false;
  asio::post(impl_->io, [impl = impl_.get(),
                         data = std::vector<std::uint8_t>(bytes.begin(), bytes.end())]() mutable {
    impl->write(std::move(data));
  });
  return true;
}

bool Client::send_envelope(const protocol::Envelope& envelope) {
  std::vector<std::uint8_t> bytes;
  if (!protocol::encode_append(envelope, bytes)) return false;
  return send_raw(bytes);
}

std::optional<protocol::Envelope> Client::wait_reply(std::optional<std::uint32_t> request_id,
                                                     Milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  std::unique_lock lock(impl_->mutex);
  std::optional<protocol::Envelope> found;
  impl_->changed.wait_until(lock, deadline, [&] {
    auto& replies = impl_->replies;
    for (auto it = replies.begin(); it != replies.end(); ++it) {
      if (!request_id || it->request_id == *request_id) {
        found = std::move(*it);
        replies.erase(it);
        return true;
      }
    }
    return !impl_->is_connected;
  });
  return found;
}

bool Client::wait_closed(Milliseconds timeout) {
  std::unique_lock lock(impl_->mutex);
  return impl_->changed.wait_for(lock, timeout, [&] { return !impl_->is_connected; });
}

void Client::discard_replies() {
  std::lock_guard lock(impl_->mutex);
  impl_->replies.clear();
}

void Client::record_headers(bool on) {
  std::lock_guard lock(impl_->mutex);
  impl_->recording_headers = on;
  if (on) impl_->headers.clear();
}

std::vector<protocol::FrameHeader> Client::recorded_headers() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->headers;
}

}  // namespace ajar::client
