// The card simulator keeps simulated time exact: driven through the GTS driver at 100..2000 Hz,
// with the loop's status reads spread unevenly over each period (as a real loop's calls are), a
// trapezoidal move lasts what the trapezoid says; a huge time jump is evaluated in closed form.
// Simulated time is a manual clock here: no wall-clock timing. The uneven split is random;
// AJAR_SEED=<n> replays a run.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <random>

#include "ajar/drivers/gts_card.hpp"
#include "ajar/drivers/gts_sim_control.hpp"
#include "card_test_support.hpp"

namespace ajar::drivers {
namespace {

using testing::failure_text;
using testing::status_of;

constexpr int kLeft = 1;
constexpr int kRight = 2;
using testing::kWheels;  // {kLeft, kRight}

std::uint64_t seed() {
  if (const char* s = std::getenv("AJAR_SEED"); s != nullptr) return std::strtoull(s, nullptr, 0);
  return std::random_device{}();
}

class SimTime : public ::testing::Test {
 protected:
  void SetUp() override {
    sim_.reset();
    sim_.set_manual_clock(1);
    card_ = std::make_unique<GtsMotionCard>(testing::card_sim_settings());
    ASSERT_TRUE(card_->open().ok());
    ASSERT_EQ(card_->enable_axes(kWheels), ErrorCode::kOk) << failure_text(*card_);
    sim_.advance_clock_ns(10'000'000);  // servo on after 5 ms
    ASSERT_TRUE(status_of(*card_, kLeft)->enabled);
    ASSERT_TRUE(status_of(*card_, kRight)->enabled);
  }
  void TearDown() override { sim_.reset(); }

  GtsSimControl sim_{testing::card_sim_path()};
  std::unique_ptr<GtsMotionCard> card_;
};

// The trapezoid's duration (ms) for a move of d counts with equal acceleration and deceleration.
double trapezoid_ms(double d, double v, double a) {
  return d >= v * v / a ? d / v + v / a : 2.0 * std::sqrt(d / a);
}

class SimTimeAtRate : public SimTime, public ::testing::WithParamInterface<int> {};

TEST_P(SimTimeAtRate, AMoveLastsWhatTheTrapezoidSays) {
  const int rate_hz = GetParam();
  const std::int64_t period_ns = 1'000'000'000LL / rate_hz;
  const std::uint64_t s = seed();
  std::cout << "[ seed ] AJAR_SEED=" << s << " (rate " << rate_hz << " Hz)\n";
  std::mt19937_64 rng(s);
  std::uniform_real_distribution<double> split(0.05, 0.95);

  // A turn in place like AlignBase: 20000 counts each way at 10 counts/ms, 0.05 counts/ms^2.
  const TrapezoidProfile profile{10, 0.05, 0.05, 0};
  const AxisMove moves[] = {{kLeft, 20000}, {kRight, -20000}};
  const double expected_ms = trapezoid_ms(20000, 10, 0.05);  // 2200 ms
  ASSERT_EQ(card_->move_relative(moves, profile), ErrorCode::kOk) << failure_text(*card_);

  std::int64_t elapsed_ns = 0;
  bool done = false;
  bool checked_accel = false;
  while (!done && elapsed_ns < 10'000'000'000LL) {
    // One loop period: a status read of each wheel at uneven instants within it.
    const auto first = static_cast<std::int64_t>(split(rng) * static_cast<double>(period_ns));
    sim_.advance_clock_ns(first);
    const AxisStatus left = *status_of(*card_, kLeft);
    sim_.advance_clock_ns(period_ns - first);
    const AxisStatus right = *status_of(*card_, kRight);
    elapsed_ns += period_ns;
    done = !left.moving && !right.moving;
    // Mid-ramp, the position is the closed form's (0.5 a t^2 at the left read's instant).
    const double t_ms = static_cast<double>(elapsed_ns - period_ns + first) / 1e6;
    if (!checked_accel && t_ms > 100 && t_ms < 190) {
      EXPECT_NEAR(static_cast<double>(left.profile_position_counts), 0.5 * 0.05 * t_ms * t_ms, 1.0)
          << "at " << t_ms << " ms";
      checked_accel = true;
    }
  }
  ASSERT_TRUE(done) << "the move never ended";
  const double measured_ms = static_cast<double>(elapsed_ns) / 1e6;
  EXPECT_NEAR(measured_ms, expected_ms, 0.02 * expected_ms) << rate_hz << " Hz";
  EXPECT_EQ(status_of(*card_, kLeft)->profile_position_counts, 20000);
  EXPECT_EQ(status_of(*card_, kRight)->profile_position_counts, -20000);
  EXPECT_TRUE(status_of(*card_, kLeft)->in_position);
}

INSTANTIATE_TEST_SUITE_P(CallRates, SimTimeAtRate, ::testing::Values(100, 250, 500, 1000, 2000),
                         [](const auto& param_info) {
                           return std::to_string(param_info.param) + "Hz";
                         });

TEST_F(SimTime, AHugeTimeJumpIsEvaluatedInClosedForm) {
  // 10^9 counts at 1 count/ms: about 11.6 days. A 1 ms stepper would need 10^9 steps under the
  // simulator's lock to catch up; the closed form needs none.
  const AxisMove moves[] = {{kLeft, 1'000'000'000}};
  ASSERT_EQ(card_->move_relative(moves, TrapezoidProfile{1, 0.5, 0.5, 0}), ErrorCode::kOk);
  sim_.advance_clock_ns(5LL * 24 * 3600 * 1'000'000'000LL);  // 5 days
  const AxisStatus mid = *status_of(*card_, kLeft);
  EXPECT_TRUE(mid.moving);
  // 2 ms ramp (1 count), then 1 count/ms.
  EXPECT_EQ(mid.profile_position_counts, 5LL * 24 * 3600 * 1000 - 1);
  sim_.advance_clock_ns(30LL * 365 * 24 * 3600 * 1'000'000'000LL);  // 30 years
  const AxisStatus end = *status_of(*card_, kLeft);
  EXPECT_FALSE(end.moving);
  EXPECT_EQ(end.profile_position_counts, 1'000'000'000);
  EXPECT_EQ(end.encoder_position_counts, 1'000'000'000);
}

TEST_F(SimTime, TheScaledClockContinuesFromTheManualOne) {
  sim_.advance_clock_ns(1'000'000'000);
  const double manual_ms = sim_.now_ms();
  sim_.set_manual_clock(0);
  sim_.set_time_scale(1e-6);  // nearly still, but never backwards
  EXPECT_GE(sim_.now_ms(), manual_ms);
  EXPECT_LT(sim_.now_ms(), manual_ms + 1000);
}

TEST_F(SimTime, FailureRulesForUnknownCallsAreIgnoredAndNothingThrows) {
  sim_.fail_next_calls("GT_NoSuchCall", -7, -1);  // matches nothing: refused quietly
  EXPECT_TRUE(status_of(*card_, kLeft).has_value());
  sim_.fail_next_calls(nullptr, -7, 1);  // any call, once
  EXPECT_FALSE(status_of(*card_, kLeft).has_value());
  EXPECT_EQ(card_->last_failure().vendor_code, -7);
  EXPECT_TRUE(status_of(*card_, kLeft).has_value());
}

}  // namespace
}  // namespace ajar::drivers
