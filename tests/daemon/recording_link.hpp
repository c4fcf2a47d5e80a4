// One client connection as the session hub sees it, in tests: it keeps every frame the hub sends
// (the test decodes them) and says closed once the hub closes or aborts it. The interleaving
// proof and the reply-order campaign add what each expects on top.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/daemon/session_hub.hpp"

namespace ajar::testing {

class RecordingLink : public daemon::SessionLink {
 public:
  // peer_port: the port in the link's peer address (each test its own range, for its traces).
  RecordingLink(std::uint64_t id, std::uint64_t client_instance, std::uint64_t peer_port)
      : id_(id), instance(client_instance), peer_("127.0.0.1:" + std::to_string(peer_port)) {}
  std::uint64_t id() const noexcept override { return id_; }
  const std::string& peer() const noexcept override { return peer_; }
  bool send(daemon::SharedFrame frame) override {
    if (closed) return false;
    frames.push_back(std::move(frame));
    return true;
  }
  void close_after_flush(std::string_view) override { closed = true; }
  void abort(std::string_view) override { closed = true; }

  std::uint64_t id_;
  std::uint64_t instance;  // Hello.client_instance_id
  std::string peer_;
  bool closed = false;
  std::vector<daemon::SharedFrame> frames;

 protected:
  ~RecordingLink() = default;  // owned as the test's own link type, as SessionLink
};

}  // namespace ajar::testing
