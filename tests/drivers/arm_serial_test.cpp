// The serial arm driver against the arm-controller simulator on a pseudo-terminal: one test per
// line fault. No timing assertions: conditions are awaited with generous deadlines, and what is
// asserted is behaviour (the task ran exactly once, the link came back, ...).
#include <gtest/gtest.h>

#include <cmath>

#include "arm_test_support.hpp"

namespace ajar::drivers {
namespace {

using test::sample_task;
using test::SerialRig;
using test::wait_for;
using test::wait_phase;

ArmSimulatorSettings quick_tasks() {
  ArmSimulatorSettings s;
  s.task_duration_ms = 30;
  return s;
}

ArmSimulatorSettings endless_tasks() {
  ArmSimulatorSettings s;
  s.task_duration_ms = 600'000;
  return s;
}

// Hands off a task and waits until the driver reports it done.
void run_task_to_done(SerialRig& rig) {
  auto id = rig.arm->hand_off(sample_task());
  ASSERT_TRUE(id.ok()) << id.error().message;
  ASSERT_TRUE(wait_for([&] {
    const auto s = rig.arm->status();
    return s.phase == ArmPhase::kDone && s.task_id == id.value();
  })) << "phase "
      << static_cast<int>(rig.arm->status().phase);
}

TEST(ArmSerial, NormalHandoffDeliversTheTaskOnce) {
  SerialRig rig(quick_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  auto id = rig.arm->hand_off(sample_task());
  ASSERT_TRUE(id.ok());
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kDone));
  const auto c = rig.sim->counters();
  EXPECT_EQ(c.tasks_executed, 1U);
  EXPECT_EQ(c.tasks_completed, 1U);
  EXPECT_EQ(rig.sim->last_task_id(), id.value());
  const auto task = rig.sim->last_task();
  ASSERT_TRUE(task.has_value());
  const DoorTask sent = sample_task();
  EXPECT_NEAR(task->contact_base_m.x(), sent.contact_base_m.x(), 1e-4);
  EXPECT_NEAR(task->contact_base_m.y(), sent.contact_base_m.y(), 1e-4);
  EXPECT_NEAR(task->contact_base_m.z(), sent.contact_base_m.z(), 1e-4);
  EXPECT_NEAR(task->door_width_m, sent.door_width_m, 1e-4);
  EXPECT_NEAR(task->handle_length_m, sent.handle_length_m, 1e-4);
  EXPECT_EQ(task->door_direction, sent.door_direction);
  EXPECT_EQ(task->handle_direction, sent.handle_direction);
}

TEST(ArmSerial, BadChecksumRepliesAreRetriedAndTheTaskRunsOnce) {
  SerialRig rig(quick_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  rig.sim->corrupt_next_replies(2, arm::Command::kTask);
  run_task_to_done(rig);
  // DONE may overtake the retries (the task is short): wait for the exchange to finish.
  ASSERT_TRUE(wait_for([&] { return rig.sim->counters().duplicates_ignored >= 2; }));
  ASSERT_TRUE(wait_for([&] { return rig.arm->counters().bad_lines >= 2; }));
  const auto c = rig.sim->counters();
  EXPECT_EQ(c.tasks_executed, 1U);
  EXPECT_GE(c.duplicates_ignored, 2U);
  EXPECT_GE(rig.arm->counters().bad_lines, 2U);
  EXPECT_GE(rig.arm->counters().retransmissions, 2U);
}

TEST(ArmSerial, LostAcknowledgementsAreRetriedWithTheSameSeqAndTheTaskRunsOnce) {
  SerialRig rig(quick_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  rig.sim->drop_next_replies(3, arm::Command::kTask);
  run_task_to_done(rig);
  ASSERT_TRUE(wait_for([&] { return rig.sim->counters().duplicates_ignored >= 3; }));
  const auto c = rig.sim->counters();
  EXPECT_EQ(c.tasks_executed, 1U) << "a retry moved the arm twice";
  EXPECT_GE(c.duplicates_ignored, 3U);
  EXPECT_GE(rig.arm->counters().retransmissions, 3U);
}

TEST(ArmSerial, RetriesExhaustedGiveArmTimeoutThenTheControllerStatusTells) {
  SerialArmSettings settings = test::serial_settings("");
  settings.retries = 2;
  SerialRig rig(quick_tasks(), settings);
  ASSERT_TRUE(rig.arm->connect().ok());
  rig.sim->drop_next_replies(3, arm::Command::kTask);  // every attempt's reply
  auto id = rig.arm->hand_off(sample_task());
  ASSERT_TRUE(id.ok());
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kFault));
  EXPECT_EQ(rig.arm->status().last_error, ErrorCode::kArmTimeout);
  EXPECT_EQ(rig.arm->counters().timeouts, 1U);
  EXPECT_EQ(rig.sim->counters().tasks_executed, 1U) << "three attempts, one execution";
  // The task did reach the arm: after clearing, the controller's status shows it done.
  ASSERT_TRUE(rig.arm->clear_fault().ok());
  ASSERT_TRUE(wait_for([&] {
    const auto s = rig.arm->status();
    return s.phase == ArmPhase::kDone && s.task_id == id.value();
  }));
}

TEST(ArmSerial, GarbageBytesAreSkipped) {
  SerialRig rig(quick_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  static constexpr char kNoise[] = "\x00\xFF\xFE garbage $$$ *12\r\n";
  rig.sim->send_raw(std::string(kNoise, sizeof kNoise - 1));
  rig.sim->garble_next_replies(4);
  run_task_to_done(rig);
  rig.sim->send_raw("$1,ACK,STOP,IDLE,0*0000\r\n$xyz\r\n");
  run_task_to_done(rig);
  EXPECT_EQ(rig.sim->counters().tasks_executed, 2U);
  EXPECT_GT(rig.arm->counters().dropped_bytes, 0U);
  EXPECT_GT(rig.arm->counters().bad_lines, 0U);
}

TEST(ArmSerial, SlowRepliesAreWaitedForAndTheTaskRunsOnce) {
  SerialRig rig(quick_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  // Slower than one ack timeout (150 ms), well inside the retry budget (6 x 150 ms).
  rig.sim->set_reply_delay_ms(400);
  run_task_to_done(rig);
  EXPECT_EQ(rig.sim->counters().tasks_executed, 1U);
  EXPECT_GT(rig.arm->counters().retransmissions, 0U);
  EXPECT_GT(rig.arm->counters().bad_lines, 0U) << "late replays of earlier attempts are dropped";
}

TEST(ArmSerial, DeviceGoneAndBackReconnectsAndAHandoffWorks) {
  SerialRig rig(quick_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  EXPECT_EQ(rig.arm->status().reconnects, 0U);
  rig.sim->unplug();
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kDisconnected));
  EXPECT_EQ(rig.arm->status().last_error, ErrorCode::kArmDisconnected);
  auto refused = rig.arm->hand_off(sample_task());
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kArmDisconnected);
  EXPECT_FALSE(rig.arm->stop().ok()) << "a stop while the link is down says it did not arrive";

  rig.sim->replug();
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kIdle));
  EXPECT_GE(rig.arm->status().reconnects, 1U);
  EXPECT_EQ(rig.arm->status().last_error, ErrorCode::kOk);
  EXPECT_TRUE(wait_for([&] { return rig.sim->counters().stops >= 1; }))
      << "the stop queued while disconnected is sent on reconnect";
  run_task_to_done(rig);
  EXPECT_EQ(rig.sim->counters().tasks_executed, 1U);
}

