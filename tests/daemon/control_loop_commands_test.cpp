// The loop's ordered command path and its recovery state machine, cycle by cycle on a fake clock
// over the deterministic card (no thread, no timing).
#include <gtest/gtest.h>

#include "ajar/daemon/control_loop.hpp"
#include "det_loop_fixture.hpp"

namespace ajar::daemon {
namespace {

using ajar::testing::CardCall;
using ajar::testing::kMs;

class LoopCommands : public ajar::testing::DetLoopTest {
 protected:
  void configure(ControlLoopSettings& s) override { s.recovery_timeout_s = 0.1; }
};

TEST_F(LoopCommands, AStopCancelsEveryMoveQueuedBeforeIt) {
  ASSERT_TRUE(loop->post_move({1, 5000, 5000}));
  loop->request_stop();  // same "read": before the loop's next cycle
  run(5);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 0);
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMoveCancelled);
  EXPECT_EQ(rs[0].motion_id, 1U);
  EXPECT_EQ(loop->snapshot().last_motion_id, 1U);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);  // a Stop latches nothing
}

TEST_F(LoopCommands, AMovePostedAfterAStopRuns) {
  loop->request_stop();
  ASSERT_TRUE(loop->post_move({2, 500, 500}));
  run(200);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 1);
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMotionFinished);
}

TEST_F(LoopCommands, AStopBetweenTwoCyclesOfARunningMoveStopsItInTheNextCycle) {
  ASSERT_TRUE(loop->post_move({3, 100000, 100000}));
  run(2);
  ASSERT_EQ(calls(CardCall::kMoveRelative), 1);
  loop->request_stop();
  ASSERT_TRUE(loop->post_move({4, 10, 10}));  // posted after the stop: refused, a motion runs
  run(1);
  EXPECT_EQ(calls(CardCall::kSmoothStop), 1);
  run(10);
  const auto rs = reports();
  EXPECT_EQ(count(rs, LoopReportKind::kMotionStopped), 1);
  EXPECT_EQ(count(rs, LoopReportKind::kMoveRefused), 1);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 1);
}

TEST_F(LoopCommands, EmergencyStopReachesTheCardWithAFullQueue) {
  ASSERT_TRUE(loop->post_move({1, 100000, 100000}));
  run(2);
  for (std::uint32_t i = 0; i < ControlLoop::kCommandQueueCapacity; ++i) {
    ASSERT_TRUE(loop->post_move({10 + i, 10, 10}));
  }
  ASSERT_FALSE(loop->post_move({99, 10, 10}));
  loop->request_emergency_stop();  // never refused
  run(1);
  EXPECT_EQ(calls(CardCall::kEmergencyStop), 1);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 1);  // none of the queued moves started
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kEmergencyStopped);
  const auto rs = reports();
  EXPECT_EQ(count(rs, LoopReportKind::kMoveCancelled),
            static_cast<int>(ControlLoop::kCommandQueueCapacity));
  EXPECT_EQ(count(rs, LoopReportKind::kFault), 1);
}

TEST_F(LoopCommands, FaultStopCodesAreNeverOverwritten) {
  ASSERT_TRUE(loop->post_move({1, 100000, 100000}));
  run(2);
  loop->request_fault_stop(ErrorCode::kDeadman);
  loop->request_fault_stop(ErrorCode::kArmTimeout);  // before the loop saw the first
  run(1);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kDeadman);  // the first is the root cause
  run(10);
  const auto rs = reports();
  ASSERT_EQ(count(rs, LoopReportKind::kFault), 1);
  for (const auto& r : rs) {
    if (r.kind == LoopReportKind::kFault) {
      EXPECT_EQ(r.code, ErrorCode::kDeadman);
    }
    if (r.kind == LoopReportKind::kMotionStopped) {
      EXPECT_EQ(r.code, ErrorCode::kDeadman);
    }
  }
  // More codes than the fault queue holds: the first still wins.
  ASSERT_TRUE(loop->request_recover(1));
  run(5);
  for (std::size_t i = 0; i < ControlLoop::kFaultQueueCapacity + 4; ++i) {
    loop->request_fault_stop(i == 0 ? ErrorCode::kLimitHit : ErrorCode::kArmFault);
  }
  run(1);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kLimitHit);
}

