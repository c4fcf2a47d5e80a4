// Support for the tests that stop, kill and restart the ajard binary on one state directory
// (e2e_lifecycle_test.cpp, crash_campaign_test.cpp): start-and-wait-for-the-port, replies that may
// never come (the daemon may be going away), "nothing moves" from telemetry, and a state writer
// that hangs on demand.
#pragma once

#include <sys/stat.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "ajard_process.hpp"
#include "test_client.hpp"

namespace ajar::test {

// Starts `ajard --config CONFIG --port-file DIR/port` (the state directory is the config's) and
// waits until it serves. nullopt when it exited instead (its stderr says why).
inline std::optional<std::uint16_t> start_ajard(std::unique_ptr<AjardProcess>& process,
                                                const std::string& config, const std::string& dir,
                                                const std::string& name) {
  const std::string port_file = dir + "/port";
  std::filesystem::remove(port_file);
  process = std::make_unique<AjardProcess>(
      std::vector<std::string>{"--config", config, "--port-file", port_file}, dir, name);
  return wait_for_port_file(port_file, *process);
}

// The reply to `request_id`, or nullopt when the connection closed or `timeout` passed; no test
// failure (the daemon may be going away). Events on the way are kept in client.events();
// telemetry is skipped.
inline std::optional<protocol::Message> try_reply(
    TestClient& client, std::uint32_t request_id,
    std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    auto outcome = client.next(left);
    if (!outcome) return std::nullopt;
    if (outcome->kind != protocol::StreamDecoder::Kind::kMessage) continue;
    const auto& envelope = outcome->envelope;
    if (const auto* event = std::get_if<protocol::Event>(&envelope.message)) {
      client.events().push_back(*event);
      continue;
    }
    if (std::holds_alternative<protocol::Telemetry>(envelope.message)) continue;
    if (envelope.request_id == request_id) return envelope.message;
  }
}

inline std::optional<protocol::Message> try_request(
    TestClient& client, const protocol::Message& message,
    std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
  return try_reply(client, client.send(message), timeout);
}

inline bool is_ack(const std::optional<protocol::Message>& reply) {
  return reply && std::holds_alternative<protocol::Ack>(*reply);
}

inline ErrorCode refusal_of(const std::optional<protocol::Message>& reply) {
  return reply ? error_code_of(*reply) : ErrorCode::kInternal;
}

// Over the next `frames` telemetry frames (a fresh subscription of `watcher`): nothing is reported
// moving, nothing is commanded, and the wheel counts never change. Adds a failure naming what
// moved.
inline bool nothing_moves(TestClient& watcher, std::size_t frames = 25) {
  std::optional<protocol::Telemetry> first;
  for (std::size_t i = 0; i < frames; ++i) {
    if (!watcher.wait_telemetry(watcher.telemetry_count() + 1, std::chrono::seconds(10))) {
      ADD_FAILURE() << "no telemetry";
      return false;
    }
    const protocol::Telemetry& t = *watcher.last_telemetry();
    if (!first) first = t;
    if (t.moving || t.commanded_linear_m_s != 0 || t.commanded_angular_rad_s != 0 ||
        t.left_counts != first->left_counts || t.right_counts != first->right_counts) {
      ADD_FAILURE() << "the base moved: left " << first->left_counts << " -> " << t.left_counts
                    << ", right " << first->right_counts << " -> " << t.right_counts
                    << (t.moving ? " (moving)" : "") << ", commanded " << t.commanded_linear_m_s
                    << " m/s";
      return false;
    }
  }
  return true;
}

// Makes the state store's next save hang: `ajard.state.tmp` becomes a FIFO, and the writer's
// open() of it blocks until somebody reads it (nobody does) — a disk that never finishes, from the
// instant the test chooses. A save already in flight (its `.tmp` written, not yet renamed) is let
// finish first: the FIFO is made only where no file is, so it is never the writer's file renamed
// over `ajard.state` (removing the writer's `.tmp` did that, or lost the name to the writer's next
// open: mkfifo failed, the crash campaign's rare "hang_disk returned false"). resume_disk()
// removes it (before the next start).
inline bool hang_disk(const std::string& state_dir) {
  const std::string fifo = state_dir + "/ajard.state.tmp";
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (;;) {
    if (::mkfifo(fifo.c_str(), 0600) == 0) return true;
    if (errno != EEXIST || std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}
inline void resume_disk(const std::string& state_dir) {
  std::filesystem::remove(state_dir + "/ajard.state.tmp");
}

}  // namespace ajar::test
