// The lifecycle wrapper: order enforcement, stops always passing, and which errors latch kFault.
#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "ajar/drivers/lifecycle.hpp"
#include "ajar/drivers/mock_arm.hpp"
#include "ajar/drivers/mock_card.hpp"
#include "card_test_support.hpp"
#include "fake_clock.hpp"

namespace ajar::drivers {
namespace {

using testing::kFastTimeScale;
using testing::status_of;

using testing::kWheels;

class ManagedCard : public ::testing::Test {
 protected:
  ManagedCard() {
    auto mock = std::make_unique<MockMotionCard>(MockFault::kNone, 0, kFastTimeScale, 4);
    mock_ = mock.get();
    card_ = std::make_unique<ManagedMotionCard>(std::move(mock), kWheels);
  }
  ErrorCode move(std::int64_t distance = 100) {
    const AxisMove moves[] = {{1, distance}, {2, distance}};
    return card_->move_relative(moves, TrapezoidProfile{1, 0.5, 0.5, 0});
  }

  MockMotionCard* mock_ = nullptr;
  std::unique_ptr<ManagedMotionCard> card_;
};

TEST_F(ManagedCard, EnforcesTheOrderOfTransitions) {
  EXPECT_EQ(card_->state(), LifecycleState::kUnconfigured);
  EXPECT_EQ(card_->activate().error().code, ErrorCode::kWrongState);
  EXPECT_EQ(card_->deactivate().error().code, ErrorCode::kWrongState);
  EXPECT_EQ(card_->cleanup().error().code, ErrorCode::kWrongState);
  EXPECT_EQ(card_->recover().error().code, ErrorCode::kWrongState);
  EXPECT_EQ(move(), ErrorCode::kDriverNotActive);
  EXPECT_EQ(card_->state(), LifecycleState::kUnconfigured);

  ASSERT_TRUE(card_->configure().ok());
  EXPECT_EQ(card_->state(), LifecycleState::kInactive);
  EXPECT_EQ(card_->configure().error().code, ErrorCode::kWrongState);
  EXPECT_EQ(card_->deactivate().error().code, ErrorCode::kWrongState);
  EXPECT_EQ(move(), ErrorCode::kDriverNotActive);
  EXPECT_FALSE(status_of(*card_, 1)->moving);

  ASSERT_TRUE(card_->activate().ok());
  EXPECT_EQ(card_->state(), LifecycleState::kActive);
  EXPECT_TRUE(status_of(*card_, 1)->enabled);
  EXPECT_TRUE(status_of(*card_, 2)->enabled);
  EXPECT_FALSE(status_of(*card_, 3)->enabled);  // only the managed axes
  EXPECT_EQ(card_->activate().error().code, ErrorCode::kWrongState);
  EXPECT_EQ(card_->cleanup().error().code, ErrorCode::kWrongState);
  ASSERT_TRUE(move() == ErrorCode::kOk);

  ASSERT_TRUE(card_->deactivate().ok());
  EXPECT_EQ(card_->state(), LifecycleState::kInactive);
  EXPECT_FALSE(status_of(*card_, 1)->enabled);
  EXPECT_FALSE(status_of(*card_, 1)->moving);
  EXPECT_EQ(move(), ErrorCode::kDriverNotActive);

  ASSERT_TRUE(card_->cleanup().ok());
  EXPECT_EQ(card_->state(), LifecycleState::kUnconfigured);
  EXPECT_FALSE(status_of(*card_, 1).has_value());  // the card is closed
}

TEST_F(ManagedCard, StopsAreNeverRefused) {
  ASSERT_TRUE(card_->configure().ok());
  EXPECT_TRUE(card_->smooth_stop(kWheels) == ErrorCode::kOk);
  EXPECT_TRUE(card_->emergency_stop(kWheels) == ErrorCode::kOk);
  ASSERT_TRUE(card_->activate().ok());
  mock_->inject_alarm(1);
  (void)status_of(*card_, 1);
  ASSERT_EQ(card_->state(), LifecycleState::kFault);
  EXPECT_TRUE(card_->smooth_stop(kWheels) == ErrorCode::kOk);
  EXPECT_TRUE(card_->emergency_stop(kWheels) == ErrorCode::kOk);
}

TEST_F(ManagedCard, DeactivateStopsARunningMoveBeforeDisabling) {
  ASSERT_TRUE(card_->configure().ok());
  ASSERT_TRUE(card_->activate().ok());
  ASSERT_TRUE(move(100'000'000) == ErrorCode::kOk);
  ASSERT_TRUE(status_of(*card_, 1)->moving);
  ASSERT_TRUE(card_->deactivate().ok());
  const AxisStatus st = *status_of(*card_, 1);
  EXPECT_FALSE(st.moving);
  EXPECT_FALSE(st.enabled);
  EXPECT_TRUE(st.smooth_stopped);
  EXPECT_FALSE(st.emergency_stopped);
}

TEST(ManagedCardDeadline, DeactivateFallsBackToEmergencyStopAfterItsDeadline) {
  // A fake clock that stands still while deactivate() waits: the smooth stop (a deceleration that
  // would take ~100 s) cannot finish within the 0 ms stop deadline.
  ajar::testing::FakeClock clock;
  auto mock = std::make_unique<MockMotionCard>(MockFault::kNone, 0, 1.0, 4, clock.clock());
  ManagedMotionCard card(std::move(mock), kWheels, 0);
  ASSERT_TRUE(card.configure().ok());
  ASSERT_TRUE(card.activate().ok());
  const AxisMove moves[] = {{1, 100'000'000}};
  ASSERT_TRUE(card.move_relative(moves, TrapezoidProfile{10, 100, 0.0001, 0}) == ErrorCode::kOk);
  clock.advance_ms(1);
  ASSERT_GT(status_of(card, 1)->profile_position_counts, 0);
  const auto s = card.deactivate();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kMotionTimeout);
  EXPECT_EQ(card.state(), LifecycleState::kInactive);
  const AxisStatus st = *status_of(card, 1);
  EXPECT_FALSE(st.moving);
  EXPECT_TRUE(st.emergency_stopped);
  EXPECT_FALSE(st.enabled);
}

TEST_F(ManagedCard, HardwareFaultsLatchAndRecoverNeedsHealthyAxes) {
  ASSERT_TRUE(card_->configure().ok());
  ASSERT_TRUE(card_->activate().ok());
  mock_->inject_following_error(2);
  EXPECT_TRUE(status_of(*card_, 2)->following_error);
  EXPECT_EQ(card_->state(), LifecycleState::kFault);
  EXPECT_EQ(move(), ErrorCode::kFollowingError);  // refused with the root cause
  EXPECT_EQ(card_->activate().error().code, ErrorCode::kWrongState);
  ASSERT_TRUE(card_->recover().ok());  // clear_faults clears the mock's latch
  EXPECT_EQ(card_->state(), LifecycleState::kInactive);
  ASSERT_TRUE(card_->activate().ok());
  EXPECT_TRUE(move() == ErrorCode::kOk);
}

TEST_F(ManagedCard, ErrorsOfTheCallerOrTheSituationDoNotLatch) {
  ASSERT_TRUE(card_->configure().ok());
  ASSERT_TRUE(card_->activate().ok());
  const AxisMove bad[] = {{7, 100}};
  EXPECT_EQ(card_->move_relative(bad, TrapezoidProfile{}), ErrorCode::kCardBadParameter);
  mock_->inject_limit(1, true);
  EXPECT_EQ(move(), ErrorCode::kLimitHit);
  ASSERT_TRUE(card_->emergency_stop(kWheels) == ErrorCode::kOk);
  EXPECT_EQ(move(-100), ErrorCode::kEmergencyStopped);
  EXPECT_EQ(card_->state(), LifecycleState::kActive);
}

TEST_F(ManagedCard, CommunicationFailuresLatch) {
  ASSERT_TRUE(card_->configure().ok());
  ASSERT_TRUE(card_->activate().ok());
  mock_->set_fault(MockFault::kIntermittent);
  bool failed = false;
  for (int i = 0; i < 3 && !failed; ++i) {
    AxisStatus st;
    const ErrorCode e = card_->axis_status(1, st);
    failed = e != ErrorCode::kOk;
    if (failed) {
      EXPECT_EQ(e, ErrorCode::kCardCommunication);
    }
  }
  ASSERT_TRUE(failed);
  EXPECT_EQ(card_->state(), LifecycleState::kFault);
  // A move is then refused with the cause, CARD_COMMUNICATION (502), not DRIVER_NOT_ACTIVE (501):
  // a caller that latches what it is told reports why the card is unusable.
  mock_->set_fault(MockFault::kNone);
  EXPECT_EQ(move(), ErrorCode::kCardCommunication);
  EXPECT_STREQ(card_->last_failure().call, "move_relative");
  // Recovery (clear_faults in fault) makes it usable again once the card answers.
  ASSERT_EQ(card_->clear_faults(kWheels), ErrorCode::kOk);
  EXPECT_EQ(card_->state(), LifecycleState::kInactive);
  EXPECT_EQ(move(), ErrorCode::kDriverNotActive);
}

TEST_F(ManagedCard, RealtimeCallsKeepTheirFailureDetailWithoutText) {
  EXPECT_EQ(move(), ErrorCode::kDriverNotActive);
  CardFailure f = card_->last_failure();
  EXPECT_EQ(f.code, ErrorCode::kDriverNotActive);
  EXPECT_STREQ(f.call, "move_relative");
  EXPECT_NE(describe(f).find("unconfigured"), std::string::npos) << describe(f);
  ASSERT_TRUE(card_->configure().ok());
  ASSERT_TRUE(card_->activate().ok());
  const AxisMove bad[] = {{7, 100}};
  EXPECT_EQ(card_->move_relative(bad, TrapezoidProfile{}), ErrorCode::kCardBadParameter);
  f = card_->last_failure();  // the implementation's detail, passed through
  EXPECT_EQ(f.axis, 7);
  EXPECT_EQ(describe(f), "move_relative: axis 7: axis outside 1..axis_count of the card");
}

TEST_F(ManagedCard, TheMotionCardInterfaceDrivesTheLifecycle) {
  ASSERT_TRUE(card_->open().ok());
  EXPECT_EQ(card_->state(), LifecycleState::kInactive);
  ASSERT_TRUE(card_->enable_axes(kWheels) == ErrorCode::kOk);
  EXPECT_EQ(card_->state(), LifecycleState::kActive);
  ASSERT_TRUE(card_->disable_axes(kWheels) == ErrorCode::kOk);
  EXPECT_EQ(card_->state(), LifecycleState::kInactive);
  ASSERT_TRUE(card_->enable_axes(kWheels) == ErrorCode::kOk);
  ASSERT_TRUE(move(100'000'000) == ErrorCode::kOk);
  ASSERT_TRUE(card_->close().ok());  // deactivates (stops) first
  EXPECT_EQ(card_->state(), LifecycleState::kUnconfigured);
}

TEST(ManagedCardOpen, AFailedConfigureStaysUnconfigured) {
  auto mock = std::make_unique<MockMotionCard>();
  mock->set_open_fails(true);
  ManagedMotionCard failing(std::move(mock), kWheels);
  EXPECT_EQ(failing.configure().error().code, ErrorCode::kCardOpenFailed);
  EXPECT_EQ(failing.state(), LifecycleState::kUnconfigured);
}

// --- ManagedManipulator over the mock arm (its call log and scripted refusals) ----------------

TEST(ManagedArm, EnforcesTheOrderAndPassesStops) {
  auto mock = std::make_unique<MockManipulator>();
  ASSERT_TRUE(mock->connect().ok());  // so that its stop() succeeds before configure()
  MockManipulator* log = mock.get();
  ManagedManipulator arm(std::move(mock));
  EXPECT_EQ(arm.hand_off(DoorTask{}).error().code, ErrorCode::kDriverNotActive);
  EXPECT_EQ(arm.activate().error().code, ErrorCode::kWrongState);
  EXPECT_TRUE(arm.stop().ok());  // stopping is never refused
  ASSERT_TRUE(arm.configure().ok());
  EXPECT_EQ(arm.hand_off(DoorTask{}).error().code, ErrorCode::kDriverNotActive);
  ASSERT_TRUE(arm.activate().ok());
  const auto id = arm.hand_off(DoorTask{});
  ASSERT_TRUE(id.ok());
  EXPECT_EQ(*id, 1U);
  EXPECT_EQ(arm.cleanup().error().code, ErrorCode::kWrongState);
  ASSERT_TRUE(arm.deactivate().ok());
  EXPECT_EQ(arm.hand_off(DoorTask{}).error().code, ErrorCode::kDriverNotActive);
  ASSERT_TRUE(arm.cleanup().ok());
  EXPECT_EQ(arm.state(), LifecycleState::kUnconfigured);
  const std::vector<std::string> expected{"connect",  "stop", "connect",
                                          "hand_off", "stop", "disconnect"};
  EXPECT_EQ(log->calls(), expected);
}

TEST(ManagedArm, BrokenImplementationLatchesButLinkTroubleDoesNot) {
  auto mock = std::make_unique<MockManipulator>(MockFault::kStuck);  // tasks stay busy
  MockManipulator* log = mock.get();
  ManagedManipulator arm(std::move(mock));
  ASSERT_TRUE(arm.connect().ok());
  ASSERT_TRUE(arm.activate().ok());
  log->fail_next_call(make_error(ErrorCode::kArmTimeout, "", "no ack"));
  EXPECT_EQ(arm.hand_off(DoorTask{}).error().code, ErrorCode::kArmTimeout);
  EXPECT_EQ(arm.state(), LifecycleState::kActive);
  log->fail_next_call(make_error(ErrorCode::kDriverError, "", "worker died"));
  EXPECT_EQ(arm.hand_off(DoorTask{}).error().code, ErrorCode::kDriverError);
  EXPECT_EQ(arm.state(), LifecycleState::kFault);
  EXPECT_EQ(arm.hand_off(DoorTask{}).error().code, ErrorCode::kDriverNotActive);
  EXPECT_TRUE(arm.stop().ok());
  ASSERT_TRUE(arm.clear_fault().ok());  // = recover()
  EXPECT_EQ(arm.state(), LifecycleState::kInactive);
  ASSERT_TRUE(arm.activate().ok());
  EXPECT_TRUE(arm.hand_off(DoorTask{}).ok());
  ASSERT_TRUE(arm.disconnect().ok());  // stops, then disconnects
  EXPECT_EQ(arm.state(), LifecycleState::kUnconfigured);
  const auto calls = log->calls();
  ASSERT_GE(calls.size(), 2U);
  EXPECT_EQ(calls.back(), "disconnect");
  EXPECT_EQ(calls[calls.size() - 2], "stop");
}

}  // namespace
}  // namespace ajar::drivers
