// A small synchronous test client: a blocking Asio socket and the protocol codec. Reads take a
// timeout (poll(2) before each read) so that a test never hangs on a silent daemon.
#pragma once

#include <utility>  // before Asio (asio issue 944)

#include <poll.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <ostream>
#include <span>
#include <string>
#include <vector>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <gtest/gtest.h>

#include "ajar/protocol/codec.hpp"

namespace ajar {
// Readable error codes in gtest failure messages.
inline void PrintTo(ErrorCode code, std::ostream* os) {
  *os << to_string(code);
}
}  // namespace ajar

namespace ajar::test {

using namespace std::chrono_literals;
namespace asio = boost::asio;

// Encodes a message as one frame.
inline std::vector<std::uint8_t> frame_of(const protocol::Message& message,
                                          std::uint32_t request_id, std::uint16_t flags = 0) {
  std::vector<std::uint8_t> bytes;
  const bool encoded =
      protocol::encode_append(protocol::Envelope{request_id, flags, message}, bytes);
  EXPECT_TRUE(encoded) << "test bug: cannot encode "
                       << protocol::to_string(protocol::type_of(message));
  return bytes;
}

// Recomputes the CRC of a frame after a test edited its header or payload.
inline void fix_crc(std::vector<std::uint8_t>& frame) {
  std::vector<std::uint8_t> covered(frame.begin(), frame.begin() + 18);
  covered.insert(covered.end(), frame.begin() + static_cast<long>(protocol::kHeaderSize),
                 frame.end());
  const std::uint32_t crc = protocol::crc32c(covered);
  for (int i = 0; i < 4; ++i)
    frame[static_cast<std::size_t>(18 + i)] = static_cast<std::uint8_t>(crc >> (8 * i));
}

inline void put_u16(std::vector<std::uint8_t>& bytes, std::size_t at, std::uint16_t v) {
  bytes[at] = static_cast<std::uint8_t>(v);
  bytes[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
inline void put_u32(std::vector<std::uint8_t>& bytes, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i)
    bytes[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

inline protocol::Hello hello_as(protocol::Role role, std::uint64_t client_instance_id = 0,
                                bool take_over = false, std::string_view name = "test") {
  protocol::Hello hello;
  hello.requested_role = role;
  hello.client_instance_id = client_instance_id;
  hello.take_over = take_over;
  hello.client_name = name;
  return hello;
}

class TestClient {
 public:
  explicit TestClient(std::uint16_t port, std::optional<int> receive_buffer_bytes = std::nullopt)
      : socket_(io_) {
    socket_.open(asio::ip::tcp::v4());
    if (receive_buffer_bytes)
      socket_.set_option(asio::socket_base::receive_buffer_size(*receive_buffer_bytes));
    socket_.connect(asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    socket_.set_option(asio::ip::tcp::no_delay(true));
  }

  std::uint32_t next_id() { return ++last_request_id_; }

  // Sends a request; returns its request id (fresh unless given).
  std::uint32_t send(const protocol::Message& message, std::uint32_t request_id = 0,
                     std::uint16_t flags = 0) {
    if (request_id == 0) request_id = next_id();
    send_raw(frame_of(message, request_id, flags));
    return request_id;
  }

  // False when the daemon closed the connection (EPIPE/ECONNRESET).
  bool send_raw(std::span<const std::uint8_t> bytes) {
    boost::system::error_code ec;
    asio::write(socket_, asio::buffer(bytes.data(), bytes.size()), ec);
    return !ec;
  }

  // The next decoded outcome (message or decode error), or nullopt on timeout or close
  // (closed() tells which).
  std::optional<protocol::StreamDecoder::Outcome> next(std::chrono::milliseconds timeout = 20s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    protocol::StreamDecoder::Outcome outcome;
    for (;;) {
      while (offset_ < pending_.size()) {
        const std::size_t used = decoder_.feed(
            std::span<const std::uint8_t>(pending_.data() + offset_, pending_.size() - offset_),
            outcome);
        offset_ += used;
        if (outcome.kind != protocol::StreamDecoder::Kind::kNeedMore) return outcome;
        if (used == 0) break;
      }
      pending_.clear();
      offset_ = 0;
      if (closed_) return std::nullopt;
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      pollfd p{socket_.native_handle(), POLLIN, 0};
      const int ready = ::poll(&p, 1, static_cast<int>(left.count()));
      if (ready <= 0) continue;
      std::array<std::uint8_t, 8192> buffer{};
      boost::system::error_code ec;
      const std::size_t n = socket_.read_some(asio::buffer(buffer), ec);
      if (ec) {
        closed_ = true;
        continue;
      }
      pending_.assign(buffer.begin(), buffer.begin() + static_cast<long>(n));
    }
  }

  // The next message that is a reply to `request_id`; events and telemetry on the way are kept
  // (events(), telemetry_count()). Fails the test on timeout or close.
  protocol::Message reply_to(std::uint32_t request_id, std::chrono::milliseconds timeout = 20s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      auto outcome = next(std::max(left, 1ms));
      if (!outcome) {
        ADD_FAILURE() << "no reply to request " << request_id
                      << (closed_ ? " (connection closed)" : " (timeout)");
        return protocol::ErrorReply{};
      }
      if (outcome->kind != protocol::StreamDecoder::Kind::kMessage) {
        ADD_FAILURE() << "undecodable frame from the daemon: " << to_string(outcome->error.code);
        continue;
      }
      if (keep(outcome->envelope)) continue;
      if (outcome->envelope.request_id == request_id) return outcome->envelope.message;
    }
  }

  protocol::Message request(const protocol::Message& message, std::uint32_t request_id = 0,
                            std::uint16_t flags = 0) {
    return reply_to(send(message, request_id, flags));
  }

  template <typename T>
  T request_as(const protocol::Message& message, std::uint32_t request_id = 0,
               std::uint16_t flags = 0) {
    auto reply = request(message, request_id, flags);
    if (!std::holds_alternative<T>(reply)) {
      ADD_FAILURE() << "reply to " << protocol::to_string(protocol::type_of(message)) << " is "
                    << protocol::to_string(protocol::type_of(reply)) << describe(reply);
      return T{};
    }
    return std::get<T>(reply);
  }

  protocol::Welcome hello(protocol::Role role, std::uint64_t client_instance_id = 0,
                          bool take_over = false) {
    return request_as<protocol::Welcome>(hello_as(role, client_instance_id, take_over));
  }

  // Waits for an event of `kind` (already received ones count). Returns it or nullopt on timeout.
  std::optional<protocol::Event> wait_event(
      protocol::EventKind kind, std::chrono::milliseconds timeout = 20s,
      std::optional<protocol::ProcedureState> state = std::nullopt) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      for (std::size_t i = 0; i < events_.size(); ++i) {
        if (events_[i].kind == kind && (!state || events_[i].state == *state)) {
          auto e = events_[i];
          events_.erase(events_.begin() + static_cast<long>(i));
          return e;
        }
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      auto outcome = next(left);
      if (!outcome) return std::nullopt;
      if (outcome->kind == protocol::StreamDecoder::Kind::kMessage) keep(outcome->envelope);
    }
  }

  // Reads until `count` telemetry frames arrived in total; false on timeout.
  bool wait_telemetry(std::size_t count, std::chrono::milliseconds timeout = 20s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (telemetry_count_ < count) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return false;
      auto outcome = next(left);
      if (!outcome) return false;
      if (outcome->kind == protocol::StreamDecoder::Kind::kMessage) keep(outcome->envelope);
    }
    return true;
  }

  // True when the daemon closes the connection within `timeout` (frames on the way are kept).
  bool wait_closed(std::chrono::milliseconds timeout = 20s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!closed_) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return false;
      auto outcome = next(left);
      if (outcome && outcome->kind == protocol::StreamDecoder::Kind::kMessage) {
        if (!keep(outcome->envelope)) others_.push_back(outcome->envelope);
      }
    }
    return true;
  }

