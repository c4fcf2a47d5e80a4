// Client::Impl (private to ajar_client): the I/O thread's state and its work: reading and
// framing, handing replies to the waiting callers and events/telemetry to the callbacks, the
// write queue and the heartbeat. client.cpp is the callers' side, client_connect.cpp connects.
#pragma once

#include <utility>  // before Asio (asio issue 944 with GCC 12)

#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <set>
#include <thread>
#include <unordered_map>

#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>

#include "ajar/client/client.hpp"

namespace ajar::client {

namespace asio = boost::asio;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using TlsSocket = ssl::stream<tcp::socket&>;

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

  // One connection attempt on the I/O thread (client_connect.cpp).
  class Connecting;

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
    if (const auto handler = copy_of(disconnect_handler); handler && !why.empty()) handler(why);
  }

  // A callback, copied under handler_mutex: it runs without the lock (it may replace itself).
  template <typename Handler>
  Handler copy_of(const Handler& handler) {
    std::lock_guard lock(handler_mutex);
    return handler;
  }

  void dispatch(protocol::Envelope&& envelope) {
    if (const auto* event = std::get_if<protocol::Event>(&envelope.message)) {
      if (const auto handler = copy_of(event_handler)) handler(*event);
      return;
    }
    if (const auto* telemetry = std::get_if<protocol::Telemetry>(&envelope.message)) {
      if (const auto handler = copy_of(telemetry_handler)) handler(*telemetry);
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

}  // namespace ajar::client
