// MockMotionCard's fault menu (the normal behaviour is covered by the contract tests).
#include <gtest/gtest.h>

#include <array>
#include <set>

#include "ajar/drivers/mock_card.hpp"
#include "card_test_support.hpp"
#include "fake_clock.hpp"

namespace ajar::drivers {
namespace {

using ajar::testing::FakeClock;
using testing::status_of;

using testing::kWheels;
constexpr AxisMove kLeftWheelMove[] = {{1, 500}};

// A trapezoidal profile whose moves take a known time: 1 count/ms cruising, 0.01 count/ms^2 ramps
// (each ramp 100 ms and 50 counts). A move of D >= 100 counts takes (D - 100) + 200 ms.
constexpr TrapezoidProfile kSlowProfile{1, 0.01, 0.01, 0};

std::unique_ptr<MockMotionCard> ready_card(FakeClock& clock, MockFault fault, int slow_ms = 0) {
  auto card = std::make_unique<MockMotionCard>(MockFault::kNone, slow_ms, 1.0, 4, clock.clock());
  EXPECT_TRUE(card->open().ok());
  EXPECT_TRUE(card->enable_axes(kWheels) == ErrorCode::kOk);
  card->set_fault(fault);
  return card;
}

TEST(MockCardFaults, StuckAcceptsMovesThatNeverProgressUntilStopped) {
  FakeClock clock;
  auto card = ready_card(clock, MockFault::kStuck);
  ASSERT_TRUE(card->move_relative(kLeftWheelMove, kSlowProfile) == ErrorCode::kOk);
  clock.advance_ms(24 * 3600e3);  // a day: the 600 ms move would have finished many times over
  EXPECT_TRUE(status_of(*card, 1)->moving);
  EXPECT_EQ(status_of(*card, 1)->profile_position_counts, 0);
  ASSERT_TRUE(card->smooth_stop(kWheels) == ErrorCode::kOk);
  EXPECT_FALSE(status_of(*card, 1)->moving);
}

TEST(MockCardFaults, SlowStillWorks) {
  FakeClock clock;
  auto card = ready_card(clock, MockFault::kSlow, 1);
  const auto before = card->calls();
  ASSERT_TRUE(card->move_relative(kLeftWheelMove, kSlowProfile) == ErrorCode::kOk);
  clock.advance_ms(600);  // the move's duration (kSlowProfile)
  EXPECT_FALSE(status_of(*card, 1)->moving);
  EXPECT_EQ(status_of(*card, 1)->profile_position_counts, 500);
  EXPECT_GT(card->calls(), before);
}

TEST(MockCardFaults, ErrorCodeFailsEverythingButOpenAndClose) {
  FakeClock clock;
  auto card = ready_card(clock, MockFault::kErrorCode);
  EXPECT_EQ(card->move_relative(kLeftWheelMove, TrapezoidProfile{}), ErrorCode::kDriverError);
  AxisStatus st;
  EXPECT_EQ(card->axis_status(1, st), ErrorCode::kDriverError);
  EXPECT_EQ(card->smooth_stop(kWheels), ErrorCode::kDriverError);
  EXPECT_EQ(card->enable_axes(kWheels), ErrorCode::kDriverError);
  EXPECT_TRUE(card->close().ok());
  EXPECT_TRUE(card->open().ok());
}

TEST(MockCardFaults, IntermittentFailsEveryThirdCall) {
  FakeClock clock;
  auto card = ready_card(clock, MockFault::kIntermittent);
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
  FakeClock clock;
  auto card = ready_card(clock, MockFault::kGarbage);
  std::set<std::int64_t> positions;
  for (int i = 0; i < 5; ++i) {
    const AxisStatus st = *status_of(*card, 1);
    EXPECT_TRUE(st.moving && st.in_position);  // contradictory
    EXPECT_NE(st.encoder_position_counts, st.profile_position_counts);
    positions.insert(st.profile_position_counts);
  }
  EXPECT_GT(positions.size(), 1U);  // jumps while nothing was commanded
  EXPECT_TRUE(card->move_relative(kLeftWheelMove, TrapezoidProfile{}) == ErrorCode::kOk);
}

TEST(MockCardTime, MovesTakeTheirSimulatedDuration) {
  FakeClock clock;
  auto card = ready_card(clock, MockFault::kNone);
  const AxisMove move[] = {{1, 10'000}};  // 10 100 ms with kSlowProfile
  ASSERT_TRUE(card->move_relative(move, kSlowProfile) == ErrorCode::kOk);
  clock.advance_ms(100);  // end of the ramp: 50 counts
  EXPECT_EQ(status_of(*card, 1)->profile_position_counts, 50);
  clock.advance_ms(4900);  // cruising at 1 count/ms
  EXPECT_EQ(status_of(*card, 1)->profile_position_counts, 4950);
  clock.advance_ms(5099);  // 1 ms before the end
  EXPECT_TRUE(status_of(*card, 1)->moving);
  clock.advance_ms(1);
  const AxisStatus st = *status_of(*card, 1);
  EXPECT_FALSE(st.moving);
  EXPECT_TRUE(st.in_position);
  EXPECT_EQ(st.profile_position_counts, 10'000);
}

TEST(MockCardTime, TimeScaleSpeedsTheClockUp) {
  FakeClock clock;
  MockMotionCard card(MockFault::kNone, 0, 1000.0, 4, clock.clock());
  ASSERT_TRUE(card.open().ok());
  ASSERT_TRUE(card.enable_axes(kWheels) == ErrorCode::kOk);
  const AxisMove move[] = {{1, 10'000}};
  ASSERT_TRUE(card.move_relative(move, kSlowProfile) == ErrorCode::kOk);
  clock.advance_ms(5);  // 5 s of simulated time
  EXPECT_EQ(status_of(card, 1)->profile_position_counts, 4950);
  clock.advance_ms(5.1);
  EXPECT_FALSE(status_of(card, 1)->moving);
}

}  // namespace
}  // namespace ajar::drivers
