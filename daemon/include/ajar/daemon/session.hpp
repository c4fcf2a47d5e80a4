// Session: one client connection's byte I/O, independent of the stream type (a plain TCP socket,
// or after the server's TLS handshake Session<ssl::stream<tcp::socket>>, see tls.hpp). It decodes
// frames with the protocol's StreamDecoder and hands messages and decode errors to a
// SessionHandler (the SessionHub: roles, requests, fan-out); it knows nothing about the protocol's
// session rules.
//
// Guarantees (docs/operations.md):
// - Send queue bounded by `send_queue_frames` (queued + being written): a client that stops
//   reading is dropped when it overflows, never buffered without bound.
// - Each queued frame leaves in one gather-write (async_write of a buffer sequence; several frames
//   that queued up meanwhile go out together).
// - Read deadline: once the first byte of a frame arrived, the frame must be complete within
//   `read_deadline`, else an ERROR BAD_PAYLOAD_LENGTH (field "read_deadline_s", saying how many
//   bytes arrived) is sent and the session is closed gracefully. Optional idle timeout (0 = none).
// - refuse(): a connection refused by the server still has its first frames read for a short
//   window and handed to the handler (a refused peer's EmergencyStop is executed), then closes.
// - close_after_flush(): stops handling input, writes what is queued, half-closes (FIN), waits for
//   the peer's close for at most `linger`, then closes.
// - SessionHandler::on_closed() is called exactly once, always from a posted handler (never from
//   inside send()/abort()), so a handler may iterate over its sessions and send to them.
//
// Threading: every member is called on the stream's executor (the single I/O thread).
#pragma once

#include <utility>  // before Asio (asio issue 944)

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>

#include "ajar/protocol/codec.hpp"

namespace ajar::daemon {

// An encoded frame, shared between the sessions it is sent to (an event is encoded once per
// protocol minor version in use). `minor`: the layout of protocol 1.minor (the session's).
using SharedFrame = std::shared_ptr<const std::vector<std::uint8_t>>;
SharedFrame encode_frame(const protocol::Envelope& envelope,
                         std::uint8_t minor = protocol::kVersionMinor);

// What the peer at the other end may do (docs/security.md). Plaintext sessions (loopback, or
// network.insecure_plaintext) get everything; TLS sessions what their certificate is granted.
struct PeerAccess {
  std::string identity = "plaintext";  // for logs and errors: "cn:alice (sha256:AB12...)"
  bool may_control = true;             // may ask for the controller role
  bool may_stop = true;                // may send Stop / EmergencyStop
};

// What the hub sees of a session.
class SessionLink {
 public:
  virtual const PeerAccess& access() const noexcept {
    static const PeerAccess plaintext;
    return plaintext;
  }
  virtual std::uint64_t id() const noexcept = 0;
  virtual const std::string& peer() const noexcept = 0;  // "127.0.0.1:40312"
  // Queues a frame. False when the session is closing/closed or the queue overflowed (the session
  // is then being dropped).
  virtual bool send(SharedFrame frame) = 0;
  virtual void close_after_flush(std::string_view reason) = 0;
  virtual void abort(std::string_view reason) = 0;

 protected:
  ~SessionLink() = default;
};

class SessionHandler {
 public:
  virtual void on_open(SessionLink& link) = 0;
  virtual void on_message(SessionLink& link, const protocol::Envelope& envelope) = 0;
  virtual void on_decode_error(SessionLink& link, const protocol::DecodeError& error) = 0;
  virtual void on_closed(SessionLink& link, std::string_view reason) = 0;
  // Around the frames decoded from one read (several frames can arrive in one TCP segment).
  virtual void on_read_begin(SessionLink& link) { (void)link; }
  virtual void on_read_end(SessionLink& link) { (void)link; }
  // The protocol minor of the frames the session writes itself (the read deadline's Error): the
  // minor its Hello settled (docs/protocol.md 7.1), ours before.
  virtual std::uint8_t frame_minor(const SessionLink& link) const {
    (void)link;
    return protocol::kVersionMinor;
  }

