// Cases the randomized interleaving test (interleaving_test.cpp) found, pinned as plain tests on
// the manual loop and the deterministic card.
#include <gtest/gtest.h>

#include "manual_engine.hpp"

namespace ajar::testing {
namespace {

class InterleavingRegressions : public ManualEngine {
 protected:
  // Every axis at rest or stopping (no wheel runs on under an older command).
  bool wheels_stopping_or_at_rest() { return stopping_or_at_rest(*card, {left_axis, right_axis}); }
  bool wheels_move() { return card->any_moving(); }
};

// Seed 2 of the first Drive campaign: a Reset acknowledged during a jog left the wheels jogging
// (Reset stopped only an alignment or the arm's task). docs/procedure.md: Reset "stops any motion".
TEST_F(InterleavingRegressions, ResetDuringAJogStopsIt) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  expect_ack(send(protocol::Drive{0.1, 0.0}), ProcedureState::kAwaitingHandle);
  cycles(50);
  ASSERT_TRUE(wheels_move());
  const std::size_t before = card->log_size();
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingHandle);
  cycles(1);
  EXPECT_TRUE(wheels_stopping_or_at_rest()) << "the jog went on after an acknowledged Reset";
  cycles(100);
  EXPECT_FALSE(wheels_move());
  EXPECT_EQ(count_calls(*card, CardCall::kJog, before, true), 0);
  EXPECT_EQ(count(EventKind::kMotionStarted), 1);
  EXPECT_EQ(count(EventKind::kMotionStopped), 1);
  EXPECT_EQ(count(EventKind::kMotionFinished), 0);
}

TEST_F(InterleavingRegressions, ResetDuringAnApproachStopsIt) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  expect_ack(send(protocol::Approach{1.4}), ProcedureState::kAwaitingHandle);
  cycles(10);
  ASSERT_TRUE(wheels_move());
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingHandle);
  cycles(1);
  EXPECT_TRUE(wheels_stopping_or_at_rest()) << "the approach went on after an acknowledged Reset";
  cycles(100);
  EXPECT_FALSE(wheels_move());
  EXPECT_EQ(count(EventKind::kMotionStopped), 1);
  EXPECT_EQ(count(EventKind::kMotionFinished), 0);
}

// Approach (or Drive) and Reset in one read: nothing reaches the card, the motion is closed.
TEST_F(InterleavingRegressions, ApproachOrDriveAndResetInOneReadNeverMove) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  engine->begin_read_batch();
  expect_ack(send(protocol::Approach{1.4}), ProcedureState::kAwaitingHandle);
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingHandle);
  engine->end_read_batch();
  engine->begin_read_batch();
  expect_ack(send(protocol::Drive{0.1, 0.2}), ProcedureState::kAwaitingHandle);
  expect_ack(send(protocol::Reset{}), ProcedureState::kAwaitingHandle);
  engine->end_read_batch();
  cycles(100);
  EXPECT_EQ(moves(), 0);
  EXPECT_EQ(count_calls(*card, CardCall::kJog, 0, true), 0);
  EXPECT_EQ(count(EventKind::kMotionStarted), 2);
  EXPECT_EQ(count(EventKind::kMotionStopped), 2);
}

}  // namespace
}  // namespace ajar::testing
