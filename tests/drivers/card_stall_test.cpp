// A card call that hangs, and the out-of-band emergency stop from another thread while it hangs:
// against the mock (block_calls) and the GTS driver over the card simulator
// (AjarSim_BlockNextCall), bare and inside the lifecycle wrapper. The stop reaches the card while
// the other call is still inside it, the wheels rest and stay latched, and the call that hung,
// once it returns, cannot move them.
#include <gtest/gtest.h>

#include <array>
#include <future>
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

// Each maker builds one implementation and makes the next call of a kind hang until released.
struct MockHangs {
  MockMotionCard* raw = nullptr;
  std::unique_ptr<MotionCard> make() {
    auto card = std::make_unique<MockMotionCard>(MockFault::kNone, 0, kFastTimeScale, 4);
    raw = card.get();
    return card;
  }
  void hang_next_status() { raw->block_calls(CardCall::kAxisStatus, 1); }
  void hang_next_jog() { raw->block_calls(CardCall::kJog, 1); }
  std::size_t hanging() const { return raw->blocked_calls(); }
  void release() { raw->release_blocked_calls(); }
  bool stop_reached_the_card() const { return raw->calls(CardCall::kEmergencyStopOutOfBand) == 1; }
};

struct SimHangs {
  std::unique_ptr<GtsSimControl> sim;
  std::unique_ptr<MotionCard> make() {
    sim = std::make_unique<GtsSimControl>(testing::card_sim_path());
    sim->reset();
    sim->set_time_scale(kFastTimeScale);
    return std::make_unique<GtsMotionCard>(testing::card_sim_settings());
  }
  void hang_next_status() { sim->block_next_call("GT_GetSts", -1); }
  // After jog()'s status reads (which pass), before it commands anything.
  void hang_next_jog() { sim->block_next_call("GT_SetJogPrm", -1); }
  std::size_t hanging() const { return static_cast<std::size_t>(sim->blocked_calls()); }
  void release() { sim->release_blocked_calls(); }
  bool stop_reached_the_card() const {
    long mask = 0;
    long option = 0;
    sim->last_stop(&mask, &option);
    return mask == 0b11 && option == 0b11;  // GT_Stop of both wheels, abrupt
  }
};

template <typename Inner>
struct Managed : Inner {
  std::unique_ptr<MotionCard> make() {
    return std::make_unique<ManagedMotionCard>(Inner::make(), kWheels);
  }
};

template <typename Maker>
class CardStall : public ::testing::Test {
 protected:
  void SetUp() override {
    card_ = maker_.make();
    ASSERT_TRUE(card_->open().ok());
    ASSERT_EQ(card_->enable_axes(kWheels), ErrorCode::kOk) << failure_text(*card_);
    ASSERT_TRUE(wait_until([&] {
      const auto l = status_of(*card_, 1);
      const auto r = status_of(*card_, 2);
      return l && r && l->enabled && r->enabled;
    }));
  }
  void TearDown() override {
    maker_.release();
    card_.reset();
  }
  void jog_both(double velocity) {
    const AxisVelocity v[2] = {{1, velocity}, {2, -velocity}};
    ASSERT_EQ(card_->jog(v, JogProfile{1.0, 1.0, 0}), ErrorCode::kOk) << failure_text(*card_);
    ASSERT_TRUE(wait_until([&] {
      const auto st = status_of(*card_, 1);
      return st && st->moving;
    }));
  }
  // Both wheels report rest, latched emergency stop, and the same position twice in a row while
  // simulated time runs (1000 times real time).
  void expect_wheels_rest() {
    for (const int axis : kWheels) {
      const auto first = status_of(*card_, axis);
      ASSERT_TRUE(first) << failure_text(*card_);
      EXPECT_FALSE(first->moving) << axis;
      EXPECT_TRUE(first->emergency_stopped) << axis;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));  // 5 s simulated
      const auto second = status_of(*card_, axis);
      ASSERT_TRUE(second);
      EXPECT_EQ(second->encoder_position_counts, first->encoder_position_counts) << axis;
    }
  }

  Maker maker_;
  std::unique_ptr<MotionCard> card_;
};

