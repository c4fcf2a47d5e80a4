// ManualEngine: the engine with its loop driven by hand on the FakeClock
// (EngineOptions::manual_loop) over the deterministic card and the mock arm (make_arm(): a suite
// may give another). `configure` may change the config before start.
#pragma once

#include <functional>
#include <memory>

#include <gtest/gtest.h>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/engine.hpp"
#include "det_mock_card.hpp"
#include "fake_clock.hpp"
#include "fake_door.hpp"
#include "fake_engine_fixture.hpp"

namespace ajar::testing {

using protocol::EventKind;
using protocol::ProcedureState;

constexpr std::int64_t kPeriodNs = 2'000'000;

class ManualEngine : public ::testing::Test {
 protected:
  void SetUp() override { start_engine(); }
  void start_engine(const std::function<void(daemon::Config&)>& configure = {}) {
    config.safety.deadman_timeout_s = 0.05;
    config.safety.arm_task_timeout_s = 0.5;
    config.control.motion_timeout_margin_s = 0.2;
    if (configure) configure(config);
    left_axis = config.base.left.card_axis;
    right_axis = config.base.right.card_axis;
    drivers::DriverSet set;
    auto mock_card = make_det_card(clock);
    card = mock_card.get();
    set.card = std::move(mock_card);
    set.arm = make_arm();
    daemon::EngineOptions options;
    options.now_ns = clock.clock();
    options.manual_loop = true;
    engine = daemon::make_engine(config, std::move(set), std::move(options));
    engine->set_event_sink([this](const protocol::Event& e) { events.push_back(e); });
    engine->start();
  }
  void TearDown() override { engine.reset(); }
  // The engine's arm; `arm` points at it. The default: make_mock_arm (busy until the test says).
  virtual std::unique_ptr<drivers::Manipulator> make_arm() { return make_mock_arm(arm); }
  // A new engine with a changed config (a new card and arm).
  void restart(const std::function<void(daemon::Config&)>& configure) {
    engine.reset();
    events.clear();
    start_engine(configure);
  }

  protocol::Message send(const protocol::Message& m) {
    ++tick;
    engine->controller_heartbeat();
    return engine->handle_command(m);
  }
  void cycles(int n, bool alive = true) {
    for (int i = 0; i < n; ++i) {
      ++tick;
      clock.advance_ns(kPeriodNs);
      if (alive) engine->controller_heartbeat();
      engine->run_loop_cycle();
      engine->poll();
    }
  }
  ProcedureState state() { return engine->status().state; }
  int count(EventKind kind) const {
    int n = 0;
    for (const auto& e : events)
      n += e.kind == kind ? 1 : 0;
    return n;
  }
  int moves() const { return count_calls(*card, CardCall::kMoveRelative); }
  void to_ready_to_align() {
    cycles(3);
    expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
    expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
    expect_ack(send(plane_at_yaw(0.1)), ProcedureState::kReadyToAlign);
  }
  void to_ready_to_engage() {
    to_ready_to_align();
    expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
    cycles(1000);
    ASSERT_EQ(state(), ProcedureState::kAligned);
    expect_ack(send(good_contact()), ProcedureState::kReadyToEngage);
  }

  TempDir tmp;
  daemon::Config config = test_config(tmp.path());
  FakeClock clock;
  std::uint64_t tick = 0;
  drivers::MockMotionCard* card = nullptr;  // the engine's
  int left_axis = 1, right_axis = 2;
  drivers::MockManipulator* arm = nullptr;  // the engine's
  std::unique_ptr<daemon::Engine> engine;
  std::vector<protocol::Event> events;
};

}  // namespace ajar::testing
