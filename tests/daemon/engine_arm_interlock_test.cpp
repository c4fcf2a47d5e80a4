// The arm interlock (docs/procedure.md, "The arm interlock") on the manual loop, the deterministic
// card and the mock arm, all on one fake clock: the base moves only while the arm has reported
// idle since its last task; a stop the arm does not confirm in time latches ARM_NOT_CLEAR; Reset
// clears a fault only once the arm reports idle. One test per arm-controller fault (it stops
// answering mid-task or mid-stop, resets mid-task, answers a stop but stays busy), and the loop's
// own refusal (belt and braces).
#include <string>

#include <gtest/gtest.h>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/engine.hpp"
#include "det_loop_fixture.hpp"
#include "det_mock_card.hpp"
#include "fake_door.hpp"
#include "fake_engine_fixture.hpp"
#include "manual_engine.hpp"

namespace ajar::testing {
namespace {

using protocol::EventKind;
using protocol::ProcedureState;

// The manual engine with an arm on the same fake clock whose tasks stay busy until the test says;
// its silence shows after 10 ms.
class ArmInterlock : public ManualEngine {
 protected:
  void SetUp() override {
    start_engine([](daemon::Config& c) {
      c.safety.arm_task_timeout_s = 5.0;
      c.safety.arm_stop_timeout_s = 0.5;
      c.drive.stale_yaw_rad = 1.0;  // a jog before Engage keeps the contact point
    });
  }
  std::unique_ptr<drivers::Manipulator> make_arm() override {
    auto mock_arm = std::make_unique<drivers::MockManipulator>(drivers::MockArmFault::kStuck, 10,
                                                               clock.clock());
    arm = mock_arm.get();
    return mock_arm;
  }

  static void accepted(const protocol::Message& reply) {
    ASSERT_TRUE(std::holds_alternative<protocol::Ack>(reply))
        << std::get<protocol::ErrorReply>(reply).message.view();
  }
  // Cycles for `seconds` of fake time.
  void run_for(double seconds) { cycles(static_cast<int>(seconds * 1e9 / kPeriodNs) + 1); }
  ErrorCode fault() { return engine->status().latched_fault; }
  // Every call that could turn a wheel (a move, or a jog with a speed).
  int wheel_calls() const {
    return count_calls(*card, CardCall::kMoveRelative) +
           count_calls(*card, CardCall::kJog, 0, true);
  }
  // The plane at a yaw that needs a turn, with the contact point: ready to engage, base aligned.
  void to_engaging() {
    to_ready_to_engage();
    expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
    cycles(3);
    wheel_calls_before = wheel_calls();
  }
  // Every command that turns the wheels is refused with `code` (AlignBase after a re-measured
  // plane, so that only the interlock can refuse it).
  void expect_base_refused(ErrorCode code) {
    expect_refused(send(protocol::Drive{0.1, 0.0}), code);
    expect_refused(send(protocol::Drive{0.0, 0.5}), code);
    expect_refused(send(protocol::Approach{0.6}), code);
    if (code == ErrorCode::kDriveNotAllowed) {
      (void)send(plane_at_yaw(0.05));
      expect_refused(send(protocol::AlignBase{}), code, "arm");
    } else {
      expect_refused(send(protocol::AlignBase{}), code);
    }
  }