  void close() {
    boost::system::error_code ignored;
    socket_.shutdown(asio::socket_base::shutdown_both, ignored);
    socket_.close(ignored);
  }

  bool closed() const { return closed_; }
  std::vector<protocol::Event>& events() { return events_; }
  std::vector<protocol::Envelope>& others() { return others_; }
  std::size_t telemetry_count() const { return telemetry_count_; }
  const std::optional<protocol::Telemetry>& last_telemetry() const { return last_telemetry_; }
  asio::ip::tcp::socket& socket() { return socket_; }

  static std::string describe(const protocol::Message& m) {
    if (const auto* e = std::get_if<protocol::ErrorReply>(&m)) {
      return std::string(" ") + std::string(to_string(e->code)) + " field '" +
             std::string(e->field.view()) + "': " + std::string(e->message.view());
    }
    return {};
  }

 private:
  // Keeps events and telemetry; true when the envelope was one of them.
  bool keep(const protocol::Envelope& envelope) {
    if (const auto* event = std::get_if<protocol::Event>(&envelope.message)) {
      events_.push_back(*event);
      return true;
    }
    if (const auto* telemetry = std::get_if<protocol::Telemetry>(&envelope.message)) {
      ++telemetry_count_;
      last_telemetry_ = *telemetry;
      return true;
    }
    return false;
  }

  asio::io_context io_;
  asio::ip::tcp::socket socket_;
  protocol::StreamDecoder decoder_;
  std::vector<std::uint8_t> pending_;
  std::size_t offset_ = 0;
  bool closed_ = false;
  std::uint32_t last_request_id_ = 0;
  std::vector<protocol::Event> events_;
  std::vector<protocol::Envelope> others_;
  std::size_t telemetry_count_ = 0;
  std::optional<protocol::Telemetry> last_telemetry_;
};

// An ErrorReply's code, or kOk when `m` is not an ErrorReply.
inline ErrorCode error_code_of(const protocol::Message& m) {
  const auto* e = std::get_if<protocol::ErrorReply>(&m);
  return e == nullptr ? ErrorCode::kOk : e->code;
}

}  // namespace ajar::test
