// MockManipulator's fault menu (settings.hpp MockFault), as the daemon tests rely on it.
#include <gtest/gtest.h>

#include "ajar/drivers/mock_arm.hpp"
#include "arm_test_support.hpp"

namespace ajar::drivers {
namespace {

using test::sample_task;
using test::wait_phase;

TEST(ArmMock, OffFinishesTasks) {
  MockManipulator arm(MockFault::kOff);
  ASSERT_TRUE(arm.connect().ok());
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  EXPECT_EQ(arm.status().phase, ArmPhase::kBusy);
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kDone));
  EXPECT_EQ(arm.tasks_started(), 1U);
}

TEST(ArmMock, StuckStaysBusyUntilStopped) {
  MockManipulator arm(MockFault::kStuck, 5);
  ASSERT_TRUE(arm.connect().ok());
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  // Well past the normal task duration it is still busy.
  EXPECT_FALSE(wait_phase(arm, ArmPhase::kDone,
                          std::chrono::milliseconds(10 * MockManipulator::kTaskDurationMs)));
  EXPECT_EQ(arm.status().phase, ArmPhase::kBusy);
  ASSERT_TRUE(arm.stop().ok());
  EXPECT_EQ(arm.status().phase, ArmPhase::kIdle);
  EXPECT_EQ(arm.stops(), 1U);
}

TEST(ArmMock, SlowFinishesEventually) {
  MockManipulator arm(MockFault::kSlow, 10);
  ASSERT_TRUE(arm.connect().ok());
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kDone));
}

TEST(ArmMock, ErrorCodeRejectsEveryTask) {
  MockManipulator arm(MockFault::kErrorCode);
  ASSERT_TRUE(arm.connect().ok());
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(arm.hand_off(sample_task()).ok());
    ASSERT_TRUE(wait_phase(arm, ArmPhase::kFault));
    EXPECT_EQ(arm.status().last_error, ErrorCode::kArmRejected);
    ASSERT_TRUE(arm.clear_fault().ok());
    EXPECT_EQ(arm.status().phase, ArmPhase::kIdle);
  }
}

TEST(ArmMock, IntermittentFailsEverySecondTask) {
  MockManipulator arm(MockFault::kIntermittent);
  ASSERT_TRUE(arm.connect().ok());
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kDone));
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kFault));
  EXPECT_EQ(arm.status().last_error, ErrorCode::kArmTimeout);
  ASSERT_TRUE(arm.clear_fault().ok());
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kDone));
}

TEST(ArmMock, GarbageEndsInTimeout) {
  MockManipulator arm(MockFault::kGarbage, 5);
  ASSERT_TRUE(arm.connect().ok());
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kFault));
  EXPECT_EQ(arm.status().last_error, ErrorCode::kArmTimeout);
}

TEST(ArmMock, FaultCanBeChangedAtRunTime) {
  MockManipulator arm(MockFault::kErrorCode);
  ASSERT_TRUE(arm.connect().ok());
  arm.set_fault(MockFault::kOff);
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kDone));
}

}  // namespace
}  // namespace ajar::drivers
