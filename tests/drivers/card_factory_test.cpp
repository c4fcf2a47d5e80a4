// make_drivers(): each kind gives a working card and arm (wrapped here as the daemon wraps them).
#include <gtest/gtest.h>

#include <array>

#include "ajar/drivers/factory.hpp"
#include "ajar/drivers/gts_sim_control.hpp"
#include "ajar/drivers/lifecycle.hpp"
#include "card_test_support.hpp"

namespace ajar::drivers {
namespace {

using testing::status_of;
using testing::wait_until;

core::BaseGeometry wheels_on(int left, int right) {
  core::BaseGeometry base;
  base.left.card_axis = left;
  base.right.card_axis = right;
  return base;
}

// Wraps the card as the daemon does, brings it up, turns the wheels and checks they arrive.
void drive(DriverSet& set, int left, int right) {
  ASSERT_NE(set.card, nullptr);
  const int wheels[] = {left, right};
  ManagedMotionCard card(std::move(set.card), wheels);
  ASSERT_TRUE(card.configure().ok());
  const auto activated = card.activate();
  ASSERT_TRUE(activated.ok()) << activated.error().message;
  const AxisMove moves[] = {{left, 4000}, {right, -4000}};
  ASSERT_TRUE(card.move_relative(moves, TrapezoidProfile{}) == ErrorCode::kOk);
  ASSERT_TRUE(wait_until([&] {
    auto l = status_of(card, left);
    auto r = status_of(card, right);
    return l && r && !l->moving && !r->moving;
  }));
  EXPECT_EQ(status_of(card, left)->profile_position_counts, 4000);
  EXPECT_EQ(status_of(card, right)->profile_position_counts, -4000);
  ASSERT_TRUE(card.deactivate().ok());
  ASSERT_TRUE(card.cleanup().ok());
}

TEST(DriverFactory, MockKindGivesMocks) {
  DriverSettings settings;
  settings.kind = DriverKind::kMock;
  settings.sim_speedup = testing::kFastTimeScale;
  DriverSet set = make_drivers(settings, wheels_on(1, 2));
  ASSERT_NE(set.arm, nullptr);
  ManagedManipulator arm(std::move(set.arm));
  drive(set, 1, 2);
  ASSERT_TRUE(arm.configure().ok());
  ASSERT_TRUE(arm.activate().ok());
  EXPECT_TRUE(arm.hand_off(DoorTask{}).ok());
  ASSERT_TRUE(arm.disconnect().ok());
}

TEST(DriverFactory, SimKindDrivesTheCardSimulatorAndTheArmOverAPty) {
  GtsSimControl sim(testing::card_sim_path());
  sim.reset();
  DriverSettings settings;
  settings.kind = DriverKind::kSim;  // empty library path: the simulator built here
  settings.sim_speedup = testing::kFastTimeScale;
  DriverSet set = make_drivers(settings, wheels_on(2, 3));
  EXPECT_NE(set.keepalive, nullptr);
  drive(set, 2, 3);
  EXPECT_GT(sim.call_count("GT_Update"), 0);  // the moves went through the simulator library
  ASSERT_NE(set.arm, nullptr);
  const auto connected = set.arm->connect();
  ASSERT_TRUE(connected.ok()) << connected.error().message;
  EXPECT_NE(set.arm->status().phase, ArmPhase::kDisconnected);
  ASSERT_TRUE(set.arm->disconnect().ok());
}

TEST(DriverFactory, RefusesUnusableSettings) {
  DriverSettings settings;
  settings.kind = DriverKind::kMock;
  EXPECT_THROW(make_drivers(settings, wheels_on(1, 1)), DriverStartupError);
  EXPECT_THROW(make_drivers(settings, wheels_on(0, 2)), DriverStartupError);
  EXPECT_THROW(make_drivers(settings, wheels_on(1, 5)), DriverStartupError);  // axis_count 4
  settings.sim_speedup = 0;
  EXPECT_THROW(make_drivers(settings, wheels_on(1, 2)), DriverStartupError);
  settings.sim_speedup = 1;
  settings.kind = DriverKind::kSim;
  settings.card.library_path = "/nonexistent-ajar-dir/libajar_gts_sim.so";
  try {
    (void)make_drivers(settings, wheels_on(1, 2));
    FAIL() << "no exception";
  } catch (const DriverStartupError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-ajar-dir/libajar_gts_sim.so"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace ajar::drivers
