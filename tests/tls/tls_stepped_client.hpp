// A TLS 1.3 client that a test drives one step at a time, to withhold any flight of the handshake
// (issue 22): OpenSSL on memory BIOs over a blocking socket the test owns. Steps: connect,
// ClientHello, read the daemon's flight (the client's handshake is then done on its side and its
// second flight is ready, not sent), the second flight one TLS record at a time (in TLS 1.3 with
// middlebox compatibility: ChangeCipherSpec, Certificate, CertificateVerify, Finished), then
// protocol frames through the TLS session. Every read has a deadline; failure() says why a step
// failed (an alert from the daemon: "sslv3 alert certificate revoked", a close...).
#pragma once

#include <utility>  // before Asio (asio issue 944)

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "test_client.hpp"

namespace ajar::test {

class SteppedTlsClient {
 public:
  SteppedTlsClient(std::uint16_t port, const std::string& ca, const std::string& certificate,
                   const std::string& private_key)
      : port_(port) {
    ctx_ = SSL_CTX_new(TLS_client_method());
    SSL_CTX_set_min_proto_version(ctx_, TLS1_3_VERSION);
    SSL_CTX_set_verify(ctx_, SSL_VERIFY_PEER, nullptr);
    if (SSL_CTX_load_verify_locations(ctx_, ca.c_str(), nullptr) != 1 ||
        SSL_CTX_use_certificate_chain_file(ctx_, certificate.c_str()) != 1 ||
        SSL_CTX_use_PrivateKey_file(ctx_, private_key.c_str(), SSL_FILETYPE_PEM) != 1) {
      fail("client setup");
      return;
    }
    ssl_ = SSL_new(ctx_);
    BIO* in = BIO_new(BIO_s_mem());
    BIO* out = BIO_new(BIO_s_mem());
    SSL_set_bio(ssl_, in, out);  // ssl_ owns both
    in_ = in;
    out_ = out;
    SSL_set_connect_state(ssl_);
    SSL_set1_host(ssl_, "localhost");

    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd_ < 0 || ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      failure_ = "cannot connect";
      return;
    }
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    sockaddr_in local{};
    socklen_t length = sizeof local;
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&local), &length);
    local_port_ = ntohs(local.sin_port);
  }
  ~SteppedTlsClient() {
    if (fd_ >= 0) ::close(fd_);
    if (ssl_ != nullptr) SSL_free(ssl_);
    if (ctx_ != nullptr) SSL_CTX_free(ctx_);
  }
  SteppedTlsClient(const SteppedTlsClient&) = delete;
  SteppedTlsClient& operator=(const SteppedTlsClient&) = delete;

  bool ok() const { return failure_.empty(); }
  const std::string& failure() const { return failure_; }

  // Step: the ClientHello.
  bool send_client_hello() {
    if (!ok()) return false;
    const int r = SSL_do_handshake(ssl_);
    if (r != -1 || SSL_get_error(ssl_, r) != SSL_ERROR_WANT_READ) return fail("ClientHello");
    return send_bytes(drain());
  }

  // Step: reads the daemon's flight until the handshake is done on the client's side; the
  // client's second flight is then split into records(), not sent.
  bool read_daemon_flight(std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    if (!ok()) return false;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const int r = SSL_do_handshake(ssl_);
      if (r == 1) break;
      if (SSL_get_error(ssl_, r) != SSL_ERROR_WANT_READ) return fail("the daemon's flight");
      if (const auto early = drain(); !early.empty() && !send_bytes(early)) return false;
      if (!receive(deadline)) return false;
    }
    const std::vector<std::uint8_t> flight = drain();
    for (std::size_t at = 0; at + 5 <= flight.size();) {
      const std::size_t length = (std::size_t{flight[at + 3]} << 8) | flight[at + 4];
      const std::size_t end = std::min(flight.size(), at + 5 + length);
      records_.emplace_back(flight.begin() + static_cast<long>(at),
                            flight.begin() + static_cast<long>(end));
      at = end;
    }
    return true;
  }

  // The client's second flight, record by record, not yet sent (after read_daemon_flight()).
  std::size_t records_left() const { return records_.size(); }
  // Step: sends the next record of the second flight.
  bool send_next_record() {
    if (!ok() || records_.empty()) return false;
    const auto record = std::move(records_.front());
    records_.pop_front();
    return send_bytes(record);
  }

  // Step: a protocol frame through the TLS session (the second flight must have been sent).
  // False when the daemon has closed the connection (next() still reads what it sent before).
  bool send(const protocol::Message& message, std::uint32_t request_id) {
    if (!ok() || send_failed_) return false;
    const auto frame = frame_of(message, request_id);
    if (SSL_write(ssl_, frame.data(), static_cast<int>(frame.size())) <= 0)
      return fail("SSL_write");
    return send_bytes(drain());
  }

  // The next frame from the daemon, or nullopt (failure(): an alert, the close, the deadline).
  std::optional<protocol::Envelope> next(
      std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    protocol::StreamDecoder::Outcome outcome;
    for (;;) {
      while (offset_ < plain_.size()) {
        const std::size_t used = decoder_.feed(
            std::span<const std::uint8_t>(plain_.data() + offset_, plain_.size() - offset_),
            outcome);
        offset_ += used;
        if (outcome.kind == protocol::StreamDecoder::Kind::kMessage) return outcome.envelope;
        if (outcome.kind == protocol::StreamDecoder::Kind::kError) {
          failure_ = "undecodable frame from the daemon";
          return std::nullopt;
        }
        if (used == 0) break;
      }
      plain_.erase(plain_.begin(), plain_.begin() + static_cast<long>(offset_));
      offset_ = 0;
      if (!ok()) return std::nullopt;
      std::array<std::uint8_t, 4096> buffer{};
      const int r = SSL_read(ssl_, buffer.data(), static_cast<int>(buffer.size()));
      if (r > 0) {
        plain_.insert(plain_.end(), buffer.begin(), buffer.begin() + r);
        continue;
      }
      const int error = SSL_get_error(ssl_, r);
      if (error == SSL_ERROR_ZERO_RETURN) {
        failure_ = "closed by the daemon (close_notify)";
        return std::nullopt;
      }
      if (error != SSL_ERROR_WANT_READ) {
        fail("read");
        return std::nullopt;
      }
      if (!receive(deadline)) return std::nullopt;
    }
  }

  // The reply to `request_id` (events, telemetry and other replies skipped), or the unsolicited
  // Error (request id 0) the daemon sends before it closes a session; nullopt: see failure().
  std::optional<protocol::Message> reply_to(
      std::uint32_t request_id, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      auto envelope = next(std::max(left, std::chrono::milliseconds(1)));
      if (!envelope) return std::nullopt;
      if (envelope->request_id == request_id) return envelope->message;
      if (envelope->request_id == 0 &&
          std::holds_alternative<protocol::ErrorReply>(envelope->message))
        return envelope->message;
    }
  }

  // The bytes the daemon's kernel socket holds that the daemon has not read yet (its end of this
  // connection in /proc/net/tcp), or nullopt when not found. 0: the daemon read all we sent.
  std::optional<long> unread_at_daemon() const {
    std::ifstream table("/proc/net/tcp");
    std::string line;
    std::getline(table, line);  // header
    char local[64];
    char remote[64];
    std::snprintf(local, sizeof local, "0100007F:%04X", port_);
    std::snprintf(remote, sizeof remote, "0100007F:%04X", local_port_);
    while (std::getline(table, line)) {
      std::istringstream fields(line);
      std::string slot, l, r, state, queues;
      fields >> slot >> l >> r >> state >> queues;
      if (l == local && r == remote) {
        const auto colon = queues.find(':');
        if (colon == std::string::npos) return std::nullopt;
        return std::stol(queues.substr(colon + 1), nullptr, 16);
      }
    }
    return std::nullopt;
  }

 private:
  bool fail(const std::string& what) {
    std::string text = what + ": ";
    const unsigned long e = ERR_get_error();
    if (e != 0) {
      char buffer[256];
      ERR_error_string_n(e, buffer, sizeof buffer);
      text += buffer;
    } else {
      text += closed_ ? "connection closed" : "failed";
    }
    ERR_clear_error();
    if (failure_.empty()) failure_ = text;
    return false;
  }

  std::vector<std::uint8_t> drain() {
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(BIO_ctrl_pending(out_)));
    if (!bytes.empty()) BIO_read(out_, bytes.data(), static_cast<int>(bytes.size()));
    return bytes;
  }

  bool send_bytes(const std::vector<std::uint8_t>& bytes) {
    std::size_t at = 0;
    while (at < bytes.size()) {
      const ssize_t n = ::send(fd_, bytes.data() + at, bytes.size() - at, MSG_NOSIGNAL);
      if (n <= 0) {  // the daemon closed: what it sent before (an alert) is still read
        send_failed_ = true;
        return false;
      }
      at += static_cast<std::size_t>(n);
    }
    return true;
  }

  // Reads what the socket has into OpenSSL's input (waits until the deadline).
  bool receive(std::chrono::steady_clock::time_point deadline) {
    if (closed_) {
      if (failure_.empty()) failure_ = "connection closed by the daemon";
      return false;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    pollfd p{fd_, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) {
      failure_ = "no answer from the daemon before the deadline";
      return false;
    }
    std::array<std::uint8_t, 16384> buffer{};
    const ssize_t n = ::recv(fd_, buffer.data(), buffer.size(), 0);
    if (n <= 0) {
      closed_ = true;
      BIO_set_mem_eof_return(in_, 0);  // OpenSSL now reads the end of the stream
      return true;
    }
    BIO_write(in_, buffer.data(), static_cast<int>(n));
    return true;
  }

  std::uint16_t port_ = 0;
  std::uint16_t local_port_ = 0;
  int fd_ = -1;
  SSL_CTX* ctx_ = nullptr;
  SSL* ssl_ = nullptr;
  BIO* in_ = nullptr;
  BIO* out_ = nullptr;
  bool closed_ = false;
  bool send_failed_ = false;
  std::string failure_;
  std::deque<std::vector<std::uint8_t>> records_;
  std::vector<std::uint8_t> plain_;
  std::size_t offset_ = 0;
  protocol::StreamDecoder decoder_;
};

}  // namespace ajar::test
