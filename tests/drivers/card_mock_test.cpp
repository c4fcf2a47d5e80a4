// MockMotionCard's fault menu (the normal behaviour is covered by the contract tests).
#include <gtest/gtest.h>

#include <array>
#include <set>

#include "ajar/drivers/mock_card.hpp"
#include "card_test_support.hpp"

namespace ajar::drivers {
namespace {

using testing::kFastTimeScale;
using testing::status_of;
using testing::wait_until;

constexpr std::array<int, 2> kWheels{1, 2};
constexpr AxisMove kMove[] = {{1, 500}};

std::unique_ptr<MockMotionCard> ready_card(MockFault fault, int slow_ms = 0) {
  auto card = std::make_unique<MockMotionCard>(MockFault::kOff, slow_ms, kFastTimeScale, 4);
  EXPECT_TRUE(card->open().ok());
  EXPECT_TRUE(card->enable_axes(kWheels) == ErrorCode::kOk);
  card->set_fault(fault);
  return card;
}

TEST(MockCardFaults, StuckAcceptsMovesThatNeverProgressUntilStopped) {
  auto card = ready_card(MockFault::kStuck);
  ASSERT_TRUE(card->move_relative(kMove, TrapezoidProfile{}) == ErrorCode::kOk);
  // Long enough in simulated time for the move to have finished many times over.
  EXPECT_FALSE(
      wait_until([&] { return !status_of(*card, 1)->moving; }, std::chrono::milliseconds(50)));
  EXPECT_EQ(status_of(*card, 1)->profile_position_counts, 0);
  ASSERT_TRUE(card->smooth_stop(kWheels) == ErrorCode::kOk);
  EXPECT_FALSE(status_of(*card, 1)->moving);
}

TEST(MockCardFaults, SlowStillWorks) {
  auto card = ready_card(MockFault::kSlow, 2);
  const auto before = card->calls();
  ASSERT_TRUE(card->move_relative(kMove, TrapezoidProfile{}) == ErrorCode::kOk);
  ASSERT_TRUE(wait_until([&] { return !status_of(*card, 1)->moving; }));
  EXPECT_EQ(status_of(*card, 1)->profile_position_counts, 500);
  EXPECT_GT(card->calls(), before);
}

TEST(MockCardFaults, ErrorCodeFailsEverythingButOpenAndClose) {
  auto card = ready_card(MockFault::kErrorCode);
  EXPECT_EQ(card->move_relative(kMove, TrapezoidProfile{}), ErrorCode::kDriverError);
  AxisStatus st;
  EXPECT_EQ(card->axis_status(1, st), ErrorCode::kDriverError);
  EXPECT_EQ(card->smooth_stop(kWheels), ErrorCode::kDriverError);
  EXPECT_EQ(card->enable_axes(kWheels), ErrorCode::kDriverError);
  EXPECT_TRUE(card->close().ok());
  EXPECT_TRUE(card->open().ok());
}

TEST(MockCardFaults, IntermittentFailsEveryThirdCall) {
  auto card = ready_card(MockFault::kIntermittent);
  int failures = 0;
  for (int i = 0; i < 9; ++i) {
    AxisStatus st;
    const ErrorCode e = card->axis_status(1, st);
    if (e != ErrorCode::kOk) {
      ++failures;
      EXPECT_EQ(e, ErrorCode::kCardCommunication);
      EXPECT_EQ(card->last_failure().code, ErrorCode::kCardCommunication);
    }
  }
  EXPECT_EQ(failures, 3);
}

TEST(MockCardFaults, GarbageReportsImplausibleStatus) {
  auto card = ready_card(MockFault::kGarbage);
  std::set<std::int64_t> positions;
  for (int i = 0; i < 5; ++i) {
    const AxisStatus st = *status_of(*card, 1);
    EXPECT_TRUE(st.moving && st.in_position);  // contradictory
    EXPECT_NE(st.encoder_position_counts, st.profile_position_counts);
    positions.insert(st.profile_position_counts);
  }
  EXPECT_GT(positions.size(), 1U);  // jumps while nothing was commanded
  EXPECT_TRUE(card->move_relative(kMove, TrapezoidProfile{}) == ErrorCode::kOk);
}

TEST(MockCardTime, MovesTakeTheirSimulatedDuration) {
  // At real-time speed, a 10^8-count move at 1 count/ms takes about a day: it is running now.
  MockMotionCard card(MockFault::kOff, 0, 1.0, 4);
  ASSERT_TRUE(card.open().ok());
  ASSERT_TRUE(card.enable_axes(kWheels) == ErrorCode::kOk);
  const AxisMove far[] = {{1, 100'000'000}};
  ASSERT_TRUE(card.move_relative(far, TrapezoidProfile{1, 0.01, 0.01, 0}) == ErrorCode::kOk);
  const AxisStatus st = *status_of(card, 1);
  EXPECT_TRUE(st.moving);
  EXPECT_LT(st.profile_position_counts, 100'000'000);
}

}  // namespace
}  // namespace ajar::drivers
