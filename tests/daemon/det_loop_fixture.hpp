// DetLoopTest: the control loop driven cycle by cycle (2 ms apart) on a fake clock over the
// deterministic card (det_mock_card.hpp) (no thread, no timing). A test suite derives from it and
// adjusts the settings in configure() before the loop is made.
#pragma once

#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "ajar/daemon/control_loop.hpp"
#include "det_mock_card.hpp"

namespace ajar::testing {

class DetLoopTest : public ::testing::Test {
 public:
  static constexpr std::int64_t kMs = ajar::testing::kMs;

 protected:
  void SetUp() override {
    settings.control.rate_hz = 500;
    settings.safety.deadman_timeout_s = 30;
    configure(settings);
    left_axis = settings.base.left.card_axis;
    right_axis = settings.base.right.card_axis;
    // The loop starts over an open card with both wheels' servos on (what activate() leaves).
    ASSERT_TRUE(card.open().ok());
    const int wheels[] = {left_axis, right_axis};
    ASSERT_EQ(card.enable_axes(wheels), ErrorCode::kOk);
    log_start = card.log_size();
    make_loop();
  }
  virtual void configure(daemon::ControlLoopSettings&) {}
  void make_loop() { loop = std::make_unique<daemon::ControlLoop>(*impl, settings); }

  // n cycles, 2 ms apart; the controller's heartbeat kept fresh unless told otherwise.
  void run(int n, bool heartbeat = true) {
    for (int i = 0; i < n; ++i) {
      ++tick;
      clock.advance_ns(2 * kMs);
      if (heartbeat) loop->heartbeat(now());
      loop->cycle(now());
    }
  }
  // Cycles (as run(1)) until a fault latches in the loop, at most `limit`: the number run.
  int run_until_fault(int limit) {
    int n = 0;
    while (n < limit && loop->snapshot().fault == ErrorCode::kOk) {
      run(1);
      ++n;
    }
    return n;
  }
  std::int64_t now() const { return clock.now_ns(); }
  std::vector<daemon::LoopReport> reports() {
    std::vector<daemon::LoopReport> out;
    daemon::LoopReport r;
    while (loop->pop_report(r))
      out.push_back(r);
    return out;
  }
  // Calls the loop made (the set-up's excluded).
  int calls(CardCall kind) const { return count_calls(card, kind, log_start); }
  static int count(const std::vector<daemon::LoopReport>& rs, daemon::LoopReportKind kind) {
    int n = 0;
    for (const auto& r : rs)
      n += r.kind == kind ? 1 : 0;
    return n;
  }

  daemon::ControlLoopSettings settings;
  FakeClock clock;
  std::uint64_t tick = 0;
  std::unique_ptr<drivers::MockMotionCard> impl = make_det_card(clock);
  drivers::MockMotionCard& card = *impl;
  int left_axis = 1, right_axis = 2;
  std::size_t log_start = 0;
  std::unique_ptr<daemon::ControlLoop> loop;
};

}  // namespace ajar::testing