using StallingCards = ::testing::Types<MockHangs, SimHangs, Managed<MockHangs>, Managed<SimHangs>>;
TYPED_TEST_SUITE(CardStall, StallingCards);

TYPED_TEST(CardStall, TheOutOfBandStopActsWhileAStatusReadHangs) {
  this->jog_both(20.0);
  this->maker_.hang_next_status();
  auto hung = std::async(std::launch::async, [&] {
    AxisStatus st;
    return this->card_->axis_status(1, st);
  });
  ASSERT_TRUE(wait_until([&] { return this->maker_.hanging() == 1; }));
  EXPECT_EQ(this->card_->emergency_stop_out_of_band(kWheels), ErrorCode::kOk);
  EXPECT_TRUE(this->maker_.stop_reached_the_card());
  // Still hanging: the stop did not need it to return.
  EXPECT_EQ(this->maker_.hanging(), 1U);
  this->maker_.release();
  EXPECT_EQ(hung.get(), ErrorCode::kOk);
  this->expect_wheels_rest();
  EXPECT_EQ(this->card_->last_failure().code, ErrorCode::kOk);  // untouched by the stop
}

TYPED_TEST(CardStall, AJogThatHungCannotMoveTheWheelsAfterTheStop) {
  this->jog_both(20.0);
  this->maker_.hang_next_jog();
  auto hung = std::async(std::launch::async, [&] {
    const AxisVelocity v[2] = {{1, 40.0}, {2, -40.0}};
    return this->card_->jog(v, JogProfile{1.0, 1.0, 0});
  });
  ASSERT_TRUE(wait_until([&] { return this->maker_.hanging() == 1; }));
  EXPECT_EQ(this->card_->emergency_stop_out_of_band(kWheels), ErrorCode::kOk);
  this->maker_.release();
  // The card refuses what the hung call commands after the stop (emergency stop latched).
  EXPECT_NE(hung.get(), ErrorCode::kOk);
  this->expect_wheels_rest();
  // Until the faults are cleared, nothing moves.
  const AxisVelocity v[2] = {{1, 10.0}, {2, -10.0}};
  EXPECT_EQ(this->card_->jog(v, JogProfile{1.0, 1.0, 0}), ErrorCode::kEmergencyStopped);
}

TYPED_TEST(CardStall, TheOutOfBandStopNeedsAnOpenCardAndAWheel) {
  const int none[] = {9};
  EXPECT_EQ(this->card_->emergency_stop_out_of_band(none), ErrorCode::kCardBadParameter);
  ASSERT_TRUE(this->card_->close().ok());
  EXPECT_EQ(this->card_->emergency_stop_out_of_band(kWheels), ErrorCode::kDriverError);
}

TEST(MockCardHang, ABoundedHangReturnsByItselfAndCountsAsHanging) {
  MockMotionCard card(MockFault::kNone, 0, 1.0, 4);
  ASSERT_TRUE(card.open().ok());
  card.block_calls(CardCall::kAxisStatus, 2, 20);  // two reads hang 20 ms each (real time)
  AxisStatus st;
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kOk);  // returns without a release
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kOk);
  EXPECT_EQ(card.blocked_calls(), 0U);
  EXPECT_EQ(card.calls(CardCall::kAxisStatus), 2U);
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kOk);  // the rule was for two calls
}

TEST(SimCardHang, ABoundedHangReturnsByItselfAndOnlyTheNamedCallHangs) {
  GtsSimControl sim(testing::card_sim_path());
  sim.reset();
  GtsMotionCard card(testing::card_sim_settings());
  ASSERT_TRUE(card.open().ok());
  sim.block_next_call("GT_GetEncPos", 20);
  AxisStatus st;
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kOk);
  EXPECT_EQ(sim.blocked_calls(), 0);
  EXPECT_EQ(sim.call_count("GT_GetEncPos"), 1);
  sim.block_next_call("NoSuchCall", -1);  // not a vendor call: nothing hangs
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kOk);
  sim.reset();
}

}  // namespace
}  // namespace ajar::drivers
