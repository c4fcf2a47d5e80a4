// DetLoopTest: the control loop driven cycle by cycle (2 ms apart) on a fake clock over the
// deterministic card (no thread, no timing). A test suite derives from it and adjusts the settings
// in configure() before the loop is made.
#pragma once

#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "ajar/daemon/control_loop.hpp"
#include "det_card.hpp"

namespace ajar::testing {

class DetLoopTest : public ::testing::Test {
 public:
  static constexpr std::int64_t kMs = 1'000'000;

 protected:
  void SetUp() override {
    settings.rate_hz = 500;
    settings.deadman_timeout_s = 30;
    configure(settings);
    card.now_ns = &now;
    card.tick = &tick;
    card.left_axis = settings.base.left.card_axis;
    card.right_axis = settings.base.right.card_axis;
    card.axes[card.left_axis].enabled = true;
    card.axes[card.right_axis].enabled = true;
    make_loop();
  }
  virtual void configure(daemon::ControlLoopSettings&) {}
  void make_loop() { loop = std::make_unique<daemon::ControlLoop>(impl, settings); }

  // n cycles, 2 ms apart; the controller's heartbeat kept fresh unless told otherwise.
  void run(int n, bool heartbeat = true) {
    for (int i = 0; i < n; ++i) {
      ++tick;
      now += 2 * kMs;
      if (heartbeat) loop->heartbeat(now);
      loop->cycle(now);
    }
  }
  std::vector<daemon::LoopReport> reports() {
    std::vector<daemon::LoopReport> out;
    daemon::LoopReport r;
    while (loop->pop_report(r))
      out.push_back(r);
    return out;
  }
  int calls(DetCardState::Call::Kind kind) const {
    int n = 0;
    for (const auto& c : card.calls)
      n += c.kind == kind ? 1 : 0;
    return n;
  }
  static int count(const std::vector<daemon::LoopReport>& rs, daemon::LoopReportKind kind) {
    int n = 0;
    for (const auto& r : rs)
      n += r.kind == kind ? 1 : 0;
    return n;
  }

  daemon::ControlLoopSettings settings;
  std::int64_t now = 1'000 * kMs;
  std::uint64_t tick = 0;
  DetCardState card;
  DetCard impl{card};
  std::unique_ptr<daemon::ControlLoop> loop;
};

}  // namespace ajar::testing