 protected:
  ~SessionHandler() = default;
};

struct SessionOptions {
  std::size_t send_queue_frames = 512;
  std::chrono::steady_clock::duration read_deadline = std::chrono::seconds(10);
  std::chrono::steady_clock::duration idle_timeout{0};  // 0 = none
  std::chrono::steady_clock::duration linger = std::chrono::seconds(2);
  // The black box (docs/blackbox.md): every frame as on the wire, with the session's id and its
  // direction (0 received, once its last byte is in; 1 sent, when queued). `sent` is the frame
  // itself when it was sent (shared: the tap may keep a reference, e.g. one Telemetry frame sent
  // to 256 observers, rather than copy it), null when received. Empty: none.
  std::function<void(std::uint64_t session_id, std::uint8_t direction,
                     std::span<const std::uint8_t> frame, const SharedFrame& sent)>
      frame_tap;
};

// Sessions per stream type. Stream: an AsyncReadStream + AsyncWriteStream with lowest_layer()
// (tcp::socket, ssl::stream<tcp::socket>).
template <typename Stream>
class Session final : public SessionLink, public std::enable_shared_from_this<Session<Stream>> {
 public:
  // `handler` null: a refused connection (see refuse()), not registered anywhere.
  Session(Stream stream, std::uint64_t id, std::string peer, SessionHandler* handler,
          SessionOptions options, PeerAccess access = {})
      : stream_(std::move(stream)),
        timer_(stream_.get_executor()),
        id_(id),
        peer_(std::move(peer)),
        handler_(handler),
        options_(options),
        access_(std::move(access)) {}

  void start() {
    last_read_ = Clock::now();
    if (handler_ != nullptr) handler_->on_open(*this);
    read_more();
    arm_timer();
  }

  // Sends one frame (e.g. ErrorReply TOO_MANY_CLIENTS), keeps reading for `read_window` (the
  // handler sees what arrives; start() is not called, so no on_open()), then closes gracefully.
  void refuse(SharedFrame frame, std::string_view reason,
              std::chrono::steady_clock::duration read_window) {
    refusal_reason_ = reason;
    refuse_at_ = Clock::now() + read_window;
    last_read_ = Clock::now();
    send(std::move(frame));
    read_more();
    arm_timer();
  }

  std::uint64_t id() const noexcept override { return id_; }
  const std::string& peer() const noexcept override { return peer_; }
  const PeerAccess& access() const noexcept override { return access_; }

  bool send(SharedFrame frame) override {
    if (state_ != State::kOpen) return false;
    if (queue_.size() + in_flight_.size() >= options_.send_queue_frames) {
      close_now("send queue full (" + std::to_string(options_.send_queue_frames) +
                " frames): client not reading");
      return false;
    }
    if (options_.frame_tap) options_.frame_tap(id_, 1, *frame, frame);
    queue_.push_back(std::move(frame));
    if (!writing_) write_more();
    return true;
  }

  void close_after_flush(std::string_view reason) override {
    if (state_ != State::kOpen) return;
    state_ = State::kClosing;
    close_reason_ = reason;
    closing_since_ = Clock::now();
    if (!writing_) half_close();
    arm_timer();
  }

  void abort(std::string_view reason) override { close_now(std::string(reason)); }

 private:
  using Clock = std::chrono::steady_clock;
  enum class State { kOpen, kClosing, kClosed };
  static constexpr std::size_t kMaxGather = 64;

  void read_more() {
    if (reading_ || state_ == State::kClosed) return;
    reading_ = true;
    const std::span<std::uint8_t> space = read_space();
    stream_.async_read_some(
        boost::asio::buffer(space.data(), space.size()),
        [self = this->shared_from_this()](const boost::system::error_code& ec, std::size_t n) {
          self->reading_ = false;
          self->on_read(ec, n);
        });
  }

