// The MotionCard contract, run against every implementation: the mock, the GTS driver over the
// card simulator library (the sim driver = the real driver over its simulator), and the lifecycle
// wrapper around each.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <memory>

#include "ajar/drivers/gts_card.hpp"
#include "ajar/drivers/gts_sim_control.hpp"
#include "ajar/drivers/lifecycle.hpp"
#include "ajar/drivers/mock_card.hpp"
#include "card_test_support.hpp"

namespace ajar::drivers {
namespace {

using testing::failure_text;
using testing::kFastTimeScale;
using testing::status_of;
using testing::wait_until;

using testing::kWheels;

// Each maker builds one implementation and injects hardware faults into it.
struct MockMaker {
  MockMotionCard* raw = nullptr;
  std::unique_ptr<MotionCard> make() {
    auto card = std::make_unique<MockMotionCard>(MockFault::kNone, 0, kFastTimeScale, 4);
    raw = card.get();
    return card;
  }
  void alarm(int axis) { raw->inject_alarm(axis); }
  void following_error(int axis) { raw->inject_following_error(axis); }
  void limit(int axis, bool positive) { raw->inject_limit(axis, positive); }
  void manual_clock() { raw->set_manual_clock(true); }
  void advance_ms(double ms) { raw->advance_clock_ns(std::llround(ms * 1e6)); }
};

struct SimMaker {
  std::unique_ptr<GtsSimControl> sim;
  std::unique_ptr<MotionCard> make() {
    sim = std::make_unique<GtsSimControl>(testing::card_sim_path());
    sim->reset();
    sim->set_time_scale(kFastTimeScale);
    return std::make_unique<GtsMotionCard>(testing::card_sim_settings());
  }
  void alarm(int axis) { sim->inject_fault(axis, SimFault::kDriveAlarm); }
  void following_error(int axis) { sim->inject_fault(axis, SimFault::kFollowingError); }
  void limit(int axis, bool positive) {
    sim->inject_fault(axis, positive ? SimFault::kPositiveLimit : SimFault::kNegativeLimit);
  }
  void manual_clock() { sim->set_manual_clock(1); }
  void advance_ms(double ms) { sim->advance_clock_ns(std::llround(ms * 1e6)); }
};

template <typename Inner>
struct ManagedMaker : Inner {
  std::unique_ptr<MotionCard> make() {
    return std::make_unique<ManagedMotionCard>(Inner::make(), kWheels);
  }
};

template <typename Maker>
class MotionCardContract : public ::testing::Test {
 protected:
  void SetUp() override { card_ = maker_.make(); }
  void TearDown() override { card_.reset(); }

  void open_and_enable() {
    ASSERT_TRUE(card_->open().ok());
    enable();
  }
  void enable() {
    const auto e = card_->enable_axes(kWheels);
    ASSERT_EQ(e, ErrorCode::kOk) << failure_text(*card_);
    // The servo comes on a few ms (simulated) later.
    ASSERT_TRUE(wait_until([&] {
      auto a = status_of(*card_, 1), b = status_of(*card_, 2);
      return a && b && a->enabled && b->enabled;
    }));
  }
  AxisStatus status(int axis) {
    auto st = status_of(*card_, axis);
    EXPECT_TRUE(st.has_value()) << failure_text(*card_);
    return st ? *st : AxisStatus{};
  }
  bool wait_resting(int axis) {
    return wait_until([&] {
      auto st = status_of(*card_, axis);
      return st && !st->moving;
    });
  }
  // A move long enough that it is certainly still running when the test looks (hours of
  // simulated time).
  ErrorCode start_long_move(std::int64_t sign = 1) {
    const AxisMove moves[] = {{1, sign * 100'000'000}, {2, sign * 100'000'000}};
    return card_->move_relative(moves, TrapezoidProfile{1.0, 0.5, 0.5, 0});
  }