TEST_F(LoopCommands, RecoveryIsAStateMachineAdvancedOncePerCycle) {
  card.set_enable_delay_reads(6);  // the servo comes on a few status reads after enable
  card.inject_alarm(left_axis);
  run(1);
  ASSERT_EQ(loop->snapshot().fault, ErrorCode::kAxisAlarm);
  reports();
  ASSERT_TRUE(loop->request_recover(7));
  run(1);  // clear faults, nothing else
  EXPECT_EQ(calls(CardCall::kClearFaults), 1);
  EXPECT_EQ(calls(CardCall::kEnableAxes), 0);
  EXPECT_TRUE(loop->snapshot().recovering);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);  // the latch is cleared when it starts
  run(1);                                             // enable
  EXPECT_EQ(calls(CardCall::kEnableAxes), 1);
  EXPECT_TRUE(reports().empty());
  ASSERT_TRUE(loop->post_move({5, 500, 500}));  // waits behind the recovery
  run(1);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 0);
  run(6);  // polls until the servo is on
  auto rs = reports();
  ASSERT_GE(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kRecovered);
  EXPECT_EQ(rs[0].code, ErrorCode::kOk);
  EXPECT_EQ(rs[0].sequence, 7U);
  EXPECT_FALSE(loop->snapshot().recovering);
  EXPECT_EQ(loop->snapshot().recover_sequence, 7U);
  EXPECT_EQ(loop->snapshot().card_state, drivers::LifecycleState::kActive);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 1);  // the queued move ran after it
}

TEST_F(LoopCommands, TwoRecoversInOneBatchAreEachAnswered) {
  card.inject_following_error(right_axis);
  ASSERT_TRUE(loop->post_move({1, 10, 10}));
  run(1);
  ASSERT_EQ(loop->snapshot().fault, ErrorCode::kFollowingError);
  ASSERT_TRUE(loop->request_recover(1));
  ASSERT_TRUE(loop->request_recover(2));
  run(20);
  std::vector<std::uint32_t> answered;
  for (const auto& r : reports()) {
    if (r.kind == LoopReportKind::kRecovered) {
      EXPECT_EQ(r.code, ErrorCode::kOk);
      answered.push_back(r.sequence);
    }
  }
  EXPECT_EQ(answered, (std::vector<std::uint32_t>{1, 2}));
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);
}

TEST_F(LoopCommands, ARecoverPostedBeforeAnEmergencyStopDoesNotClearIt) {
  loop->request_emergency_stop();
  run(1);
  ASSERT_TRUE(loop->request_recover(1));  // Reset ...
  loop->request_emergency_stop();         // ... then EmergencyStop, in one read
  run(5);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kEmergencyStopped);
  bool answered = false;
  for (const auto& r : reports()) {
    if (r.kind == LoopReportKind::kRecovered) {
      EXPECT_EQ(r.sequence, 1U);
      EXPECT_EQ(r.code, ErrorCode::kEmergencyStopped);
      answered = true;
    }
  }
  EXPECT_TRUE(answered);
}

TEST_F(LoopCommands, EmergencyStopDuringRecoveryEndsIt) {
  card.set_enable_delay_reads(50);
  card.inject_alarm(left_axis);
  run(1);
  ASSERT_TRUE(loop->request_recover(3));
  run(3);
  ASSERT_TRUE(loop->snapshot().recovering);
  loop->request_emergency_stop();
  run(1);
  EXPECT_FALSE(loop->snapshot().recovering);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kEmergencyStopped);
  EXPECT_GE(calls(CardCall::kEmergencyStop), 1);
  const auto rs = reports();
  ASSERT_FALSE(rs.empty());
  EXPECT_EQ(rs.back().kind, LoopReportKind::kRecovered);
  EXPECT_EQ(rs.back().code, ErrorCode::kEmergencyStopped);
}

TEST_F(LoopCommands, RecoveryFailsWhenTheAlarmPersistsOrTheServoNeverComesOn) {
  card.set_alarm_persists(true);
  card.inject_alarm(left_axis);
  run(1);
  ASSERT_TRUE(loop->request_recover(1));
  run(5);
  auto rs = reports();
  ASSERT_FALSE(rs.empty());
  EXPECT_EQ(rs.back().kind, LoopReportKind::kRecovered);
  EXPECT_EQ(rs.back().code, ErrorCode::kAxisAlarm);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kAxisAlarm);

  card.set_alarm_persists(false);
  card.set_enable_delay_reads(1'000'000);  // servo never on
  ASSERT_TRUE(loop->request_recover(2));
  const int deadline_cycles = static_cast<int>(settings.recovery_timeout_s / 0.002);
  run(deadline_cycles / 2);
  EXPECT_TRUE(loop->snapshot().recovering);  // still polling, every cycle, without waiting
  run(deadline_cycles * 3);
  rs = reports();
  ASSERT_FALSE(rs.empty());
  EXPECT_EQ(rs.back().kind, LoopReportKind::kRecovered);
  EXPECT_EQ(rs.back().sequence, 2U);
  EXPECT_EQ(rs.back().code, ErrorCode::kMotionTimeout);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kMotionTimeout);
}

TEST_F(LoopCommands, FaultReportsCarryTheLastRecoverTaken) {
  card.inject_alarm(left_axis);
  run(1);
  ASSERT_TRUE(loop->request_recover(4));
  run(10);
  reports();
  loop->request_fault_stop(ErrorCode::kDeadman);
  run(1);
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kFault);
  EXPECT_EQ(rs[0].sequence, 4U);
}

}  // namespace
}  // namespace ajar::daemon