  int wheel_calls_before = 0;
};

// The reported case (issue 22, item 2): the arm controller stops answering during its task, the
// operator sends Stop. The base stays still; the stop is not confirmed, ARM_NOT_CLEAR latches;
// Reset is refused until the arm answers again.
TEST_F(ArmInterlock, AnArmSilentMidTaskThenStopLatchesAndTheBaseNeverMoves) {
  to_engaging();
  arm->go_silent();
  expect_ack(send(protocol::Stop{}), ProcedureState::kReadyToEngage);
  // Before the stop's deadline: refused because the arm has not reported idle.
  expect_base_refused(ErrorCode::kDriveNotAllowed);
  cycles(20);  // the silence shows (disconnected)
  EXPECT_EQ(engine->status().arm_state, protocol::ArmState::kDisconnected);
  expect_base_refused(ErrorCode::kDriveNotAllowed);
  run_for(config.safety.arm_stop_timeout_s);
  EXPECT_EQ(fault(), ErrorCode::kArmNotClear);
  EXPECT_EQ(count(EventKind::kFaultLatched), 1);
  expect_base_refused(ErrorCode::kFaultLatched);
  expect_refused(send(protocol::Reset{}), ErrorCode::kArmNotClear, "arm");
  expect_refused(send(protocol::Reset{true}), ErrorCode::kArmNotClear, "arm");
  EXPECT_EQ(fault(), ErrorCode::kArmNotClear);
  run_for(1.0);
  EXPECT_EQ(wheel_calls(), wheel_calls_before) << "the wheels turned while the arm was silent";
  arm->answer_again();  // the owed stop acts: idle
  cycles(2);
  EXPECT_EQ(engine->status().arm_state, protocol::ArmState::kIdle);
  accepted(send(protocol::Reset{}));
  EXPECT_EQ(count(EventKind::kFaultCleared), 1);
  accepted(send(protocol::Drive{0.1, 0.0}));
  cycles(5);
  EXPECT_GT(wheel_calls(), wheel_calls_before) << "a Drive after the Reset moves the base again";
  accepted(send(protocol::Drive{0.0, 0.0}));  // released: the jog ends
  cycles(300);
  EXPECT_EQ(count(EventKind::kMotionStarted),
            count(EventKind::kMotionStopped) + count(EventKind::kMotionFinished));
}

// Silent mid-task and nobody stops it: the task's supervision latches (the silence shows as the
// driver reports it, ARM_TIMEOUT), and the same holds: no wheel, Reset only once it answers.
TEST_F(ArmInterlock, AnArmSilentMidTaskLatchesWithoutAStop) {
  to_engaging();
  arm->go_silent();
  cycles(20);
  EXPECT_EQ(fault(), ErrorCode::kArmTimeout);
  expect_base_refused(ErrorCode::kFaultLatched);
  expect_refused(send(protocol::Reset{}), ErrorCode::kArmNotClear, "arm");
  run_for(1.0);
  EXPECT_EQ(wheel_calls(), wheel_calls_before);
  arm->answer_again();
  cycles(2);
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToEngage);
}

// The arm answers until the stop, and the stop is the first thing it does not answer.
TEST_F(ArmInterlock, AnArmSilentMidStopLatches) {
  to_engaging();
  arm->silence_next_stop();
  expect_ack(send(protocol::Stop{}), ProcedureState::kReadyToEngage);
  expect_base_refused(ErrorCode::kDriveNotAllowed);
  run_for(config.safety.arm_stop_timeout_s);
  EXPECT_EQ(fault(), ErrorCode::kArmNotClear);
  expect_base_refused(ErrorCode::kFaultLatched);
  expect_refused(send(protocol::Reset{}), ErrorCode::kArmNotClear, "arm");
  EXPECT_EQ(wheel_calls(), wheel_calls_before);
  arm->answer_again();
  cycles(2);
  accepted(send(protocol::Reset{}));
}

// The arm answers the stop but stays busy: not a confirmation.
TEST_F(ArmInterlock, AnArmThatAnswersStopButStaysBusyLatches) {
  to_engaging();
  arm->ignore_stops(true);
  expect_ack(send(protocol::Stop{}), ProcedureState::kReadyToEngage);
  EXPECT_EQ(engine->status().arm_state, protocol::ArmState::kBusy);
  expect_base_refused(ErrorCode::kDriveNotAllowed);
  run_for(config.safety.arm_stop_timeout_s);
  EXPECT_EQ(fault(), ErrorCode::kArmNotClear);
  // Stops go on being sent (each Reset stops); the arm stays busy: Reset is refused.
  expect_refused(send(protocol::Reset{}), ErrorCode::kArmNotClear, "arm");
  expect_ack(send(protocol::Stop{}), ProcedureState::kFault);
  expect_refused(send(protocol::Reset{}), ErrorCode::kArmNotClear, "arm");
  EXPECT_EQ(wheel_calls(), wheel_calls_before);
  arm->ignore_stops(false);
  accepted(send(protocol::Reset{}));  // its stop now acts
}

// The controller resets mid-task: it comes back idle having forgotten the task. The task is
// aborted (ARM_FAULT); the arm did report idle, so a Reset clears it and the base may move.
TEST_F(ArmInterlock, AnArmControllerResetMidTaskAbortsAndResetClearsIt) {
  to_engaging();
  arm->reset_controller();
  cycles(2);
  EXPECT_EQ(fault(), ErrorCode::kArmFault);
  expect_base_refused(ErrorCode::kFaultLatched);
  EXPECT_EQ(wheel_calls(), wheel_calls_before);
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToEngage);
  expect_ack(send(protocol::Drive{0.1, 0.0}), ProcedureState::kReadyToEngage);
}

// A controller that drops the task before the engine's first poll is caught too.
TEST_F(ArmInterlock, AnArmThatForgetsTheTaskAtOnceAborts) {
  to_engaging();
  expect_ack(send(protocol::Stop{}), ProcedureState::kReadyToEngage);
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
  arm->reset_controller();  // before any poll
  cycles(2);
  EXPECT_EQ(fault(), ErrorCode::kArmFault);
}

