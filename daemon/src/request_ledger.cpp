#include "ajar/daemon/request_ledger.hpp"

#include <algorithm>

namespace ajar::daemon {

RequestLedger::RequestLedger(Limits limits) : limits_(limits) {
  limits_.replies_per_client = std::max<std::size_t>(limits_.replies_per_client, 1);
  limits_.max_clients = std::max<std::size_t>(limits_.max_clients, 1);
}

const protocol::Message* RequestLedger::find(std::uint64_t client_instance_id,
                                             std::uint32_t request_id, protocol::MessageType type) {
  auto it = clients_.find(client_instance_id);
  if (it == clients_.end()) return nullptr;
  it->second.last_used = ++use_counter_;
  auto& replies = it->second.replies;
  for (auto r = replies.rbegin(); r != replies.rend(); ++r) {
    if (r->request_id == request_id) return r->type == type ? &r->reply : nullptr;
  }
  return nullptr;
}

RequestLedger::Client& RequestLedger::touch(std::uint64_t client_instance_id) {
  auto it = clients_.find(client_instance_id);
  if (it == clients_.end()) {
    if (clients_.size() >= limits_.max_clients) {
      auto oldest = std::min_element(
          clients_.begin(), clients_.end(),
          [](const auto& a, const auto& b) { return a.second.last_used < b.second.last_used; });
      clients_.erase(oldest);
    }
    it = clients_.emplace(client_instance_id, Client{}).first;
  }
  it->second.last_used = ++use_counter_;
  return it->second;
}

void RequestLedger::record(std::uint64_t client_instance_id, std::uint32_t request_id,
                           protocol::MessageType type, const protocol::Message& reply) {
  auto& replies = touch(client_instance_id).replies;
  std::erase_if(replies, [&](const Record& r) { return r.request_id == request_id; });
  if (replies.size() >= limits_.replies_per_client) replies.pop_front();
  replies.push_back(Record{request_id, type, reply});
}

std::size_t RequestLedger::reply_count(std::uint64_t client_instance_id) const noexcept {
  auto it = clients_.find(client_instance_id);
  return it == clients_.end() ? 0 : it->second.replies.size();
}

}  // namespace ajar::daemon
