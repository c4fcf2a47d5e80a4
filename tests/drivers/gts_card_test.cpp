// The GTS driver over the card simulator: start-up errors, the vendor-code table, the calls it
// makes, and the simulator's fault cases (drive alarm, following error, limit hit, no response,
// open failure, slow calls).
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "ajar/drivers/gts_abi.hpp"
#include "ajar/drivers/factory.hpp"
#include "ajar/drivers/gts_card.hpp"
#include "ajar/drivers/gts_sim_control.hpp"
#include "ajar/drivers/lifecycle.hpp"
#include "card_test_support.hpp"

namespace ajar::drivers {
namespace {

using testing::failure_text;
using testing::kFastTimeScale;
using testing::status_of;
using testing::wait_until;

using testing::kWheels;

class GtsOverSimulator : public ::testing::Test {
 protected:
  void SetUp() override {
    sim_.reset();
    sim_.set_time_scale(kFastTimeScale);
  }
  void TearDown() override { sim_.reset(); }

  std::unique_ptr<GtsMotionCard> open_card(
      GtsCardSettings settings = testing::card_sim_settings()) {
    auto card = std::make_unique<GtsMotionCard>(std::move(settings));
    EXPECT_TRUE(card->open().ok());
    return card;
  }
  std::unique_ptr<GtsMotionCard> enabled_card() {
    auto card = open_card();
    EXPECT_EQ(card->enable_axes(kWheels), ErrorCode::kOk) << failure_text(*card);
    EXPECT_TRUE(wait_until([&] { return status_of(*card, 2) && status_of(*card, 2)->enabled; }));
    return card;
  }
  static ErrorCode long_move(MotionCard& card, std::int64_t sign = 1) {
    const AxisMove moves[] = {{1, sign * 100'000'000}, {2, sign * 100'000'000}};
    return card.move_relative(moves, TrapezoidProfile{1.0, 0.5, 0.5, 0});
  }

