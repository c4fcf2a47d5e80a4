// RequestLedger: exactly-once execution of host commands. The session layer records the reply the
// engine gave to (client instance id, request id); a repeated request from the same client
// instance (a host retrying after a timeout, also over a new connection) gets the recorded reply
// and never reaches the engine again.
//
// Bounded: the last `replies_per_client` replies per client instance id, and at most
// `max_clients` client instance ids (the least recently used one is forgotten first). A host must
// not reuse a request id within its last `replies_per_client` requests.
// Not thread-safe: used on the I/O thread only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <unordered_map>

#include "ajar/protocol/messages.hpp"

namespace ajar::daemon {

class RequestLedger {
 public:
  struct Limits {
    std::size_t replies_per_client = 256;
    std::size_t max_clients = 64;
  };

  RequestLedger() : RequestLedger(Limits{}) {}
  explicit RequestLedger(Limits limits);

  // The reply recorded for this request, or nullptr. `type` is the request's message type: a
  // request id reused for a different message type is not a repeat (returns nullptr).
  // Marks the client instance as recently used.
  const protocol::Message* find(std::uint64_t client_instance_id, std::uint32_t request_id,
                                protocol::MessageType type);

  // Records the reply to a request that reached the engine (replacing an older record with the
  // same request id). Evicts the oldest reply of this client, and the least recently used client,
  // when a bound is reached.
  void record(std::uint64_t client_instance_id, std::uint32_t request_id,
              protocol::MessageType type, const protocol::Message& reply);

  std::size_t client_count() const noexcept { return clients_.size(); }
  std::size_t reply_count(std::uint64_t client_instance_id) const noexcept;
  const Limits& limits() const noexcept { return limits_; }

 private:
  struct Record {
    std::uint32_t request_id = 0;
    protocol::MessageType type = protocol::MessageType::kPing;
    protocol::Message reply;
  };
  struct Client {
    std::deque<Record> replies;  // oldest first
    std::uint64_t last_used = 0;
  };

  Client& touch(std::uint64_t client_instance_id);

  Limits limits_;
  std::unordered_map<std::uint64_t, Client> clients_;
  std::uint64_t use_counter_ = 0;
};

}  // namespace ajar::daemon