  Maker maker_;
  std::unique_ptr<MotionCard> card_;
};

using CardImplementations =
    ::testing::Types<MockMaker, SimMaker, ManagedMaker<MockMaker>, ManagedMaker<SimMaker>>;
class ImplementationNames {
 public:
  template <typename T>
  static std::string GetName(int) {
    if (std::is_same_v<T, MockMaker>) return "Mock";
    if (std::is_same_v<T, SimMaker>) return "GtsOverSimulator";
    if (std::is_same_v<T, ManagedMaker<MockMaker>>) return "ManagedMock";
    return "ManagedGtsOverSimulator";
  }
};
TYPED_TEST_SUITE(MotionCardContract, CardImplementations, ImplementationNames);

TYPED_TEST(MotionCardContract, RefusesEverythingBeforeOpen) {
  EXPECT_FALSE(status_of(*this->card_, 1).has_value());
  EXPECT_FALSE(this->card_->enable_axes(kWheels) == ErrorCode::kOk);
  const AxisMove moves[] = {{1, 100}};
  EXPECT_FALSE(this->card_->move_relative(moves, TrapezoidProfile{}) == ErrorCode::kOk);
}

TYPED_TEST(MotionCardContract, OpenGivesDisabledAxesAtRest) {
  ASSERT_TRUE(this->card_->open().ok());
  for (const int axis : kWheels) {
    const AxisStatus st = this->status(axis);
    EXPECT_FALSE(st.enabled);
    EXPECT_FALSE(st.moving);
    EXPECT_FALSE(st.faulted());
    EXPECT_FALSE(st.emergency_stopped);
    EXPECT_EQ(st.profile_position_counts, 0);
    EXPECT_EQ(st.encoder_position_counts, 0);
  }
}

TYPED_TEST(MotionCardContract, EnableThenDisable) {
  this->open_and_enable();
  EXPECT_TRUE(this->status(1).enabled);
  EXPECT_TRUE(this->status(2).enabled);
  EXPECT_FALSE(this->status(3).enabled);  // only the axes asked for
  ASSERT_TRUE(this->card_->disable_axes(kWheels) == ErrorCode::kOk);
  EXPECT_FALSE(this->status(1).enabled);
}

TYPED_TEST(MotionCardContract, RelativeMoveReachesItsTargetOnEveryAxis) {
  this->open_and_enable();
  const AxisMove moves[] = {{1, 5000}, {2, -3000}};
  const auto s = this->card_->move_relative(moves, TrapezoidProfile{10, 0.5, 0.5, 0});
  ASSERT_EQ(s, ErrorCode::kOk) << failure_text(*this->card_);
  ASSERT_TRUE(this->wait_resting(1));
  ASSERT_TRUE(this->wait_resting(2));
  const AxisStatus a1 = this->status(1);
  const AxisStatus a2 = this->status(2);
  EXPECT_EQ(a1.profile_position_counts, 5000);
  EXPECT_EQ(a1.encoder_position_counts, 5000);
  EXPECT_TRUE(a1.in_position);
  EXPECT_EQ(a2.profile_position_counts, -3000);
  EXPECT_EQ(a2.encoder_position_counts, -3000);
  EXPECT_TRUE(a2.in_position);

  // Relative to where the axis is now.
  const AxisMove again[] = {{1, 1000}};
  ASSERT_TRUE(this->card_->move_relative(again, TrapezoidProfile{10, 0.5, 0.5, 0}) ==
              ErrorCode::kOk);
  ASSERT_TRUE(this->wait_resting(1));
  EXPECT_EQ(this->status(1).profile_position_counts, 6000);
  EXPECT_EQ(this->status(2).profile_position_counts, -3000);
}

TYPED_TEST(MotionCardContract, AxesOfOneMoveRunTogether) {
  this->open_and_enable();
  ASSERT_TRUE(this->start_long_move() == ErrorCode::kOk);
  EXPECT_TRUE(this->status(1).moving);
  EXPECT_TRUE(this->status(2).moving);
  EXPECT_FALSE(this->status(1).in_position);
  ASSERT_TRUE(this->card_->emergency_stop(kWheels) == ErrorCode::kOk);
}

TYPED_TEST(MotionCardContract, SmoothStopDeceleratesToRestAndDoesNotLatch) {
  this->open_and_enable();
  ASSERT_TRUE(this->start_long_move() == ErrorCode::kOk);
  ASSERT_TRUE(wait_until([&] { return this->status(1).profile_position_counts > 100; }));
  ASSERT_TRUE(this->card_->smooth_stop(kWheels) == ErrorCode::kOk);
  ASSERT_TRUE(this->wait_resting(1));
  ASSERT_TRUE(this->wait_resting(2));
  const AxisStatus st = this->status(1);
  EXPECT_TRUE(st.smooth_stopped);
  EXPECT_FALSE(st.emergency_stopped);
  EXPECT_GT(st.profile_position_counts, 100);
  EXPECT_LT(st.profile_position_counts, 100'000'000);
  // A smooth stop does not block the next move.
  const AxisMove moves[] = {{1, 10}};
  EXPECT_TRUE(this->card_->move_relative(moves, TrapezoidProfile{}) == ErrorCode::kOk);
}

TYPED_TEST(MotionCardContract, EmergencyStopHaltsAtOnceAndLatchesUntilCleared) {
  this->open_and_enable();
  ASSERT_TRUE(this->start_long_move() == ErrorCode::kOk);
  ASSERT_TRUE(this->card_->emergency_stop(kWheels) == ErrorCode::kOk);
  const AxisStatus st = this->status(1);
  EXPECT_FALSE(st.moving);
  EXPECT_TRUE(st.emergency_stopped);
  const std::int64_t stopped_at = st.profile_position_counts;
  const AxisMove moves[] = {{1, 10}};
  const auto refused = this->card_->move_relative(moves, TrapezoidProfile{});
  EXPECT_EQ(refused, ErrorCode::kEmergencyStopped) << failure_text(*this->card_);
  EXPECT_EQ(this->status(1).profile_position_counts, stopped_at);

  ASSERT_TRUE(this->card_->clear_faults(kWheels) == ErrorCode::kOk);
  EXPECT_FALSE(this->status(1).emergency_stopped);
  ASSERT_TRUE(this->card_->move_relative(moves, TrapezoidProfile{}) == ErrorCode::kOk);
  ASSERT_TRUE(this->wait_resting(1));
  EXPECT_EQ(this->status(1).profile_position_counts, stopped_at + 10);
}

TYPED_TEST(MotionCardContract, StopsAreAcceptedWhenNothingMoves) {
  this->open_and_enable();
  EXPECT_TRUE(this->card_->smooth_stop(kWheels) == ErrorCode::kOk);
  EXPECT_TRUE(this->card_->emergency_stop(kWheels) == ErrorCode::kOk);
  EXPECT_TRUE(this->card_->smooth_stop({}) == ErrorCode::kOk);
}

TYPED_TEST(MotionCardContract, BadParametersAreRefusedAndNothingMoves) {
  this->open_and_enable();
  const auto expect_bad = [&](std::span<const AxisMove> moves, const TrapezoidProfile& p) {
    const auto s = this->card_->move_relative(moves, p);
    EXPECT_EQ(s, ErrorCode::kCardBadParameter) << failure_text(*this->card_);
  };
  const AxisMove ok_move[] = {{1, 100}};
  const AxisMove axis0[] = {{0, 100}};
  const AxisMove axis99[] = {{99, 100}};
  const AxisMove twice[] = {{1, 100}, {1, 100}};
  expect_bad({}, TrapezoidProfile{});
  expect_bad(axis0, TrapezoidProfile{});
  expect_bad(axis99, TrapezoidProfile{});
  expect_bad(twice, TrapezoidProfile{});
  expect_bad(ok_move, TrapezoidProfile{0, 0.1, 0.1, 0});
  expect_bad(ok_move, TrapezoidProfile{std::numeric_limits<double>::quiet_NaN(), 0.1, 0.1, 0});
  expect_bad(ok_move, TrapezoidProfile{10, -1, 0.1, 0});
  expect_bad(ok_move, TrapezoidProfile{10, 0.1, 0, 0});
  expect_bad(ok_move, TrapezoidProfile{10, 0.1, 0.1, 60});
  const int bad_axes[] = {0};
  const auto e = this->card_->enable_axes(bad_axes);
  EXPECT_EQ(e, ErrorCode::kCardBadParameter) << failure_text(*this->card_);
  EXPECT_FALSE(status_of(*this->card_, 0).has_value());
  EXPECT_FALSE(this->status(1).moving);
  EXPECT_EQ(this->status(1).profile_position_counts, 0);
}

TYPED_TEST(MotionCardContract, MoveOnADisabledAxisIsRefused) {
  ASSERT_TRUE(this->card_->open().ok());
  const AxisMove moves[] = {{1, 100}};
  EXPECT_FALSE(this->card_->move_relative(moves, TrapezoidProfile{}) == ErrorCode::kOk);
  EXPECT_FALSE(this->status(1).moving);
  EXPECT_EQ(this->status(1).profile_position_counts, 0);
}

TYPED_TEST(MotionCardContract, DriveAlarmRefusesMotionUntilClearedAndReenabled) {
  this->open_and_enable();
  this->maker_.alarm(1);
  const AxisMove moves[] = {{1, 100}};
  const auto refused = this->card_->move_relative(moves, TrapezoidProfile{});
  EXPECT_EQ(refused, ErrorCode::kAxisAlarm) << failure_text(*this->card_);
  const AxisStatus st = this->status(1);
  EXPECT_TRUE(st.alarm);
  EXPECT_FALSE(st.enabled);  // the drive dropped the servo
  EXPECT_TRUE(st.faulted());

  ASSERT_TRUE(this->card_->clear_faults(kWheels) == ErrorCode::kOk);
  EXPECT_FALSE(this->status(1).alarm);
  this->enable();
  ASSERT_TRUE(this->card_->move_relative(moves, TrapezoidProfile{}) == ErrorCode::kOk);
  ASSERT_TRUE(this->wait_resting(1));
  EXPECT_EQ(this->status(1).profile_position_counts, 100);
}

TYPED_TEST(MotionCardContract, FollowingErrorRefusesMotion) {
  this->open_and_enable();
  this->maker_.following_error(2);
  const AxisMove moves[] = {{1, 100}, {2, 100}};
  const auto refused = this->card_->move_relative(moves, TrapezoidProfile{});
  EXPECT_EQ(refused, ErrorCode::kFollowingError) << failure_text(*this->card_);
  EXPECT_TRUE(this->status(2).following_error);
  EXPECT_EQ(this->status(1).profile_position_counts, 0);  // no axis of the move started
}

TYPED_TEST(MotionCardContract, LimitRefusesOnlyMotionIntoIt) {
  this->open_and_enable();
  this->maker_.limit(1, true);
  EXPECT_TRUE(this->status(1).positive_limit);
  const AxisMove forward[] = {{1, 100}};
  const auto refused = this->card_->move_relative(forward, TrapezoidProfile{});
  EXPECT_EQ(refused, ErrorCode::kLimitHit) << failure_text(*this->card_);
  const AxisMove back[] = {{1, -100}};
  ASSERT_TRUE(this->card_->move_relative(back, TrapezoidProfile{}) == ErrorCode::kOk);
  ASSERT_TRUE(this->wait_resting(1));
  EXPECT_EQ(this->status(1).profile_position_counts, -100);
}

TYPED_TEST(MotionCardContract, CloseThenReopen) {
  this->open_and_enable();
  ASSERT_TRUE(this->card_->close().ok());
  EXPECT_FALSE(status_of(*this->card_, 1).has_value());
  ASSERT_TRUE(this->card_->open().ok());
  EXPECT_TRUE(status_of(*this->card_, 1).has_value());
}

// --- velocity mode (jog) ---------------------------------------------------------------------
// On a manual clock: positions are checked against the closed-form ramp (1 count of rounding).

constexpr JogProfile kJog{0.01, 0.02, 0};  // 2 counts/ms reached in 200 ms, shed in 100 ms

template <typename Maker>
class JogContract : public MotionCardContract<Maker> {
 protected:
  void SetUp() override {
    MotionCardContract<Maker>::SetUp();
    this->open_and_enable();
    this->maker_.manual_clock();
  }
  ErrorCode jog(double left, double right, const JogProfile& p = kJog) {
    const AxisVelocity v[] = {{1, left}, {2, right}};
    return this->card_->jog(v, p);
  }
  void advance_ms(double ms) { this->maker_.advance_ms(ms); }
  double position(int axis) {
    return static_cast<double>(this->status(axis).profile_position_counts);
  }
  // Jogs both wheels (+2, -2 counts/ms) until they cruise: at 300 ms, +-400 counts.
  void cruise() {
    ASSERT_EQ(jog(2, -2), ErrorCode::kOk) << failure_text(*this->card_);
    advance_ms(300);
    ASSERT_NEAR(position(1), 400, 1);
    ASSERT_NEAR(position(2), -400, 1);
  }
};
TYPED_TEST_SUITE(JogContract, CardImplementations, ImplementationNames);

TYPED_TEST(JogContract, RampRespectsTheAccelerationThenHoldsTheVelocity) {
  ASSERT_EQ(this->jog(2, -2), ErrorCode::kOk) << failure_text(*this->card_);
  this->advance_ms(100);  // accelerating: 0.5 * 0.01 * 100^2
  EXPECT_NEAR(this->position(1), 50, 1);
  EXPECT_NEAR(this->position(2), -50, 1);
  EXPECT_TRUE(this->status(1).moving);
  this->advance_ms(100);  // 2 counts/ms reached
  EXPECT_NEAR(this->position(1), 200, 1);
  this->advance_ms(1000);  // held: 2 counts/ms for 1 s
  EXPECT_NEAR(this->position(1), 2200, 1);
  EXPECT_NEAR(this->position(2), -2200, 1);
  EXPECT_TRUE(this->status(2).moving);
  EXPECT_FALSE(this->status(1).in_position);
}

TYPED_TEST(JogContract, ANewVelocityRampsFromTheCurrentOne) {
  this->cruise();
  ASSERT_EQ(this->jog(3, -1), ErrorCode::kOk);  // left speeds up, right slows down
  this->advance_ms(50);
  EXPECT_NEAR(this->position(1), 400 + 2 * 50 + 0.5 * 0.01 * 50 * 50, 1);
  EXPECT_NEAR(this->position(2), -400 - (2 * 50 - 0.5 * 0.02 * 50 * 50), 1);
  this->advance_ms(1000);  // left at 3 after 100 ms, right at 1 after 50 ms
  EXPECT_NEAR(this->position(1), 400 + 250 + 3 * 950, 1);
  EXPECT_NEAR(this->position(2), -400 - 75 - 1 * 1000, 1);
}

TYPED_TEST(JogContract, ZeroVelocityDeceleratesToRest) {
  this->cruise();
  ASSERT_EQ(this->jog(0, 0), ErrorCode::kOk);
  this->advance_ms(50);  // 2 counts/ms shed at 0.02 counts/ms^2: 100 ms, 100 counts
  EXPECT_NEAR(this->position(1), 400 + 75, 1);
  EXPECT_TRUE(this->status(1).moving);
  this->advance_ms(51);
  const AxisStatus left = this->status(1);
  const AxisStatus right = this->status(2);
  EXPECT_FALSE(left.moving);
  EXPECT_FALSE(right.moving);
  EXPECT_NEAR(static_cast<double>(left.profile_position_counts), 500, 1);
  EXPECT_NEAR(static_cast<double>(right.profile_position_counts), -500, 1);
  this->advance_ms(1000);  // stays at rest
  EXPECT_NEAR(this->position(1), 500, 1);
  EXPECT_FALSE(left.emergency_stopped);
}

TYPED_TEST(JogContract, AReversalPassesThroughRestAtTheDeceleration) {
  this->cruise();
  ASSERT_EQ(this->jog(-2, 2), ErrorCode::kOk);
  this->advance_ms(100);  // decelerated to rest: +100 counts
  EXPECT_NEAR(this->position(1), 500, 1);
  this->advance_ms(200);  // accelerated to -2: -200 counts
  EXPECT_NEAR(this->position(1), 300, 1);
  EXPECT_NEAR(this->position(2), -300, 1);
}

TYPED_TEST(JogContract, SmoothStopEndsAJogAlongItsDeceleration) {
  this->cruise();
  ASSERT_EQ(this->card_->smooth_stop(kWheels), ErrorCode::kOk);
  this->advance_ms(101);
  const AxisStatus st = this->status(1);
  EXPECT_FALSE(st.moving);
  EXPECT_TRUE(st.smooth_stopped);
  EXPECT_FALSE(st.emergency_stopped);
  EXPECT_NEAR(static_cast<double>(st.profile_position_counts), 500, 1);
  EXPECT_NEAR(this->position(2), -500, 1);
  this->advance_ms(1000);
  EXPECT_NEAR(this->position(1), 500, 1);
  EXPECT_EQ(this->jog(1, 1), ErrorCode::kOk);  // a smooth stop does not block the next jog
}

TYPED_TEST(JogContract, EmergencyStopEndsAJogAtOnceAndLatches) {
  this->cruise();
  ASSERT_EQ(this->card_->emergency_stop(kWheels), ErrorCode::kOk);
  const AxisStatus st = this->status(1);
  EXPECT_FALSE(st.moving);
  EXPECT_TRUE(st.emergency_stopped);
  this->advance_ms(1000);
  EXPECT_NEAR(this->position(1), 400, 1);
  EXPECT_EQ(this->jog(1, 1), ErrorCode::kEmergencyStopped);
  EXPECT_NEAR(this->position(1), 400, 1);
  ASSERT_EQ(this->card_->clear_faults(kWheels), ErrorCode::kOk);
  ASSERT_EQ(this->jog(1, 1), ErrorCode::kOk);
  this->advance_ms(200);
  EXPECT_GT(this->position(1), 400);
}

TYPED_TEST(JogContract, JogAndTrapezoidDoNotMixWhileMoving) {
  this->cruise();
  const AxisMove moves[] = {{1, 100}};
  EXPECT_EQ(this->card_->move_relative(moves, TrapezoidProfile{}), ErrorCode::kDriverError);
  EXPECT_EQ(this->card_->last_failure().axis, 1);
  ASSERT_EQ(this->card_->smooth_stop(kWheels), ErrorCode::kOk);
  this->advance_ms(200);
  const double rest = this->position(1);
  ASSERT_EQ(this->card_->move_relative(moves, TrapezoidProfile{10, 1, 1, 0}), ErrorCode::kOk);
  EXPECT_EQ(this->jog(1, 1), ErrorCode::kDriverError);  // the move runs
  this->advance_ms(1000);
  EXPECT_EQ(this->position(1), rest + 100);
  EXPECT_EQ(this->jog(1, 1), ErrorCode::kOk);  // at rest: the mode may change
}

TYPED_TEST(JogContract, BadParametersAreRefusedAndNothingMoves) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto expect_bad = [&](std::span<const AxisVelocity> v, const JogProfile& p) {
    EXPECT_EQ(this->card_->jog(v, p), ErrorCode::kCardBadParameter) << failure_text(*this->card_);
  };
  const AxisVelocity ok[] = {{1, 1}};
  const AxisVelocity axis0[] = {{0, 1}};
  const AxisVelocity twice[] = {{1, 1}, {1, 1}};
  const AxisVelocity not_finite[] = {{1, nan}};
  expect_bad({}, kJog);
  expect_bad(axis0, kJog);
  expect_bad(twice, kJog);
  expect_bad(not_finite, kJog);
  expect_bad(ok, JogProfile{0, 0.1, 0});
  expect_bad(ok, JogProfile{0.1, nan, 0});
  expect_bad(ok, JogProfile{0.1, 0.1, 1.0});
  expect_bad(ok, JogProfile{0.1, 0.1, -0.1});
  this->advance_ms(100);
  EXPECT_FALSE(this->status(1).moving);
  EXPECT_EQ(this->position(1), 0);
}

TYPED_TEST(JogContract, LimitsAndAlarmsRefuseAJogIntoThem) {
  this->maker_.limit(1, false);
  EXPECT_EQ(this->jog(-1, 0), ErrorCode::kLimitHit);
  EXPECT_EQ(this->card_->last_failure().axis, 1);
  ASSERT_EQ(this->jog(1, 0), ErrorCode::kOk);  // away from the limit
  this->advance_ms(100);
  EXPECT_GT(this->position(1), 0);
  this->maker_.alarm(2);
  EXPECT_EQ(this->jog(1, 1), ErrorCode::kAxisAlarm);
}

}  // namespace
}  // namespace ajar::drivers
