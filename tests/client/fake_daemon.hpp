// A fake ajard for the client tests: Asio on 127.0.0.1 port 0, one I/O thread, every decoded frame
// recorded (with the connection it came on) and answered by a handler. It speaks the real protocol
// (protocol::encode / StreamDecoder) and claims whatever the handler says (e.g. real drivers).
#pragma once

#include <utility>  // before Asio

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include <boost/asio.hpp>
#include <gtest/gtest.h>

#include "ajar/client/client.hpp"
#include "ajar/protocol/codec.hpp"

namespace ajar::client::fake {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using protocol::MessageType;

class FakeDaemon {
 public:
  using Handler = std::function<std::vector<protocol::Envelope>(const protocol::Envelope&)>;

  explicit FakeDaemon(Handler handler)
      : handler_(std::move(handler)),
        acceptor_(io_, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0)) {
    port_ = acceptor_.local_endpoint().port();
    accept();
    thread_ = std::thread([this] { io_.run(); });
  }
  ~FakeDaemon() {
    asio::post(io_, [this] {
      boost::system::error_code ignored;
      acceptor_.close(ignored);
      for (auto& c : connections_)
        c->socket.close(ignored);
      io_.stop();
    });
    thread_.join();
  }

  std::uint16_t port() const { return port_; }
  Endpoint endpoint() const { return Endpoint{"127.0.0.1", port_}; }

  std::vector<protocol::Envelope> received() const {
    std::lock_guard lock(mutex_);
    return received_;
  }
  // The connection (numbered from 0 in accept order) each received frame came on.
  std::vector<std::size_t> received_on() const {
    std::lock_guard lock(mutex_);
    return received_on_;
  }
  std::size_t count(MessageType type) const {
    std::size_t n = 0;
    for (const auto& e : received())
      if (protocol::type_of(e.message) == type) ++n;
    return n;
  }
  // Waits (bounded) until `pred(received())` holds.
  bool wait_for(const std::function<bool(const std::vector<protocol::Envelope>&)>& pred) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, std::chrono::seconds(10), [&] { return pred(received_); });
  }
  // Sends a frame to every connection.
  void push(const protocol::Envelope& e) {
    asio::post(io_, [this, e] {
      for (auto& c : connections_)
        write(*c, {e});
    });
  }
  void close_all() {
    asio::post(io_, [this] {
      boost::system::error_code ignored;
      for (auto& c : connections_)
        c->socket.close(ignored);
      connections_.clear();
    });
  }

 private:
  struct Connection {
    Connection(tcp::socket s, std::size_t n) : socket(std::move(s)), number(n) {}
    tcp::socket socket;
    std::size_t number;
    protocol::StreamDecoder decoder;
    std::array<std::uint8_t, 4096> buffer{};
  };

  void accept() {
    acceptor_.async_accept([this](boost::system::error_code ec, tcp::socket socket) {
      if (ec) return;
      auto c = std::make_shared<Connection>(std::move(socket), accepted_++);
      connections_.push_back(c);
      read(c);
      accept();
    });
  }

  void read(const std::shared_ptr<Connection>& c) {
    c->socket.async_read_some(asio::buffer(c->buffer),
                              [this, c](boost::system::error_code ec, std::size_t n) {
                                if (ec) return;
                                std::span<const std::uint8_t> in(c->buffer.data(), n);
                                while (!in.empty()) {
                                  protocol::StreamDecoder::Outcome out;
                                  in = in.subspan(c->decoder.feed(in, out));
                                  if (out.kind != protocol::StreamDecoder::Kind::kMessage) continue;
                                  {
                                    std::lock_guard lock(mutex_);
                                    received_.push_back(out.envelope);
                                    received_on_.push_back(c->number);
                                  }
                                  changed_.notify_all();
                                  write(*c, handler_(out.envelope));
                                }
                                read(c);
                              });
  }

  static void write(Connection& c, const std::vector<protocol::Envelope>& frames) {
    std::vector<std::uint8_t> bytes;
    for (const auto& f : frames)
      ASSERT_TRUE(protocol::encode_append(f, bytes));
    boost::system::error_code ignored;
    if (!bytes.empty()) asio::write(c.socket, asio::buffer(bytes), ignored);
  }

  Handler handler_;
  asio::io_context io_;
  tcp::acceptor acceptor_;
  std::uint16_t port_ = 0;
  std::vector<std::shared_ptr<Connection>> connections_;
  std::thread thread_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<protocol::Envelope> received_;
  std::vector<std::size_t> received_on_;
  std::size_t accepted_ = 0;  // I/O thread only
};

// A well-behaved daemon: Welcome, Pong, Status, Ack.
inline std::vector<protocol::Envelope> polite(const protocol::Envelope& e) {
  const auto type = protocol::type_of(e.message);
  switch (type) {
    case protocol::MessageType::kHello: {
      protocol::Welcome w;
      w.granted_role = std::get<protocol::Hello>(e.message).requested_role;
      w.deadman_timeout_s = 0.5f;
      return {{e.request_id, 0, w}};
    }
    case protocol::MessageType::kPing:
      return {
          {e.request_id, 0, protocol::Pong{std::get<protocol::Ping>(e.message).client_time_ns, 1}}};
    case protocol::MessageType::kGetStatus:
      return {{e.request_id, 0, protocol::Status{}}};
    case protocol::MessageType::kGetRobotModel:
      return {{e.request_id, 0, protocol::RobotModel{}}};
    default:
      break;
  }
  if (!protocol::is_request(type)) {  // a daemon -> host type sent to the daemon
    protocol::ErrorReply error;
    error.code = ErrorCode::kUnknownMessageType;
    error.offending_type = type;
    error.field = "header.type";
    return {{e.request_id, 0, error}};
  }
  protocol::AckBody body;  // the body the acknowledged type has, zeros
  if (type == MessageType::kMeasureDoorWidth || type == MessageType::kMeasureHandle) {
    body = protocol::SpanAck{};
  } else if (type == MessageType::kMeasureDoorPlane) {
    body = protocol::PlaneAck{};
  } else if (type == MessageType::kSetContactPoint) {
    body = protocol::ContactAck{};
  } else if (type == MessageType::kApproach) {
    body = protocol::ApproachAck{};
  }
  return {{e.request_id, 0, protocol::Ack{type, protocol::ProcedureState::kAwaitingWidth, body}}};
}

}  // namespace ajar::client::fake
