// Shared fixture for engine tests: an engine over the mock card and the mock arm on the steady
// clock (its real control thread), its events, and helpers that poll the engine (as the I/O thread
// does) until a condition holds. Never asserts timing.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <thread>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/engine.hpp"
#include "ajar/drivers/mock_arm.hpp"
#include "fake_door.hpp"
#include "ajar/drivers/mock_card.hpp"

namespace ajar::testing {

// The arm double of the engine tests: a task stays busy until the test says how it ends
// (MockManipulator::set_phase). `arm` points at it; the engine owns it.
inline std::unique_ptr<drivers::Manipulator> make_mock_arm(drivers::MockManipulator*& arm) {
  auto mock = std::make_unique<drivers::MockManipulator>(drivers::MockFault::kStuck);
  arm = mock.get();
  return mock;
}

class EngineTest : public ::testing::Test {
 protected:
  void TearDown() override { engine.reset(); }

  void start() {
    drivers::DriverSet set;
    auto mock_card =
        std::make_unique<drivers::MockMotionCard>(drivers::MockFault::kNone, 0, kCardTimeScale);
    card = mock_card.get();
    card->record_calls(true);
    if (configure_card) configure_card(*card);
    set.card = std::move(mock_card);
    set.arm = make_mock_arm(arm);
    config.drivers.sim_speedup = kCardTimeScale;  // the loop's view of the card's time
    engine = daemon::make_engine(config, std::move(set));
    engine->set_event_sink([this](const protocol::Event& e) { events.push_back(e); });
    engine->start();
  }
  void restart() {
    engine.reset();
    events.clear();
    start();
  }

  // A command from the controller (any frame is a heartbeat).
  protocol::Message send(const protocol::Message& m) {
    engine->controller_heartbeat();
    return engine->handle_command(m);
  }

  // Polls until pred() holds (false after 20 s). With `alive`, the controller keeps sending
  // heartbeats meanwhile (otherwise it is silent: the deadman may fire).
  template <typename Pred>
  bool wait_for(Pred pred, bool alive = false) {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    for (;;) {
      if (alive) engine->controller_heartbeat();
      engine->poll();
      if (pred()) return true;
      if (std::chrono::steady_clock::now() > give_up) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  bool wait_for_state(protocol::ProcedureState s) {
    return wait_for([&] { return engine->status().state == s; });
  }
  bool saw_event(protocol::EventKind kind, ErrorCode fault = ErrorCode::kOk) const {
    for (const auto& e : events) {
      if (e.kind == kind && (fault == ErrorCode::kOk || e.fault == fault)) return true;
    }
    return false;
  }
  int move_calls() { return static_cast<int>(card->calls(drivers::CardCall::kMoveRelative)); }

  // Walks the procedure to `target` (one of the resting states or kAligning/kEngaging).
  void walk_to(protocol::ProcedureState target);

  TempDir tmp;
  daemon::Config config = test_config(tmp.path());
  // The card's simulated time runs this much faster than the steady clock: an alignment takes
  // tens of milliseconds.
  static constexpr double kCardTimeScale = 20;
  drivers::MockMotionCard* card = nullptr;  // the engine's (a new one each start)
  std::function<void(drivers::MockMotionCard&)> configure_card;  // before each start
  drivers::MockManipulator* arm = nullptr;  // the engine's (a new one each start)
  std::unique_ptr<daemon::Engine> engine;
  std::vector<protocol::Event> events;
};

inline void expect_ack(const protocol::Message& reply, protocol::ProcedureState state) {
  const auto* ack = std::get_if<protocol::Ack>(&reply);
  ASSERT_NE(ack, nullptr) << "expected an Ack, got "
                          << (std::holds_alternative<protocol::ErrorReply>(reply)
                                  ? std::string(
                                        std::get<protocol::ErrorReply>(reply).message.view())
                                  : std::string("another message"));
  EXPECT_EQ(ack->state, state) << protocol::to_string(ack->state);
}

inline void expect_refused(const protocol::Message& reply, ErrorCode code,
                           std::string_view field = {}) {
  const auto* e = std::get_if<protocol::ErrorReply>(&reply);
  ASSERT_NE(e, nullptr) << "expected an ErrorReply";
  EXPECT_EQ(e->code, code) << to_string(e->code) << ": " << e->message.view();
  if (!field.empty()) {
    EXPECT_EQ(e->field.view(), field);
  }
  EXPECT_GT(e->message.length, 0);
}

inline void EngineTest::walk_to(protocol::ProcedureState target) {
  using protocol::ProcedureState;
  if (target == ProcedureState::kAwaitingWidth) return;
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  if (target == ProcedureState::kAwaitingHandle) return;
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  if (target == ProcedureState::kAwaitingPlane) return;
  expect_ack(send(plane_at_yaw(0.1)), ProcedureState::kReadyToAlign);
  if (target == ProcedureState::kReadyToAlign) return;
  if (target == ProcedureState::kAligning) {
    card->stick_next_move();  // the alignment never ends on its own
  }
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  if (target == ProcedureState::kAligning) {
    ASSERT_TRUE(wait_for([&] { return move_calls() == 1; }));  // the wheels are turning
    return;
  }
  ASSERT_TRUE(wait_for([&] { return engine->status().state == ProcedureState::kAligned; }, true));
  if (target == ProcedureState::kAligned) return;
  expect_ack(send(good_contact()), ProcedureState::kReadyToEngage);
  if (target == ProcedureState::kReadyToEngage) return;
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
  if (target == ProcedureState::kEngaging) return;
  arm->set_phase(drivers::ArmPhase::kDone);
  ASSERT_TRUE(wait_for([&] { return engine->status().state == ProcedureState::kEngaged; }, true));
}

}  // namespace ajar::testing
