// The Manipulator contract, run against every implementation: the in-process mock, and the real
// serial driver over the arm-controller simulator on a pseudo-terminal (which is also what the
// `sim` driver set runs).
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <thread>

#include "ajar/drivers/mock_arm.hpp"
#include "arm_test_support.hpp"

namespace ajar::drivers {
namespace {

using test::sample_task;
using test::wait_phase;

enum class Scenario { kNormal, kLongTasks, kRefuseTasks };

struct MockArm {
  void make(Scenario s) {
    const MockFault fault = s == Scenario::kLongTasks     ? MockFault::kStuck
                            : s == Scenario::kRefuseTasks ? MockFault::kErrorCode
                                                          : MockFault::kNone;
    arm = std::make_unique<MockManipulator>(fault, 5);
  }
  Manipulator& get() { return *arm; }
  std::unique_ptr<MockManipulator> arm;
};

struct SerialArmOverSimulator {
  void make(Scenario s) {
    ArmSimulatorSettings sim;
    sim.task_duration_ms = s == Scenario::kLongTasks ? 600'000 : 30;
    rig = std::make_unique<test::SerialRig>(sim);
    rig->sim->set_refuse_tasks(s == Scenario::kRefuseTasks);
  }
  Manipulator& get() { return *rig->arm; }
  std::unique_ptr<test::SerialRig> rig;
};

template <typename Impl>
class ArmContract : public ::testing::Test {
 protected:
  Manipulator& make(Scenario s = Scenario::kNormal) {
    impl_.make(s);
    return impl_.get();
  }
  Manipulator& connected(Scenario s = Scenario::kNormal) {
    Manipulator& arm = make(s);
    const auto st = arm.connect();
    EXPECT_TRUE(st.ok()) << st.error().message;
    return arm;
  }

 private:
  Impl impl_;
};

using ArmImplementations = ::testing::Types<MockArm, SerialArmOverSimulator>;
class ImplNames {
 public:
  template <typename T>
  static std::string GetName(int) {
    return std::is_same_v<T, MockArm> ? "Mock" : "SerialOverSimulator";
  }
};
TYPED_TEST_SUITE(ArmContract, ArmImplementations, ImplNames);

TYPED_TEST(ArmContract, StartsDisconnectedAndRefusesHandOff) {
  Manipulator& arm = this->make();
  EXPECT_EQ(arm.status().phase, ArmPhase::kDisconnected);
  auto id = arm.hand_off(sample_task());
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.error().code, ErrorCode::kArmDisconnected);
}

TYPED_TEST(ArmContract, ConnectGivesIdle) {
  Manipulator& arm = this->connected();
  const ArmStatus s = arm.status();
  EXPECT_EQ(s.phase, ArmPhase::kIdle);
  EXPECT_EQ(s.last_error, ErrorCode::kOk);
  EXPECT_TRUE(arm.connect().ok()) << "connect() twice is harmless";
}

TYPED_TEST(ArmContract, HandOffCompletesWithItsId) {
  Manipulator& arm = this->connected();
  auto id = arm.hand_off(sample_task());
  ASSERT_TRUE(id.ok()) << id.error().message;
  EXPECT_NE(id.value(), 0U);
  EXPECT_EQ(arm.status().task_id, id.value());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kDone));
  EXPECT_EQ(arm.status().task_id, id.value());
  EXPECT_EQ(arm.status().last_error, ErrorCode::kOk);
}

TYPED_TEST(ArmContract, NextTaskGetsANewId) {
  Manipulator& arm = this->connected();
  auto first = arm.hand_off(sample_task());
  ASSERT_TRUE(first.ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kDone));
  auto second = arm.hand_off(sample_task());
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_NE(second.value(), first.value());
  ASSERT_TRUE(test::wait_for([&] {
    const auto s = arm.status();
    return s.phase == ArmPhase::kDone && s.task_id == second.value();
  }));
}

TYPED_TEST(ArmContract, HandOffWhileBusyIsRefused) {
  Manipulator& arm = this->connected(Scenario::kLongTasks);
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  EXPECT_EQ(arm.status().phase, ArmPhase::kBusy);
  auto again = arm.hand_off(sample_task());
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.error().code, ErrorCode::kWrongState);
}

TYPED_TEST(ArmContract, StopEndsATaskAndANewOneIsAccepted) {
  Manipulator& arm = this->connected(Scenario::kLongTasks);
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(arm.stop().ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kIdle));
  auto next = arm.hand_off(sample_task());
  EXPECT_TRUE(next.ok()) << next.error().message;
  EXPECT_EQ(arm.status().phase, ArmPhase::kBusy);
  EXPECT_TRUE(arm.stop().ok());
}

// A done arm may still be at the door: a stop sends it back to rest (idle), which is the word the
// daemon moves the base on (docs/procedure.md, "The arm interlock").
TYPED_TEST(ArmContract, StopAfterADoneTaskReturnsToIdle) {
  Manipulator& arm = this->connected();
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kDone));
  ASSERT_TRUE(arm.stop().ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kIdle));
}

TYPED_TEST(ArmContract, StopWhenIdleIsAccepted) {
  Manipulator& arm = this->connected();
  EXPECT_TRUE(arm.stop().ok());
  EXPECT_NE(arm.status().phase, ArmPhase::kFault);
}

TYPED_TEST(ArmContract, RefusedTaskFaultsUntilCleared) {
  Manipulator& arm = this->connected(Scenario::kRefuseTasks);
  ASSERT_TRUE(arm.hand_off(sample_task()).ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kFault));
  EXPECT_EQ(arm.status().last_error, ErrorCode::kArmRejected);
  auto again = arm.hand_off(sample_task());
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.error().code, ErrorCode::kWrongState);
  ASSERT_TRUE(arm.clear_fault().ok());
  ASSERT_TRUE(wait_phase(arm, ArmPhase::kIdle));
  EXPECT_EQ(arm.status().last_error, ErrorCode::kOk);
}

TYPED_TEST(ArmContract, DisconnectGivesDisconnected) {
  Manipulator& arm = this->connected();
  ASSERT_TRUE(arm.disconnect().ok());
  EXPECT_EQ(arm.status().phase, ArmPhase::kDisconnected);
  auto id = arm.hand_off(sample_task());
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.error().code, ErrorCode::kArmDisconnected);
  EXPECT_TRUE(arm.disconnect().ok()) << "disconnect() twice is harmless";
  ASSERT_TRUE(arm.connect().ok()) << "and it connects again";
  EXPECT_TRUE(wait_phase(arm, ArmPhase::kIdle));
}

TYPED_TEST(ArmContract, CallsFromSeveralThreadsAreSafe) {
  Manipulator& arm = this->connected();
  std::atomic<bool> done{false};
  std::atomic<int> reads{0};
  std::thread reader([&] {
    while (!done.load()) {
      const ArmStatus s = arm.status();
      if (s.phase != ArmPhase::kDisconnected) reads.fetch_add(1);
      (void)arm.clear_fault();  // harmless when not faulted
    }
  });
  for (int i = 0; i < 3; ++i) {
    auto id = arm.hand_off(sample_task());
    ASSERT_TRUE(id.ok()) << id.error().message;
    ASSERT_TRUE(test::wait_for([&] {
      const auto s = arm.status();
      return s.phase == ArmPhase::kDone && s.task_id == id.value();
    }));
  }
  done = true;
  reader.join();
  EXPECT_GT(reads.load(), 0);
}

}  // namespace
}  // namespace ajar::drivers