// A done task: the arm may still be at the door until it reports idle. Reset (the next door) and
// Stop send it back to rest; until then the base stays.
TEST_F(ArmInterlock, ADoneArmHoldsTheBaseUntilItReportsIdle) {
  to_engaging();
  arm->set_phase(drivers::ArmPhase::kDone);
  cycles(2);
  ASSERT_EQ(engine->status().state, ProcedureState::kEngaged);
  expect_refused(send(protocol::Drive{0.1, 0.0}), ErrorCode::kDriveNotAllowed);
  // Re-measuring the width leaves ENGAGED, but the arm still reports done.
  expect_ack(send(good_width()), ProcedureState::kReadyToEngage);
  expect_refused(send(protocol::Drive{0.1, 0.0}), ErrorCode::kDriveNotAllowed, "arm");
  expect_refused(send(protocol::Approach{0.6}), ErrorCode::kDriveNotAllowed, "arm");
  EXPECT_EQ(wheel_calls(), wheel_calls_before);
  expect_ack(send(protocol::Stop{}), ProcedureState::kReadyToEngage);
  EXPECT_EQ(engine->status().arm_state, protocol::ArmState::kIdle);
  expect_ack(send(protocol::Drive{0.1, 0.0}), ProcedureState::kReadyToEngage);
  EXPECT_EQ(fault(), ErrorCode::kOk);
}

TEST_F(ArmInterlock, ResetAfterADoneTaskSendsTheArmBackToRest) {
  to_engaging();
  arm->set_phase(drivers::ArmPhase::kDone);
  cycles(2);
  expect_ack(send(protocol::Reset{true}), ProcedureState::kAwaitingWidth);
  EXPECT_EQ(engine->status().arm_state, protocol::ArmState::kIdle);
  expect_ack(send(protocol::Drive{0.1, 0.0}), ProcedureState::kAwaitingWidth);
}

// Without any task: an arm that does not report idle (its link lost, a fault) keeps the base still.
TEST_F(ArmInterlock, AnArmThatIsNotIdleRefusesEveryWheelMotion) {
  cycles(3);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  expect_ack(send(plane_at_yaw(0.1)), ProcedureState::kReadyToAlign);
  for (const auto phase : {drivers::ArmPhase::kDisconnected, drivers::ArmPhase::kFault,
                           drivers::ArmPhase::kBusy, drivers::ArmPhase::kDone}) {
    arm->set_phase(phase,
                   phase == drivers::ArmPhase::kFault ? ErrorCode::kArmFault : ErrorCode::kOk);
    cycles(2);
    expect_refused(send(protocol::Drive{0.1, 0.0}), ErrorCode::kDriveNotAllowed, "arm");
    expect_refused(send(protocol::Approach{0.6}), ErrorCode::kDriveNotAllowed, "arm");
    expect_refused(send(protocol::AlignBase{}), ErrorCode::kDriveNotAllowed, "arm");
  }
  EXPECT_EQ(wheel_calls(), 0);
  arm->set_phase(drivers::ArmPhase::kIdle);
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
}

// Found by the interleaving campaign (seed 9798 with the card side's stale status): a card whose
// status lags says "not moving" the moment a jog is told to stop; the stop must not end (and the
// arm get a task) before the card can have brought the wheels to rest.
TEST_F(ArmInterlock, AStopEndedByAStaleStatusDoesNotLetTheArmGoWhileTheWheelsRoll) {
  card->set_motion_model(drivers::MockMotionModel::kProfile);  // decelerates as it was told
  to_ready_to_engage();
  card->set_stale_status_reads(400);          // the status freezes at rest
  accepted(send(protocol::Drive{0.0, 0.6}));  // turning in place (the contact point stays fresh)
  cycles(4);
  ASSERT_TRUE(card->any_moving());
  expect_ack(send(protocol::Stop{}), ProcedureState::kReadyToEngage);
  bool engaged = false;
  for (int i = 0; i < 400 && !engaged; ++i) {
    cycles(1);
    const auto reply = send(protocol::Engage{});
    engaged = std::holds_alternative<protocol::Ack>(reply);
    if (engaged) {
      EXPECT_FALSE(card->any_moving()) << "the arm got its task while the wheels still roll";
    }
  }
  EXPECT_TRUE(engaged);
}

// The loop's own refusal: while the engine says the arm may be at the door, no move or jog starts.
class ArmAtDoorLoop : public DetLoopTest {};

TEST_F(ArmAtDoorLoop, NoWheelMotionStartsWhileTheArmMayBeAtTheDoor) {
  loop->set_arm_at_door(true);
  ASSERT_TRUE(loop->post_move({1, 1000, -1000}));
  run(5);
  ASSERT_TRUE(loop->post_drive({2, true, {0.1, 0.0}, now()}));
  run(5);
  const auto rs = reports();
  EXPECT_EQ(count(rs, daemon::LoopReportKind::kMoveRefused), 2);
  for (const auto& r : rs)
    EXPECT_EQ(r.code, ErrorCode::kDriveNotAllowed);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 0);
  EXPECT_EQ(calls(CardCall::kJog), 0);
  loop->set_arm_at_door(false);
  ASSERT_TRUE(loop->post_move({3, 1000, -1000}));
  run(5);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 1);
}

}  // namespace
}  // namespace ajar::testing