TEST(ArmSerial, DeviceGoneDuringATaskResumesIt) {
  ArmSimulatorSettings sim;
  sim.task_duration_ms = 1500;
  SerialRig rig(sim);
  ASSERT_TRUE(rig.arm->connect().ok());
  auto id = rig.arm->hand_off(sample_task());
  ASSERT_TRUE(id.ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->counters().tasks_executed == 1; }));
  rig.sim->unplug();
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kDisconnected));
  rig.sim->replug();
  ASSERT_TRUE(wait_for([&] {
    const auto s = rig.arm->status();
    return s.phase == ArmPhase::kDone && s.task_id == id.value();
  }));
  EXPECT_GE(rig.arm->status().reconnects, 1U);
  EXPECT_EQ(rig.sim->counters().tasks_executed, 1U);
}

TEST(ArmSerial, StopDuringATaskStopsTheArm) {
  SerialRig rig(endless_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  ASSERT_TRUE(rig.arm->hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->phase() == arm::ControllerPhase::kBusy; }));
  ASSERT_TRUE(rig.arm->stop().ok());
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kIdle));
  EXPECT_EQ(rig.sim->phase(), arm::ControllerPhase::kIdle);
  EXPECT_EQ(rig.sim->counters().stops, 1U);
  EXPECT_EQ(rig.sim->counters().tasks_completed, 0U);
}