  GtsSimControl sim_{testing::card_sim_path()};
};

// --- start-up ---------------------------------------------------------------------------------

TEST(GtsStartup, MissingLibraryIsAStartupErrorNamingThePath) {
  GtsCardSettings s;
  s.library_path = "/nonexistent-ajar-dir/libgts.so";
  try {
    GtsMotionCard card(s);
    FAIL() << "no exception";
  } catch (const DriverStartupError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-ajar-dir/libgts.so"), std::string::npos)
        << e.what();
  }
}

TEST(GtsStartup, MissingSymbolIsAStartupErrorNamingTheSymbol) {
  GtsCardSettings s;
  s.library_path = testing::card_sim_nostop_path();
  try {
    GtsMotionCard card(s);
    FAIL() << "no exception";
  } catch (const DriverStartupError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("GT_Stop"), std::string::npos) << what;
    EXPECT_NE(what.find(s.library_path), std::string::npos) << what;
  }
}

TEST(GtsStartup, FactoryFailsAtStartupForAMissingVendorLibrary) {
  DriverSettings settings;
  settings.kind = DriverKind::kReal;
  settings.card.library_path = "/nonexistent-ajar-dir/libgts.so";
  try {
    (void)make_drivers(settings, core::BaseGeometry{});
    FAIL() << "no exception";
  } catch (const DriverStartupError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-ajar-dir/libgts.so"), std::string::npos);
  }
}

TEST(GtsStartup, EmptyPathAndBadAxisCountAreRefused) {
  GtsCardSettings s;
  EXPECT_THROW(GtsMotionCard{s}, DriverStartupError);
  s.library_path = testing::card_sim_path();
  s.axis_count = 9;
  EXPECT_THROW(GtsMotionCard{s}, DriverStartupError);
}

// --- vendor codes -----------------------------------------------------------------------------

struct CodeCase {
  short code;
  ErrorCode expected;
  const char* meaning;
};
constexpr CodeCase kCodes[] = {
    {1, ErrorCode::kDriverError, "execution error"},
    {7, ErrorCode::kCardBadParameter, "bad parameter"},
    {-1, ErrorCode::kCardCommunication, "communication failure"},
    {-2, ErrorCode::kCardCommunication, "communication failure"},
    {-3, ErrorCode::kCardCommunication, "communication failure"},
    {-4, ErrorCode::kCardCommunication, "communication failure"},
    {-5, ErrorCode::kCardCommunication, "communication failure"},
    {-6, ErrorCode::kCardOpenFailed, "open failed"},
    {-7, ErrorCode::kCardCommunication, "no response"},
    {-8, ErrorCode::kCardBusy, "resource busy"},
    {42, ErrorCode::kDriverError, "unknown vendor code"},
};

TEST(GtsErrors, EveryVendorCodeMapsToANamedError) {
  for (const CodeCase& c : kCodes) {
    const Error e = gts_error(c.code, "GT_Update", 3);
    EXPECT_EQ(e.code, c.expected) << c.code;
    EXPECT_NE(e.message.find("GT_Update(axis 3)"), std::string::npos) << e.message;
    EXPECT_NE(e.message.find(c.meaning), std::string::npos) << e.message;
    EXPECT_NE(e.message.find(std::to_string(c.code)), std::string::npos) << e.message;
  }
}

TEST_F(GtsOverSimulator, VendorCodesFromTheCardReachTheCallerNamed) {
  auto card = enabled_card();
  for (const CodeCase& c : kCodes) {
    sim_.fail_next_calls("GT_GetSts", c.code, 1);
    AxisStatus st;
    EXPECT_EQ(card->axis_status(2, st), c.expected) << c.code;
    const CardFailure f = card->last_failure();
    EXPECT_EQ(f.code, c.expected);
    EXPECT_EQ(f.vendor_code, c.code);  // the raw code, for the I/O side to name
    EXPECT_EQ(f.axis, 2);
    EXPECT_STREQ(f.call, "GT_GetSts");
    const std::string text = describe(f);
    EXPECT_NE(text.find("GT_GetSts(axis 2)"), std::string::npos) << text;
    EXPECT_NE(text.find(c.meaning), std::string::npos) << text;
    EXPECT_TRUE(status_of(*card, 2).has_value());  // the rule was for one call only
  }
}

// --- the calls the driver makes ---------------------------------------------------------------

TEST_F(GtsOverSimulator, MoveStartsAllAxesWithOneUpdate) {
  auto card = open_card();
  const int axes[] = {1, 3};
  ASSERT_TRUE(card->enable_axes(axes) == ErrorCode::kOk);
  ASSERT_TRUE(wait_until([&] { return status_of(*card, 3)->enabled; }));
  const int updates = sim_.call_count("GT_Update");
  const AxisMove moves[] = {{1, 1000}, {3, -1000}};
  ASSERT_TRUE(card->move_relative(moves, TrapezoidProfile{}) == ErrorCode::kOk);
  EXPECT_EQ(sim_.call_count("GT_Update"), updates + 1);
  EXPECT_EQ(sim_.last_update_mask(), 0b101);
  EXPECT_EQ(sim_.call_count("GT_PrfTrap"), 2);
  EXPECT_EQ(sim_.call_count("GT_SetTrapPrm"), 2);
  EXPECT_EQ(sim_.call_count("GT_SetPos"), 2);
  EXPECT_EQ(sim_.call_count("GT_SetVel"), 2);
}

TEST_F(GtsOverSimulator, StopsUseTheOptionMaskForEmergencyOnly) {
  auto card = enabled_card();
  long mask = 0;
  long option = -1;
  const int axes[] = {2, 4};
  ASSERT_TRUE(card->smooth_stop(axes) == ErrorCode::kOk);
  sim_.last_stop(&mask, &option);
  EXPECT_EQ(mask, 0b1010);
  EXPECT_EQ(option, 0);
  ASSERT_TRUE(card->emergency_stop(axes) == ErrorCode::kOk);
  sim_.last_stop(&mask, &option);
  EXPECT_EQ(mask, 0b1010);
  EXPECT_EQ(option, 0b1010);
}

TEST_F(GtsOverSimulator, StopWithAnInvalidAxisStillStopsTheValidOnes) {
  auto card = enabled_card();
  ASSERT_TRUE(long_move(*card) == ErrorCode::kOk);
  const int axes[] = {1, 2, 9};
  EXPECT_EQ(card->emergency_stop(axes), ErrorCode::kCardBadParameter);
  EXPECT_EQ(card->last_failure().axis, 9);
  EXPECT_FALSE(status_of(*card, 1)->moving);
  EXPECT_FALSE(status_of(*card, 2)->moving);
}

TEST_F(GtsOverSimulator, OpenLoadsTheCardConfigAndNamesItWhenMissing) {
  GtsCardSettings s = testing::card_sim_settings();
  s.card_config_path = "/nonexistent-ajar-dir/gts.cfg";
  GtsMotionCard card(s);
  const auto opened = card.open();
  ASSERT_FALSE(opened.ok());
  EXPECT_NE(opened.error().message.find("/nonexistent-ajar-dir/gts.cfg"), std::string::npos);

  char dir_template[] = "/tmp/ajar-card-XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string cfg = std::string(dir_template) + "/gts.cfg";
  std::ofstream(cfg) << "[axis1]\n";
  s.card_config_path = cfg;
  GtsMotionCard card2(s);
  EXPECT_TRUE(card2.open().ok());
  EXPECT_EQ(sim_.call_count("GT_LoadConfig"), 2);
  std::remove(cfg.c_str());
  rmdir(dir_template);
}

// An open() that fails after GT_Open succeeded (here GT_LoadConfig) closes the card again: the
// driver does not report "failed" while holding the card open (the lifecycle wrapper stays
// unconfigured, so nothing else would ever close it before the driver is destroyed).
TEST_F(GtsOverSimulator, FailedOpenAfterGtOpenClosesTheCardAgain) {
  GtsCardSettings s = testing::card_sim_settings();
  s.card_config_path = "/nonexistent-ajar-dir/gts.cfg";
  GtsMotionCard card(s);
  ASSERT_FALSE(card.open().ok());
  EXPECT_EQ(sim_.call_count("GT_Open"), 1);
  EXPECT_EQ(sim_.call_count("GT_Close"), 1);
  ASSERT_FALSE(status_of(card, 1).has_value());
  EXPECT_NE(failure_text(card).find("not open"), std::string::npos) << failure_text(card);

  sim_.fail_next_calls("GT_Reset", gts::kCmdNoResponse, 1);
  GtsMotionCard card2(testing::card_sim_settings());
  const auto opened = card2.open();
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.error().code, ErrorCode::kCardCommunication);
  EXPECT_EQ(sim_.call_count("GT_Close"), 2);
  EXPECT_TRUE(card2.open().ok());  // a retry opens it
}

