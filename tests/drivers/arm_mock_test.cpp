// MockManipulator's fault menu (settings.hpp MockFault), as the daemon tests rely on it, on a fake
// clock: each phase change is checked just before and at the instant it is due.
#include <gtest/gtest.h>

#include "ajar/drivers/mock_arm.hpp"
#include "arm_test_support.hpp"
#include "fake_clock.hpp"

namespace ajar::drivers {
namespace {

using ajar::testing::FakeClock;
using test::sample_task;

constexpr int kSlowMs = 10;

struct ArmMock : ::testing::Test {
  // A connected mock with `fault` on the fake clock.
  MockManipulator& arm(MockFault fault) {
    mock = std::make_unique<MockManipulator>(fault, kSlowMs, clock.clock());
    EXPECT_TRUE(mock->connect().ok());
    return *mock;
  }
  ArmPhase phase() const { return mock->status().phase; }

  FakeClock clock;
  std::unique_ptr<MockManipulator> mock;
};

TEST_F(ArmMock, OffFinishesTasksAfterTheTaskDuration) {
  MockManipulator& a = arm(MockFault::kNone);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  clock.advance_ms(MockManipulator::kTaskDurationMs - 1);
  EXPECT_EQ(phase(), ArmPhase::kBusy);
  clock.advance_ms(1);
  EXPECT_EQ(phase(), ArmPhase::kDone);
  EXPECT_EQ(a.tasks_started(), 1U);
}

TEST_F(ArmMock, StuckStaysBusyUntilStopped) {
  MockManipulator& a = arm(MockFault::kStuck);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  clock.advance_ms(3600e3);  // an hour
  EXPECT_EQ(phase(), ArmPhase::kBusy);
  ASSERT_TRUE(a.stop().ok());
  EXPECT_EQ(phase(), ArmPhase::kIdle);
  EXPECT_EQ(a.stops(), 1U);
}

TEST_F(ArmMock, SlowFinishesAfterFourTimesSlowMs) {
  MockManipulator& a = arm(MockFault::kSlow);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  clock.advance_ms(4 * kSlowMs - 1);
  EXPECT_EQ(phase(), ArmPhase::kBusy);
  clock.advance_ms(1);
  EXPECT_EQ(phase(), ArmPhase::kDone);
}

TEST_F(ArmMock, ErrorCodeRejectsEveryTask) {
  MockManipulator& a = arm(MockFault::kErrorCode);
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(a.hand_off(sample_task()).ok());
    EXPECT_EQ(phase(), ArmPhase::kFault);  // at once
    EXPECT_EQ(a.status().last_error, ErrorCode::kArmRejected);
    ASSERT_TRUE(a.clear_fault().ok());
    EXPECT_EQ(phase(), ArmPhase::kIdle);
  }
}

TEST_F(ArmMock, IntermittentFailsEverySecondTask) {
  MockManipulator& a = arm(MockFault::kIntermittent);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  clock.advance_ms(MockManipulator::kTaskDurationMs);
  EXPECT_EQ(phase(), ArmPhase::kDone);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  clock.advance_ms(MockManipulator::kTaskDurationMs);
  EXPECT_EQ(phase(), ArmPhase::kFault);
  EXPECT_EQ(a.status().last_error, ErrorCode::kArmTimeout);
  ASSERT_TRUE(a.clear_fault().ok());
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  clock.advance_ms(MockManipulator::kTaskDurationMs);
  EXPECT_EQ(phase(), ArmPhase::kDone);
}

TEST_F(ArmMock, GarbageEndsInTimeoutAfterSlowMs) {
  MockManipulator& a = arm(MockFault::kGarbage);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  clock.advance_ms(kSlowMs - 1);
  EXPECT_EQ(phase(), ArmPhase::kBusy);
  clock.advance_ms(1);
  EXPECT_EQ(phase(), ArmPhase::kFault);
  EXPECT_EQ(a.status().last_error, ErrorCode::kArmTimeout);
}

TEST_F(ArmMock, FaultCanBeChangedAtRunTime) {
  MockManipulator& a = arm(MockFault::kErrorCode);
  a.set_fault(MockFault::kNone);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  clock.advance_ms(MockManipulator::kTaskDurationMs);
  EXPECT_EQ(phase(), ArmPhase::kDone);
}

TEST_F(ArmMock, ScriptedRefusalFailsOnlyTheNextCallAndCallsAreLogged) {
  MockManipulator& a = arm(MockFault::kNone);
  a.fail_next_call(make_error(ErrorCode::kArmTimeout, "", "no ack"));
  const auto refused = a.hand_off(sample_task());
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kArmTimeout);
  EXPECT_EQ(phase(), ArmPhase::kIdle);  // nothing happened
  EXPECT_EQ(a.tasks_started(), 0U);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  ASSERT_TRUE(a.stop().ok());
  const std::vector<std::string> expected{"connect", "hand_off", "hand_off", "stop"};
  EXPECT_EQ(a.calls(), expected);
  EXPECT_EQ(a.count("hand_off"), 2U);
  EXPECT_EQ(a.count("clear_fault"), 0U);
  ASSERT_EQ(a.tasks().size(), 1U);
  EXPECT_EQ(a.tasks()[0].door_width_m, sample_task().door_width_m);
}

