// The deterministic card of the loop, engine and interleaving tests: the drivers' MockMotionCard
// (mock_card.hpp) on the test's FakeClock (never the steady clock, so that a seed replays
// exactly), with constant-speed motion (a move runs at its profile velocity from the first
// instant, a jog takes its velocity at once), smooth stops that rest kDetStopDelayNs later, and
// every call logged. The engine (or the loop test) owns it; the test keeps a pointer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "ajar/drivers/mock_card.hpp"
#include "fake_clock.hpp"

namespace ajar::testing {

using drivers::CardCall;

constexpr std::int64_t kDetStopDelayNs = 6'000'000;

inline std::unique_ptr<drivers::MockMotionCard> make_det_card(const FakeClock& clock) {
  auto mock = std::make_unique<drivers::MockMotionCard>(drivers::MockFault::kNone, 0, 1.0, 8,
                                                        clock.clock());
  mock->set_motion_model(drivers::MockMotionModel::kConstantSpeed, kDetStopDelayNs);
  mock->record_calls(true);
  return mock;
}

// Logged calls of `kind` from log index `from` on; with_speed: only jogs that set an axis moving.
inline int count_calls(const drivers::MockMotionCard& card, CardCall kind, std::size_t from = 0,
                       bool with_speed = false) {
  int n = 0;
  for (const auto& c : card.log_from(from))
    n += c.kind == kind && (!with_speed || c.jogs()) ? 1 : 0;
  return n;
}

// Every axis of `axes` at rest or stopping (no wheel runs on under an older command).
inline bool stopping_or_at_rest(drivers::MockMotionCard& card, std::initializer_list<int> axes) {
  for (const int axis : axes) {
    const auto st = card.peek(axis);
    if (st.moving && !st.smooth_stopped) return false;
  }
  return true;
}

}  // namespace ajar::testing