TEST(ArmSerial, StopCutsShortATaskStillBeingRetried) {
  SerialArmSettings settings = test::serial_settings("");
  settings.retries = 1000;  // 150 s of retries: far beyond the wait below
  SerialRig rig(endless_tasks(), settings);
  ASSERT_TRUE(rig.arm->connect().ok());
  rig.sim->drop_next_replies(1000, arm::Command::kTask);
  ASSERT_TRUE(rig.arm->hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->counters().tasks_executed == 1; }));
  ASSERT_TRUE(rig.arm->stop().ok());
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kIdle));
  EXPECT_EQ(rig.sim->phase(), arm::ControllerPhase::kIdle);
  EXPECT_EQ(rig.sim->counters().stops, 1U);
  EXPECT_EQ(rig.sim->counters().tasks_executed, 1U);
}

TEST(ArmSerial, ControllerFaultShowsAndClears) {
  SerialRig rig(endless_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  ASSERT_TRUE(rig.arm->hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->phase() == arm::ControllerPhase::kBusy; }));
  rig.sim->fail_current_task();
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kFault));
  EXPECT_EQ(rig.arm->status().last_error, ErrorCode::kArmFault);
  ASSERT_TRUE(rig.arm->clear_fault().ok());
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kIdle));
  EXPECT_EQ(rig.sim->phase(), arm::ControllerPhase::kIdle);
}

TEST(ArmSerial, ConnectNamesAMissingDevice) {
  SerialManipulator arm(test::serial_settings("/nonexistent/ajar-arm-tty"));
  auto st = arm.connect();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kArmDisconnected);
  EXPECT_NE(st.error().message.find("/nonexistent/ajar-arm-tty"), std::string::npos);
  EXPECT_EQ(arm.status().phase, ArmPhase::kDisconnected);
}

TEST(ArmSerial, ConnectReportsASilentController) {
  SerialArmSettings settings = test::serial_settings("");
  settings.retries = 1;
  SerialRig rig(quick_tasks(), settings);
  rig.sim->drop_next_replies(2);
  auto st = rig.arm->connect();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kArmTimeout);
  EXPECT_EQ(rig.arm->status().phase, ArmPhase::kDisconnected);
  EXPECT_TRUE(rig.arm->connect().ok()) << "the controller answers again";
}

TEST(ArmSerial, RejectsNonFiniteTaskWithoutSending) {
  SerialRig rig(quick_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  DoorTask t = sample_task();
  t.door_width_m = std::nan("");
  auto id = rig.arm->hand_off(t);
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.error().code, ErrorCode::kNonFinite);
  EXPECT_EQ(rig.arm->status().phase, ArmPhase::kIdle);
}

TEST(ArmSerial, InvalidLineSettingsAreNamed) {
  ArmControllerSimulator sim;
  SerialArmSettings s = test::serial_settings(sim.device_path());
  s.baud = 12345;
  SerialManipulator arm(s);
  auto st = arm.connect();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().field, "baud");
}

// The arm controller's own faults (ArmSimulatorSettings::fault and the test calls), as the serial
// driver shows them: the daemon's arm interlock (docs/procedure.md) relies on these reports.

// A controller that falls silent mid-task: the STOP runs out of retries (kDisconnected with
// kArmTimeout, never kIdle), is sent again when it answers, and only then is the arm idle.
TEST(ArmSerial, AStopToASilentControllerIsSentAgainWhenItAnswers) {
  SerialRig rig(endless_tasks());
  ASSERT_TRUE(rig.arm->connect().ok());
  ASSERT_TRUE(rig.arm->hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->phase() == arm::ControllerPhase::kBusy; }));
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kBusy));
  rig.sim->go_silent();
  ASSERT_TRUE(rig.arm->stop().ok());
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kDisconnected));
  EXPECT_EQ(rig.arm->status().last_error, ErrorCode::kArmTimeout);
  EXPECT_EQ(rig.sim->counters().stops, 0U);
  EXPECT_GE(rig.sim->counters().unanswered, 1U);
  EXPECT_EQ(rig.sim->phase(), arm::ControllerPhase::kBusy);
  rig.sim->answer_again();
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kIdle));
  // At least once: a re-sent STOP whose reply is later than the link's timeout (a loaded
  // ThreadSanitizer run did this) is sent again, with a new sequence number, until one is
  // answered; STOP is idempotent on the controller. What matters is that idle comes after one.
  EXPECT_GE(rig.sim->counters().stops, 1U);
  EXPECT_EQ(rig.sim->phase(), arm::ControllerPhase::kIdle);
}