  void on_read(const boost::system::error_code& ec, std::size_t n) {
    if (state_ == State::kClosed) return;
    if (ec) {
      if (state_ == State::kClosing) {
        close_now(close_reason_);
      } else {
        close_now(ec == boost::asio::error::eof ? std::string("closed by peer")
                                                : "read failed: " + ec.message());
      }
      return;
    }
    last_read_ = Clock::now();
    if (state_ == State::kOpen) {
      if (handler_ != nullptr) handler_->on_read_begin(*this);
      process(std::span<const std::uint8_t>(read_space().data(), n));
      if (handler_ != nullptr) handler_->on_read_end(*this);
    }
    if (!large_read_ && n == small_read_.size())  // a bulk sender: larger reads from now on
      large_read_ = std::make_unique<std::array<std::uint8_t, kLargeReadBytes>>();
    if (state_ == State::kClosed) return;
    read_more();  // also while closing: discard input until the peer closes (graceful close)
    arm_timer();
  }

  void process(std::span<const std::uint8_t> in) {
    while (!in.empty() && state_ == State::kOpen) {
      const std::size_t used = decoder_.feed(in, outcome());
      if (options_.frame_tap) {
        const auto part = in.first(used);
        tap_bytes_.insert(tap_bytes_.end(), part.begin(), part.end());
      }
      in = in.subspan(used);
      if (options_.frame_tap && outcome().kind != protocol::StreamDecoder::Kind::kNeedMore) {
        options_.frame_tap(id_, 0, tap_bytes_, nullptr);
        tap_bytes_.clear();
      }
      switch (outcome().kind) {
        case protocol::StreamDecoder::Kind::kNeedMore:
          if (used == 0) return;
          if (partial_bytes_ == 0) frame_started_ = Clock::now();
          partial_bytes_ += used;
          break;
        case protocol::StreamDecoder::Kind::kMessage:
          partial_bytes_ = 0;
          if (handler_ != nullptr) handler_->on_message(*this, outcome().envelope);
          break;
        case protocol::StreamDecoder::Kind::kError:
          partial_bytes_ = 0;
          if (handler_ != nullptr) handler_->on_decode_error(*this, outcome().error);
          if (outcome().error.framing_lost) close_after_flush("framing lost");
          break;
      }
    }
  }

  void write_more() {
    std::vector<boost::asio::const_buffer> buffers;
    while (!queue_.empty() && in_flight_.size() < kMaxGather) {
      in_flight_.push_back(std::move(queue_.front()));
      queue_.pop_front();
      buffers.emplace_back(in_flight_.back()->data(), in_flight_.back()->size());
    }
    writing_ = true;
    boost::asio::async_write(
        stream_, buffers,
        [self = this->shared_from_this()](const boost::system::error_code& ec, std::size_t) {
          self->on_written(ec);
        });
  }

  void on_written(const boost::system::error_code& ec) {
    writing_ = false;
    in_flight_.clear();
    if (state_ == State::kClosed) return;
    if (ec) {
      close_now("write failed: " + ec.message());
      return;
    }
    if (!queue_.empty()) {
      write_more();
    } else if (state_ == State::kClosing) {
      half_close();
    }
  }

  // Everything queued is written: send FIN (a TLS stream sends close_notify first, tls.hpp), keep
  // reading until the peer closes (or linger ends).
  void half_close() {
    if (!queue_.empty()) {
      write_more();
      return;
    }
    if constexpr (requires { stream_.close_notify(); }) stream_.close_notify();
    boost::system::error_code ignored;
    stream_.lowest_layer().shutdown(boost::asio::socket_base::shutdown_send, ignored);
  }

  void arm_timer() {
    if (state_ == State::kClosed) return;
    Clock::time_point deadline = Clock::time_point::max();
    if (state_ == State::kClosing) {
      deadline = closing_since_ + options_.linger;
    } else if (partial_bytes_ > 0) {
      deadline = frame_started_ + options_.read_deadline;
    } else if (options_.idle_timeout > Clock::duration::zero()) {
      deadline = last_read_ + options_.idle_timeout;
    }
    if (state_ == State::kOpen) deadline = std::min(deadline, refuse_at_);
    if (deadline == timer_deadline_) return;
    timer_deadline_ = deadline;
    timer_.expires_at(deadline);  // cancels a pending wait
    if (deadline == Clock::time_point::max()) return;
    timer_.async_wait([self = this->shared_from_this()](const boost::system::error_code& ec) {
      self->on_timer(ec);
    });
  }