// set_phase: the test decides how a stuck task ends, as the arm's controller would report it.
TEST_F(ArmMock, SetPhaseReportsWhatTheTestSays) {
  MockManipulator& a = arm(MockFault::kStuck);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  a.set_phase(ArmPhase::kFault, ErrorCode::kArmRejected);
  EXPECT_EQ(phase(), ArmPhase::kFault);
  EXPECT_EQ(a.status().last_error, ErrorCode::kArmRejected);
  EXPECT_FALSE(a.hand_off(sample_task()).ok());  // faulted: clear it first
  ASSERT_TRUE(a.clear_fault().ok());
  EXPECT_EQ(phase(), ArmPhase::kIdle);
  ASSERT_TRUE(a.hand_off(sample_task()).ok());
  a.set_phase(ArmPhase::kIdle);  // its controller was reset mid-task
  clock.advance_ms(MockManipulator::kTaskDurationMs * 10);
  EXPECT_EQ(phase(), ArmPhase::kIdle);
  a.set_phase(ArmPhase::kBusy);  // set busy: never ends by time
  clock.advance_ms(MockManipulator::kTaskDurationMs * 10);
  EXPECT_EQ(phase(), ArmPhase::kBusy);
  EXPECT_EQ(a.count("clear_fault"), 1U);
}

// The config's fault words run the same faults by time (drivers.mock.arm_fault).
TEST(ArmMockControllerFaults, RunByTimeUnderTheConfigWords) {
  FakeClock fake;
  const auto clock = fake.clock();
  const auto ms = [&fake](int n) { fake.advance_ns(std::int64_t{n} * 1'000'000); };
  const int half = MockManipulator::kTaskDurationMs / 2;
  {
    MockManipulator a(MockArmFault::kSilentMidTask, 10, clock);
    ASSERT_TRUE(a.connect().ok());
    ASSERT_TRUE(a.hand_off(DoorTask{}).ok());
    ms(half);
    EXPECT_TRUE(a.silent());
    EXPECT_EQ(a.status().phase, ArmPhase::kBusy);  // the driver still retries
    ms(10);
    EXPECT_EQ(a.status().phase, ArmPhase::kDisconnected);
    EXPECT_EQ(a.status().last_error, ErrorCode::kArmTimeout);
    EXPECT_TRUE(a.stop().ok());  // queued, owed
    ms(3600'000);
    EXPECT_EQ(a.status().phase, ArmPhase::kDisconnected);
    a.answer_again();
    EXPECT_EQ(a.status().phase, ArmPhase::kIdle);
  }
  {
    MockManipulator a(MockArmFault::kSilentMidStop, 10, clock);
    ASSERT_TRUE(a.connect().ok());
    ASSERT_TRUE(a.hand_off(DoorTask{}).ok());
    ms(3600'000);
    EXPECT_EQ(a.status().phase, ArmPhase::kBusy);
    EXPECT_TRUE(a.stop().ok());
    EXPECT_TRUE(a.silent());
    ms(10);
    EXPECT_EQ(a.status().phase, ArmPhase::kDisconnected);
    a.set_fault(MockArmFault::kNone);  // answers again: the stop acts
    EXPECT_EQ(a.status().phase, ArmPhase::kIdle);
  }
  {
    MockManipulator a(MockArmFault::kResetMidTask, 10, clock);
    ASSERT_TRUE(a.connect().ok());
    ASSERT_TRUE(a.hand_off(DoorTask{}).ok());
    ms(half - 1);
    EXPECT_EQ(a.status().phase, ArmPhase::kBusy);
    ms(1);
    EXPECT_EQ(a.status().phase, ArmPhase::kIdle);
    EXPECT_EQ(a.status().task_id, 0U);
  }
  {
    MockManipulator a(MockArmFault::kStopIgnored, 10, clock);
    ASSERT_TRUE(a.connect().ok());
    ASSERT_TRUE(a.hand_off(DoorTask{}).ok());
    EXPECT_TRUE(a.stop().ok());
    ms(3600'000);
    EXPECT_EQ(a.status().phase, ArmPhase::kBusy);
    EXPECT_EQ(a.stops(), 1U);
  }
}

}  // namespace
}  // namespace ajar::drivers