// silent-mid-stop: the STOP itself is the first request it does not answer.
TEST(ArmSerial, AControllerSilentAtTheStopNeverShowsIdle) {
  ArmSimulatorSettings sim = endless_tasks();
  sim.fault = ArmSimFault::kSilentMidStop;
  SerialRig rig(sim);
  ASSERT_TRUE(rig.arm->connect().ok());
  ASSERT_TRUE(rig.arm->hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->phase() == arm::ControllerPhase::kBusy; }));
  ASSERT_TRUE(rig.arm->stop().ok());
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kDisconnected));
  EXPECT_TRUE(rig.sim->silent());
  EXPECT_EQ(rig.sim->counters().stops, 0U);
  rig.sim->answer_again();
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kIdle));
  EXPECT_EQ(rig.sim->counters().stops, 1U);
}

// stop-ignored: the STOP is acknowledged, with phase BUSY: the driver reports busy, not idle.
TEST(ArmSerial, AStopAnsweredWithBusyLeavesTheArmBusy) {
  ArmSimulatorSettings sim = quick_tasks();
  sim.fault = ArmSimFault::kStopIgnored;
  SerialRig rig(sim);
  ASSERT_TRUE(rig.arm->connect().ok());
  rig.sim->set_task_duration_ms(600'000);
  ASSERT_TRUE(rig.arm->hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->phase() == arm::ControllerPhase::kBusy; }));
  ASSERT_TRUE(rig.arm->stop().ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->counters().stops == 1; }));
  // Several status polls later the driver still reports the controller's word: busy.
  const auto requests = rig.sim->counters().requests;
  ASSERT_TRUE(wait_for([&] { return rig.sim->counters().requests >= requests + 3; }));
  EXPECT_EQ(rig.arm->status().phase, ArmPhase::kBusy);
  EXPECT_EQ(rig.sim->phase(), arm::ControllerPhase::kBusy);
  rig.sim->set_fault(ArmSimFault::kNone);
  rig.sim->set_ignore_stops(false);
  ASSERT_TRUE(rig.arm->stop().ok());
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kIdle));
}

// reset-mid-task: half way through the task the controller comes back idle with task id 0; the
// driver reports idle (the daemon, which saw the task busy, latches ARM_FAULT).
TEST(ArmSerial, AControllerResetMidTaskShowsIdle) {
  ArmSimulatorSettings sim;
  sim.task_duration_ms = 400;
  sim.fault = ArmSimFault::kResetMidTask;
  SerialRig rig(sim);
  ASSERT_TRUE(rig.arm->connect().ok());
  ASSERT_TRUE(rig.arm->hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->counters().tasks_executed == 1; }));
  ASSERT_TRUE(wait_for([&] { return rig.sim->phase() == arm::ControllerPhase::kIdle; }));
  EXPECT_EQ(rig.sim->last_task_id(), 0U);
  EXPECT_EQ(rig.sim->counters().tasks_completed, 0U);
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kIdle));
}

// silent-mid-task with a bounded silence: it answers again by itself and the task goes on.
TEST(ArmSerial, ASilenceOfSilentMsEndsByItself) {
  ArmSimulatorSettings sim;
  sim.task_duration_ms = 200;
  sim.fault = ArmSimFault::kSilentMidTask;
  sim.silent_ms = 1500;
  SerialRig rig(sim);
  ASSERT_TRUE(rig.arm->connect().ok());
  ASSERT_TRUE(rig.arm->hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_for([&] { return rig.sim->silent(); }));
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kDisconnected));
  ASSERT_TRUE(wait_for([&] { return !rig.sim->silent(); }));
  ASSERT_TRUE(wait_phase(*rig.arm, ArmPhase::kDone));
  EXPECT_EQ(rig.sim->counters().tasks_completed, 1U);
}

}  // namespace
}  // namespace ajar::drivers