TEST_F(GtsOverSimulator, EncoderLagsTheProfileWhileMovingAndMeetsItAtRest) {
  sim_.set_encoder_lag_ms(5);
  auto card = enabled_card();
  const AxisMove moves[] = {{1, 1'000'000'000}};
  ASSERT_TRUE(card->move_relative(moves, TrapezoidProfile{10, 1, 1, 0}) == ErrorCode::kOk);
  ASSERT_TRUE(wait_until([&] { return status_of(*card, 1)->profile_position_counts > 1000; }));
  // Cruising at 10 counts/ms. Nearly freeze simulated time so that the separate position reads
  // of one axis_status() see the same instant.
  sim_.set_time_scale(1e-6);
  const AxisStatus moving = *status_of(*card, 1);
  ASSERT_TRUE(moving.moving);
  EXPECT_EQ(moving.profile_position_counts - moving.encoder_position_counts, 50);  // 5 ms x 10
  sim_.set_time_scale(kFastTimeScale);
  ASSERT_TRUE(card->smooth_stop(kWheels) == ErrorCode::kOk);
  ASSERT_TRUE(wait_until([&] { return !status_of(*card, 1)->moving; }));
  const AxisStatus rest = *status_of(*card, 1);
  EXPECT_EQ(rest.encoder_position_counts, rest.profile_position_counts);
}

// --- simulator fault cases --------------------------------------------------------------------

TEST_F(GtsOverSimulator, DriveAlarmDuringMotionStopsTheAxisAndLatchesTheWrapper) {
  const int wheels[] = {1, 2};
  ManagedMotionCard card(std::make_unique<GtsMotionCard>(testing::card_sim_settings()), wheels);
  ASSERT_TRUE(card.configure().ok());
  ASSERT_TRUE(card.activate().ok());
  ASSERT_TRUE(long_move(card) == ErrorCode::kOk);
  sim_.inject_fault(1, SimFault::kDriveAlarm);
  const AxisStatus st = *status_of(card, 1);
  EXPECT_TRUE(st.alarm);
  EXPECT_FALSE(st.moving);
  EXPECT_FALSE(st.enabled);
  EXPECT_EQ(card.state(), LifecycleState::kFault);
  // Refused with the root cause the wrapper latched, not a bare "not active".
  EXPECT_EQ(long_move(card), ErrorCode::kAxisAlarm);
  EXPECT_TRUE(card.emergency_stop(wheels) == ErrorCode::kOk);  // stops pass in fault
  ASSERT_TRUE(card.recover().ok());
  EXPECT_EQ(card.state(), LifecycleState::kInactive);
  ASSERT_TRUE(card.activate().ok());
  EXPECT_TRUE(status_of(card, 1)->enabled);
}

TEST_F(GtsOverSimulator, FollowingErrorDuringMotionStopsAndShowsInTheEncoder) {
  auto card = enabled_card();
  ASSERT_TRUE(long_move(*card) == ErrorCode::kOk);
  sim_.inject_fault(2, SimFault::kFollowingError);
  const AxisStatus st = *status_of(*card, 2);
  EXPECT_TRUE(st.following_error);
  EXPECT_FALSE(st.moving);
  EXPECT_GE(std::llabs(st.encoder_position_counts - st.profile_position_counts), 100);
  EXPECT_TRUE(status_of(*card, 1)->moving);  // only the faulted axis stopped
  ASSERT_TRUE(card->clear_faults(kWheels) == ErrorCode::kOk);
  const AxisStatus cleared = *status_of(*card, 2);
  EXPECT_FALSE(cleared.following_error);
  EXPECT_EQ(cleared.encoder_position_counts, cleared.profile_position_counts);
  ASSERT_TRUE(card->emergency_stop(kWheels) == ErrorCode::kOk);
}

TEST_F(GtsOverSimulator, LimitHitDuringMotionStopsTheAxisMovingIntoIt) {
  auto card = enabled_card();
  ASSERT_TRUE(long_move(*card, -1) == ErrorCode::kOk);
  sim_.inject_fault(1, SimFault::kPositiveLimit);  // not in the direction of travel
  EXPECT_TRUE(status_of(*card, 1)->moving);
  sim_.inject_fault(1, SimFault::kNegativeLimit);
  const AxisStatus st = *status_of(*card, 1);
  EXPECT_TRUE(st.negative_limit);
  EXPECT_FALSE(st.moving);
  const AxisMove further[] = {{1, -10}};
  EXPECT_EQ(card->move_relative(further, TrapezoidProfile{}), ErrorCode::kLimitHit);
  ASSERT_TRUE(card->emergency_stop(kWheels) == ErrorCode::kOk);
}

TEST_F(GtsOverSimulator, NoResponseLatchesTheWrapperUntilTheCardAnswersAgain) {
  const int wheels[] = {1, 2};
  ManagedMotionCard card(std::make_unique<GtsMotionCard>(testing::card_sim_settings()), wheels);
  ASSERT_TRUE(card.configure().ok());
  ASSERT_TRUE(card.activate().ok());
  sim_.fail_next_calls("*", gts::kCmdNoResponse, -1);
  AxisStatus st;
  EXPECT_EQ(card.axis_status(1, st), ErrorCode::kCardCommunication);
  EXPECT_NE(failure_text(card).find("no response"), std::string::npos) << failure_text(card);
  EXPECT_EQ(card.state(), LifecycleState::kFault);
  EXPECT_FALSE(card.recover().ok());  // still silent
  EXPECT_EQ(card.state(), LifecycleState::kFault);
  sim_.fail_next_calls("*", 0, 0);
  ASSERT_TRUE(card.recover().ok());
  EXPECT_EQ(card.state(), LifecycleState::kInactive);
}

TEST_F(GtsOverSimulator, OpenFailureIsReportedAndARetryWorks) {
  sim_.fail_next_calls("GT_Open", gts::kCmdOpenFailed, 1);
  const int wheels[] = {1, 2};
  ManagedMotionCard card(std::make_unique<GtsMotionCard>(testing::card_sim_settings()), wheels);
  const auto s = card.configure();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kCardOpenFailed);
  EXPECT_NE(s.error().message.find("GT_Open"), std::string::npos);
  EXPECT_EQ(card.state(), LifecycleState::kUnconfigured);
  EXPECT_TRUE(card.configure().ok());
  EXPECT_EQ(card.state(), LifecycleState::kInactive);
}

TEST_F(GtsOverSimulator, SlowCallsStillGiveCorrectResults) {
  sim_.set_call_delay_us(2000);
  auto card = enabled_card();
  const AxisMove moves[] = {{1, 2000}, {2, 2000}};
  ASSERT_TRUE(card->move_relative(moves, TrapezoidProfile{10, 1, 1, 0}) == ErrorCode::kOk);
  ASSERT_TRUE(wait_until([&] { return !status_of(*card, 1)->moving; }));
  EXPECT_EQ(status_of(*card, 1)->profile_position_counts, 2000);
}

TEST_F(GtsOverSimulator, EnableIssuesServoOnWithoutWaiting) {
  // Simulated time nearly stands still: the servo would take ~5000 s of real time to come on.
  // enable_axes() returns at once all the same; the servo shows later.
  sim_.set_time_scale(1e-6);
  auto card = open_card();
  ASSERT_EQ(card->enable_axes(kWheels), ErrorCode::kOk) << failure_text(*card);
  EXPECT_EQ(sim_.call_count("GT_AxisOn"), 2);
  EXPECT_FALSE(status_of(*card, 1)->enabled);
  sim_.set_time_scale(kFastTimeScale);
  EXPECT_TRUE(wait_until([&] { return status_of(*card, 1)->enabled; }));
}

TEST_F(GtsOverSimulator, EnableRefusesAnAlarmedAxisBeforeSwitchingAnyOn) {
  auto card = open_card();
  sim_.inject_fault(2, SimFault::kDriveAlarm);
  EXPECT_EQ(card->enable_axes(kWheels), ErrorCode::kAxisAlarm);
  EXPECT_EQ(card->last_failure().axis, 2);
  EXPECT_EQ(sim_.call_count("GT_AxisOn"), 0);
}

TEST_F(GtsOverSimulator, ActivateGivesUpWaitingForTheServoAtItsDeadline) {
  sim_.set_time_scale(1e-6);
  const int wheels[] = {1, 2};
  ManagedMotionCard card(std::make_unique<GtsMotionCard>(testing::card_sim_settings()), wheels,
                         5000, 20);
  ASSERT_TRUE(card.configure().ok());
  const auto activated = card.activate();
  ASSERT_FALSE(activated.ok());
  EXPECT_EQ(activated.error().code, ErrorCode::kMotionTimeout);
  EXPECT_NE(activated.error().message.find("20 ms"), std::string::npos)
      << activated.error().message;
  EXPECT_EQ(card.state(), LifecycleState::kInactive);
}

TEST_F(GtsOverSimulator, SimulatorToleratesAControlThreadBesideTheCardThread) {
  auto card = enabled_card();
  std::atomic<bool> done{false};
  std::thread control([&] {
    while (!done.load()) {
      (void)sim_.now_ms();
      sim_.inject_fault(3, SimFault::kPositiveLimit);
      sim_.inject_fault(3, SimFault::kNone);
      (void)sim_.call_count("GT_GetSts");
    }
  });
  const AxisMove moves[] = {{1, 3000}};
  ASSERT_TRUE(card->move_relative(moves, TrapezoidProfile{10, 1, 1, 0}) == ErrorCode::kOk);
  EXPECT_TRUE(wait_until([&] { return !status_of(*card, 1)->moving; }));
  done.store(true);
  control.join();
  EXPECT_EQ(status_of(*card, 1)->profile_position_counts, 3000);
}

}  // namespace
}  // namespace ajar::drivers
