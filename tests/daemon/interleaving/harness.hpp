// The interleaving proof's harness (interleaving_test.cpp): the coverage counters, the engine as
// the hub sees it (recording what reaches it), and one client connection as the hub sees it.
#pragma once

#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <stdlib.h>

#include "../recording_link.hpp"
#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/session_hub.hpp"
#include "../fake_engine.hpp"

namespace ajar::testing::interleaving {

constexpr std::int64_t kPeriodNs = 2'000'000;  // 500 Hz
constexpr double kEps = 1e-9;

inline std::string shm_dir() {
  // State files on tmpfs when available: thousands of engines each persist dozens of times.
  std::string pattern = std::filesystem::exists("/dev/shm") ? "/dev/shm/ajar-interleave-XXXXXX"
                                                            : "/tmp/ajar-interleave-XXXXXX";
  return ::mkdtemp(pattern.data()) != nullptr ? pattern : std::string("/tmp");
}

// Situations a campaign must reach (so that the test cannot silently stop exploring).
struct Coverage {
  std::map<std::string, long> counts;
  void bump(const std::string& what) { ++counts[what]; }
  void add(const Coverage& other) {
    for (const auto& [k, v] : other.counts)
      counts[k] += v;
  }
  long get(const std::string& what) const {
    const auto it = counts.find(what);
    return it == counts.end() ? 0 : it->second;
  }
};

// The engine as the hub sees it, recording what reaches it (exactly-once is checked against it), is
// the tests' one engine double in front of the real engine.
using ajar::test::FakeEngine;

// One client connection as the hub sees it; the frames it was sent are decoded by the test.
class FakeLink final : public RecordingLink {
 public:
  FakeLink(std::uint64_t id, std::uint64_t client_instance)
      : RecordingLink(id, client_instance, 40000 + id) {}

  struct Expected {
    std::uint32_t request_id = 0;
    std::optional<protocol::Message> reply;  // when known (the engine's or the recorded reply)
    bool immediate = true;                   // false once it was seen held
  };
  std::deque<Expected> expected;
};
}  // namespace ajar::testing::interleaving