  void on_timer(const boost::system::error_code& ec) {
    if (ec || state_ == State::kClosed || Clock::now() < timer_deadline_) return;
    if (state_ == State::kClosing) {
      close_now(close_reason_);
    } else if (Clock::now() >= refuse_at_) {
      close_after_flush(refusal_reason_);
    } else if (partial_bytes_ > 0) {
      const std::string what = "read deadline: a frame stayed incomplete for " +
                               std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(
                                                  options_.read_deadline)
                                                  .count()) +
                               " ms (network.read_deadline_s), " + std::to_string(partial_bytes_) +
                               " bytes received; closing";
      protocol::ErrorReply error;
      error.code = ErrorCode::kBadPayloadLength;
      error.field = "read_deadline_s";
      error.message.assign(what);
      const std::uint8_t minor =
          handler_ != nullptr ? handler_->frame_minor(*this) : protocol::kVersionMinor;
      if (auto frame = encode_frame(protocol::Envelope{0, 0, error}, minor)) send(std::move(frame));
      close_after_flush(what);
    } else {
      close_now("idle timeout");
    }
  }

  void close_now(std::string reason) {
    if (state_ == State::kClosed) return;
    state_ = State::kClosed;
    boost::system::error_code ignored;
    stream_.lowest_layer().shutdown(boost::asio::socket_base::shutdown_both, ignored);
    stream_.lowest_layer().close(ignored);
    timer_.cancel();
    queue_.clear();
    boost::asio::post(stream_.get_executor(),
                      [self = this->shared_from_this(), why = std::move(reason)] {
                        if (self->handler_ != nullptr) self->handler_->on_closed(*self, why);
                      });
  }

  Stream stream_;
  boost::asio::steady_timer timer_;
  std::uint64_t id_;
  std::string peer_;
  SessionHandler* handler_;
  SessionOptions options_;
  std::vector<std::uint8_t> tap_bytes_;  // the frame being received (options_.frame_tap only)
  PeerAccess access_;

  State state_ = State::kOpen;
  std::string close_reason_;
  std::string refusal_reason_;
  Clock::time_point refuse_at_ = Clock::time_point::max();
  bool reading_ = false;
  bool writing_ = false;
  // Reads go into a small inline buffer; a session whose read once filled it (a peer sending in
  // bulk) reads into kLargeReadBytes from then on. Most sessions (observers: a Hello, a Subscribe,
  // a Ping now and then) never need more: 257 sessions keep ~1 MiB less resident than with a
  // 4 KiB buffer each (docs/performance.md, "Footprint"). Not zeroed: only [0, n) of a read is
  // used.
  static constexpr std::size_t kSmallReadBytes = 256;
  static constexpr std::size_t kLargeReadBytes = 4096;
  std::span<std::uint8_t> read_space() {
    if (large_read_) return {large_read_->data(), large_read_->size()};
    return {small_read_.data(), small_read_.size()};
  }
  std::array<std::uint8_t, kSmallReadBytes> small_read_;
  std::unique_ptr<std::array<std::uint8_t, kLargeReadBytes>> large_read_;
  protocol::StreamDecoder decoder_;
  // The outcome of the last feed(): one per thread, shared by the sessions it serves (~1 KiB, a
  // whole decoded Message; one per session was 0.26 MiB for 257 sessions). process() hands it to
  // the handler and is done with it before any other session's read is processed on this thread.
  static protocol::StreamDecoder::Outcome& outcome() noexcept {
    thread_local protocol::StreamDecoder::Outcome shared;
    return shared;
  }
  std::size_t partial_bytes_ = 0;
  Clock::time_point frame_started_{};
  Clock::time_point last_read_{};
  Clock::time_point closing_since_{};
  Clock::time_point timer_deadline_ = Clock::time_point::max();
  std::deque<SharedFrame> queue_;
  std::vector<SharedFrame> in_flight_;
};

using TcpSession = Session<boost::asio::ip::tcp::socket>;

}  // namespace ajar::daemon
