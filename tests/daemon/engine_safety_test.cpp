// The engine with its loop driven by hand on a fake clock (EngineOptions::manual_loop) over the
// deterministic card: resets that cannot merge, events that pair, the arm's deadline, shutdown.
#include <gtest/gtest.h>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/engine.hpp"
#include "manual_engine.hpp"

namespace ajar::testing {
namespace {

using protocol::EventKind;
using protocol::ProcedureState;

TEST_F(ManualEngine, TwoResetsInOneReadDuringAFaultThenLaterFaultsStillLatch) {
  to_ready_to_engage();
  card->inject_alarm(left_axis);
  cycles(2);
  ASSERT_EQ(engine->status().latched_fault, ErrorCode::kAxisAlarm);
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToEngage);
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToEngage);
  cycles(20);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  EXPECT_EQ(engine->status().card, protocol::DriverState::kActive);
  // The engine waits for nothing any more: the deadman while the arm works latches.
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
  cycles(100, /*alive=*/false);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kDeadman);
  EXPECT_GE(arm->stops(), 1U);
  EXPECT_EQ(count(EventKind::kMotionStarted),
            count(EventKind::kMotionStopped) + count(EventKind::kMotionFinished));
}

TEST_F(ManualEngine, ResetAlignBaseStopInOneReadTurnsNothing) {
  to_ready_to_align();
  expect_ack(send(protocol::EmergencyStop{}), ProcedureState::kFault);
  cycles(5);
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToAlign);
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  expect_ack(send(protocol::Stop{}), ProcedureState::kReadyToAlign);
  cycles(300);
  EXPECT_EQ(moves(), 0);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  EXPECT_EQ(count(EventKind::kMotionStarted), 1);
  EXPECT_EQ(count(EventKind::kMotionStopped), 1);
  // The wheels never turned: the plane still holds, a new AlignBase is accepted.
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  cycles(1000);
  EXPECT_EQ(state(), ProcedureState::kAligned);
}

TEST_F(ManualEngine, TakeOverRightAfterAlignBaseClosesTheMotion) {
  to_ready_to_align();
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  engine->controller_lost();  // before the loop's next cycle
  cycles(50);
  EXPECT_EQ(moves(), 0);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kDeadman);
  EXPECT_EQ(count(EventKind::kMotionStarted), 1);
  EXPECT_EQ(count(EventKind::kMotionStopped), 1);
  EXPECT_EQ(count(EventKind::kFaultLatched), 1);
}

TEST_F(ManualEngine, EachLatchIsAnnouncedOnceAndSurfacedOnceForTheJournal) {
  to_ready_to_align();
  (void)engine->take_warnings();
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  cycles(5);
  expect_ack(send(protocol::EmergencyStop{}), ProcedureState::kFault);
  expect_ack(send(protocol::EmergencyStop{}), ProcedureState::kFault);
  cycles(50);
  EXPECT_EQ(count(EventKind::kFaultLatched), 1);
  EXPECT_EQ(count(EventKind::kMotionStopped), 1);
  int latched = 0;
  for (const auto& w : engine->take_warnings()) {
    if (w.find("fault latched: EMERGENCY_STOPPED") != std::string::npos) ++latched;
  }
  EXPECT_EQ(latched, 1);
}

TEST_F(ManualEngine, AStuckArmTaskHitsItsDeadline) {
  to_ready_to_engage();
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
  cycles(static_cast<int>(config.safety.arm_task_timeout_s / 0.002) - 5);
  EXPECT_EQ(state(), ProcedureState::kEngaging);  // not before the deadline
  cycles(10);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kArmTimeout);
  EXPECT_GE(arm->stops(), 1U);
  EXPECT_EQ(count(EventKind::kMotionStopped), 1);
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToEngage);
}

TEST_F(ManualEngine, AnArmControllerThatDropsTheTaskAborts) {
  to_ready_to_engage();
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
  cycles(3);
  arm->set_phase(drivers::ArmPhase::kIdle);  // reset mid-task: busy -> idle without our stop
  cycles(2);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kArmFault);
  EXPECT_EQ(count(EventKind::kMotionStopped), 1);
}

TEST_F(ManualEngine, ShutdownWhileMovingTellsEverySessionFirst) {
  to_ready_to_align();
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  cycles(5);
  ASSERT_EQ(moves(), 1);
  // The fake clock stands still during shutdown(): smooth stops rest at once.
  card->set_motion_model(drivers::MockMotionModel::kConstantSpeed, 0);
  engine->shutdown();
  ASSERT_EQ(count(EventKind::kMotionStopped), 1);
  EXPECT_NE(events.back().detail.view().find("shutting down"), std::string_view::npos);
  EXPECT_GE(count_calls(*card, CardCall::kSmoothStop), 1);
}

// The same over the real control thread: the wheels stop under its supervision first.
TEST_F(EngineTest, ShutdownWhileAligningEmitsMotionStoppedWithTheReason) {
  start();
  walk_to(ProcedureState::kAligning);
  engine->shutdown();
  bool said = false;
  for (const auto& e : events) {
    if (e.kind == protocol::EventKind::kMotionStopped) {
      said = said || e.detail.view().find("shutting down") != std::string_view::npos;
    }
  }
  EXPECT_TRUE(said);
  EXPECT_GE(card->calls(drivers::CardCall::kSmoothStop), 1U);
}

}  // namespace
}  // namespace ajar::testing
