// A stalled control loop, through the engine over its real control thread and loop supervisor:
// a card call hangs mid-jog and mid-move (the mock card's block_calls). The supervisor latches
// LOOP_STALLED while the call still hangs, its out-of-band stop reaches the card and the wheels
// rest, every session gets the fault event, a Reset is refused while the loop is stalled, and once
// the call returns nothing moves until a Reset. docs/control-loop.md, "Stalled loop".
#include <gtest/gtest.h>

#include <string>

#include "fake_engine_fixture.hpp"

namespace ajar::testing {
namespace {

using drivers::CardCall;
using protocol::EventKind;
using protocol::ProcedureState;

class EngineStall : public EngineTest {
 protected:
  void TearDown() override {
    if (card != nullptr) card->release_blocked_calls();  // never leave the control thread hung
    EngineTest::TearDown();
  }
  int left() const { return config.base.left.card_axis; }
  int right() const { return config.base.right.card_axis; }

  const protocol::Event* fault_event() const {
    for (const auto& e : events)
      if (e.kind == EventKind::kFaultLatched) return &e;
    return nullptr;
  }
  // The next axis_status() of the control thread hangs; returns once it does.
  void hang_the_loop() {
    card->block_calls(CardCall::kAxisStatus, 1);
    ASSERT_TRUE(wait_for([&] { return card->blocked_calls() == 1; }, true));
  }
  // While the loop still hangs: the fault is latched and told, the card took the out-of-band
  // stop, the wheels rest, and neither a Drive nor a Reset is accepted.
  void expect_stalled_and_stopped() {
    ASSERT_TRUE(wait_for([&] { return fault_event() != nullptr; }, true))
        << "no fault latched while the control loop hangs in a card call";
    const protocol::Event& e = *fault_event();
    EXPECT_EQ(e.fault, ErrorCode::kLoopStalled);
    EXPECT_NE(std::string(e.detail.view()).find("base emergency-stopped out of band"),
              std::string::npos)
        << e.detail.view();
    // The journal says what the card answered to the out-of-band stop.
    bool taken = false;
    EXPECT_TRUE(wait_for(
        [&] {
          for (const auto& w : engine->take_warnings())
            taken = taken || w == "loop supervisor: out-of-band emergency stop taken by the card";
          return taken;
        },
        true));
    EXPECT_EQ(card->blocked_calls(), 1U);  // all of it while the call still hangs
    EXPECT_EQ(card->calls(CardCall::kEmergencyStopOutOfBand), 1U);
    EXPECT_FALSE(card->any_moving());
    EXPECT_TRUE(card->peek(left()).emergency_stopped);
    EXPECT_TRUE(card->peek(right()).emergency_stopped);
    EXPECT_EQ(engine->status().latched_fault, ErrorCode::kLoopStalled);
    EXPECT_EQ(engine->status().card, protocol::DriverState::kFault);
    expect_refused(send(protocol::Drive{0.1, 0.0}), ErrorCode::kFaultLatched);
    expect_refused(send(protocol::Reset{}), ErrorCode::kLoopStalled);
    EXPECT_EQ(count(EventKind::kFaultLatched), 1);
  }
  // The call returns: the loop ends the motion (motion_stopped), the fault stays, nothing the
  // card is told after that moves a wheel, until a Reset.
  void release_and_expect_nothing_moves() {
    const std::size_t from = card->log_size();
    card->release_blocked_calls();
    ASSERT_TRUE(wait_for([&] { return count(EventKind::kMotionStopped) == 1; }, true));
    EXPECT_EQ(engine->status().latched_fault, ErrorCode::kLoopStalled);
    EXPECT_EQ(count(EventKind::kFaultLatched), 1);
    expect_refused(send(protocol::Drive{0.1, 0.0}), ErrorCode::kFaultLatched);
    // The loop runs again (its snapshot advances) and nothing moves.
    const auto cycles = engine->status().loop.cycles;
    ASSERT_TRUE(wait_for([&] { return engine->status().loop.cycles > cycles + 50; }, true));
    EXPECT_FALSE(card->any_moving());
    for (const auto& call : card->log_from(from)) {
      EXPECT_NE(call.kind, CardCall::kMoveRelative);
      EXPECT_FALSE(call.kind == CardCall::kJog && call.jogs());
    }
  }
  // Reset recovers the card; then the base drives again (the Reset was what it took).
  void reset_and_drive_again() {
    ASSERT_TRUE(wait_for(
        [&] { return !std::holds_alternative<protocol::ErrorReply>(send(protocol::Reset{})); },
        true));
    // The loop's recovery clears the card's emergency stop and enables the axes again.
    ASSERT_TRUE(wait_for(
        [&] {
          return !card->peek(left()).emergency_stopped && card->peek(left()).enabled &&
                 engine->status().card == protocol::DriverState::kActive;
        },
        true));
    EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
    const auto reply = send(protocol::Drive{0.1, 0.0});
    ASSERT_FALSE(std::holds_alternative<protocol::ErrorReply>(reply))
        << to_string(std::get<protocol::ErrorReply>(reply).code);
    EXPECT_TRUE(wait_for([&] { return card->jogging(left()); }, true));
    send(protocol::Stop{});
  }
  int count(EventKind kind) const {
    int n = 0;
    for (const auto& e : events)
      n += e.kind == kind ? 1 : 0;
    return n;
  }
};

TEST_F(EngineStall, ACardCallThatHangsMidJogIsCaughtAndTheBaseStopped) {
  start();
  ASSERT_TRUE(wait_for([&] { return engine->status().card == protocol::DriverState::kActive; }));
  const auto reply = send(protocol::Drive{0.1, 0.0});
  ASSERT_FALSE(std::holds_alternative<protocol::ErrorReply>(reply));
  ASSERT_TRUE(wait_for([&] { return card->jogging(left()) && card->jogging(right()); }, true));
  hang_the_loop();
  expect_stalled_and_stopped();
  // The wheels stay where they are while the call still hangs (the card's clock runs on: 50 ms
  // are a second of its time; a jog at 0.1 m/s would have moved).
  const auto here = card->peek(left()).encoder_position_counts;
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(card->peek(left()).encoder_position_counts, here);
  EXPECT_EQ(card->blocked_calls(), 1U);
  release_and_expect_nothing_moves();
  reset_and_drive_again();
}

TEST_F(EngineStall, ACardCallThatHangsMidMoveIsCaughtAndTheBaseStopped) {
  // The card's clock stands still unless the test advances it: the alignment runs as long as the
  // test needs (the loop's deadline, on the steady clock, is seconds away).
  configure_card = [](drivers::MockMotionCard& c) { c.set_manual_clock(true); };
  start();
  walk_to(ProcedureState::kReadyToAlign);
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  ASSERT_TRUE(wait_for([&] { return move_calls() == 1; }, true));
  const auto started = card->peek(left()).encoder_position_counts;
  card->advance_clock_ns(20'000'000);  // the wheels turn
  ASSERT_TRUE(card->any_moving());
  hang_the_loop();
  expect_stalled_and_stopped();
  const auto here = card->peek(left()).encoder_position_counts;
  EXPECT_NE(here, started);
  card->advance_clock_ns(1'000'000'000);  // a second of the card's time: the wheels stay
  EXPECT_EQ(card->peek(left()).encoder_position_counts, here);
  EXPECT_FALSE(card->any_moving());
  release_and_expect_nothing_moves();
  EXPECT_EQ(engine->status().state, ProcedureState::kFault);
  card->set_manual_clock(false);
  reset_and_drive_again();
}

}  // namespace
}  // namespace ajar::testing
