// The control loop driven cycle by cycle with a fake clock (no thread, no timing) over the
// deterministic mock card behind the lifecycle wrapper, plus a few checks of the real thread (over
// the mock card on the steady clock) that wait on conditions.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "ajar/core/geometry.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/realtime.hpp"
#include "det_mock_card.hpp"

namespace ajar::daemon {
namespace {

using drivers::CardCall;

using ajar::testing::kMs;

class ControlLoopTest : public ::testing::Test {
 protected:
  void SetUp() override {
    settings.control.rate_hz = 500;
    settings.safety.deadman_timeout_s = 0.5;
    settings.control.motion_timeout_margin_s = 2.0;
    make_loop();
  }
  // A loop over a new card: on the test's clock, or (real_clock) a plain mock on the steady clock.
  void make_loop(bool real_clock = false) {
    loop.reset();
    managed.reset();
    const int axes[2] = {settings.base.left.card_axis, settings.base.right.card_axis};
    auto mock =
        real_clock ? std::make_unique<drivers::MockMotionCard>() : testing::make_det_card(clock);
    card = mock.get();
    managed = std::make_unique<drivers::ManagedMotionCard>(std::move(mock), axes);
    ASSERT_TRUE(managed->configure().ok());
    ASSERT_TRUE(managed->activate().ok());
    loop = std::make_unique<ControlLoop>(*managed, settings);
  }
  // Runs n cycles, 2 ms apart, keeping the controller's heartbeat fresh when asked.
  void run(int n, bool heartbeat = true) {
    for (int i = 0; i < n; ++i) {
      clock.advance_ns(2 * kMs);
      if (heartbeat) loop->heartbeat(now());
      loop->cycle(now());
    }
  }
  std::vector<LoopReport> reports() {
    std::vector<LoopReport> out;
    LoopReport r;
    while (loop->pop_report(r))
      out.push_back(r);
    return out;
  }
  static bool has(const std::vector<LoopReport>& rs, LoopReportKind kind,
                  ErrorCode code = ErrorCode::kOk) {
    for (const auto& r : rs) {
      if (r.kind == kind && r.code == code) return true;
    }
    return false;
  }

  ControlLoopSettings settings;
  drivers::MockMotionCard* card = nullptr;  // managed's
  std::unique_ptr<drivers::ManagedMotionCard> managed;
  std::unique_ptr<ControlLoop> loop;
  testing::FakeClock clock;
  std::int64_t now() const { return clock.now_ns(); }
};

TEST(WheelProfile, ConvertsWheelLimitsToCardUnits) {
  core::BaseGeometry base;  // 1 rad/s, 2 rad/s^2, 50:1, 10000 counts/rev
  const auto p = wheel_profile(base);
  const double counts_per_rad = 50.0 * 10000.0 / (2 * 3.14159265358979323846);
  EXPECT_NEAR(p.velocity_counts_per_ms, 1.0 * counts_per_rad / 1e3, 1e-9);
  EXPECT_NEAR(p.acceleration_counts_per_ms2, 2.0 * counts_per_rad / 1e6, 1e-12);
  EXPECT_EQ(p.deceleration_counts_per_ms2, p.acceleration_counts_per_ms2);
  // Triangular (short) and trapezoidal (long) durations.
  EXPECT_NEAR(planned_duration_s(1000, p),
              2.0 * std::sqrt(1000 / p.acceleration_counts_per_ms2) / 1e3, 1e-9);
  const double v = p.velocity_counts_per_ms, a = p.acceleration_counts_per_ms2;
  EXPECT_NEAR(planned_duration_s(-1'000'000, p), (1e6 / v + v / a) / 1e3, 1e-9);
  EXPECT_EQ(planned_duration_s(0, p), 0.0);
}

TEST_F(ControlLoopTest, RunsAMoveToCompletion) {
  ASSERT_TRUE(loop->post_move({7, 1200, -1200}));
  run(30);
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMotionFinished);
  EXPECT_EQ(rs[0].motion_id, 7U);
  EXPECT_EQ(card->calls(CardCall::kMoveRelative), 1U);
  const auto log = card->log_from(0);
  ASSERT_FALSE(log.empty());
  ASSERT_EQ(log.back().kind, CardCall::kMoveRelative);
  const auto moves = log.back().moves;
  const auto profile = log.back().profile;
  ASSERT_EQ(moves.size(), 2U);
  EXPECT_EQ(moves[0].axis, settings.base.left.card_axis);
  EXPECT_EQ(moves[0].distance_counts, 1200);
  EXPECT_EQ(moves[1].axis, settings.base.right.card_axis);
  EXPECT_EQ(moves[1].distance_counts, -1200);
  EXPECT_NEAR(profile.velocity_counts_per_ms, wheel_profile(settings.base).velocity_counts_per_ms,
              1e-12);
  const LoopSnapshot s = loop->snapshot();
  EXPECT_FALSE(s.motion_active);
  EXPECT_EQ(s.fault, ErrorCode::kOk);
  EXPECT_EQ(s.left_counts, 1200);
  EXPECT_EQ(s.right_counts, -1200);
}

TEST_F(ControlLoopTest, PublishesOdometryFromEncoderCounts) {
  ASSERT_TRUE(loop->post_move({1, -5000, -5000}));  // polarity: right is -1, so both roll...
  run(40);                                          // 63 ms at the wheels' top speed
  const LoopSnapshot s = loop->snapshot();
  const double left = core::counts_to_wheel_rad(-5000, settings.base.left, settings.base);
  const double right = core::counts_to_wheel_rad(-5000, settings.base.right, settings.base);
  EXPECT_DOUBLE_EQ(s.left_wheel_rad, left);
  EXPECT_DOUBLE_EQ(s.right_wheel_rad, right);
  EXPECT_DOUBLE_EQ(s.base_yaw_rad, core::base_yaw_from_wheels_rad(left, right, settings.base));
  EXPECT_NE(s.base_yaw_rad, 0.0);
}

TEST_F(ControlLoopTest, CommandQueueIsBoundedAndSaysWhenFull) {
  for (std::size_t i = 0; i < ControlLoop::kCommandQueueCapacity; ++i) {
    ASSERT_TRUE(loop->post_move({static_cast<std::uint32_t>(i + 1), 10, 10}));
  }
  EXPECT_FALSE(loop->post_move({999, 10, 10}));
  run(1);
  // The first move starts; the others are refused while it runs, none is lost silently.
  const auto rs = reports();
  EXPECT_EQ(rs.size(), ControlLoop::kCommandQueueCapacity - 1);
  EXPECT_TRUE(has(rs, LoopReportKind::kMoveRefused, ErrorCode::kMotionInProgress));
  EXPECT_TRUE(loop->post_move({1000, 10, 10}));
}

TEST_F(ControlLoopTest, AxisAlarmDuringMotionStopsAndLatches) {
  card->stick_next_move();
  ASSERT_TRUE(loop->post_move({1, 50000, -50000}));
  run(3);
  card->inject_alarm(settings.base.right.card_axis);
  run(5);
  auto rs = reports();
  ASSERT_TRUE(has(rs, LoopReportKind::kFault, ErrorCode::kAxisAlarm));
  for (const auto& r : rs) {
    if (r.kind == LoopReportKind::kFault) {
      EXPECT_EQ(r.axis, settings.base.right.card_axis);
    }
  }
  EXPECT_GE(card->calls(CardCall::kSmoothStop), 1U);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kAxisAlarm);

  // No move starts with the fault latched.
  ASSERT_TRUE(loop->post_move({2, 10, 10}));
  run(1);
  rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kMoveRefused, ErrorCode::kFaultLatched));
  EXPECT_EQ(card->calls(CardCall::kMoveRelative), 1U);

  // Recover clears the card and the latch (a few cycles: clear, enable, servo on); the next move
  // runs.
  ASSERT_TRUE(loop->request_recover(1));
  run(4);
  EXPECT_TRUE(has(reports(), LoopReportKind::kRecovered, ErrorCode::kOk));
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);
  ASSERT_TRUE(loop->post_move({3, 10, 10}));
  run(30);
  EXPECT_TRUE(has(reports(), LoopReportKind::kMotionFinished));
}

TEST_F(ControlLoopTest, MotionDeadlineStopsAndLatchesTimeout) {
  card->stick_next_move();
  ASSERT_TRUE(loop->post_move({1, 1000, -1000}));
  run(1);
  const auto profile = wheel_profile(settings.base);
  const double deadline_s =
      planned_duration_s(1000, profile) * 1.5 + settings.control.motion_timeout_margin_s;
  const int cycles = static_cast<int>(deadline_s / 0.002) + 2;
  run(cycles - 3);
  EXPECT_TRUE(reports().empty());  // not before the deadline
  run(5);
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kFault, ErrorCode::kMotionTimeout));
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionStopped, ErrorCode::kMotionTimeout));
}

TEST_F(ControlLoopTest, DeadmanStopsASilentControllersMotion) {
  card->stick_next_move();
  loop->heartbeat(now());
  ASSERT_TRUE(loop->post_move({1, 100000, -100000}));
  const int silent_cycles = static_cast<int>(settings.safety.deadman_timeout_s / 0.002);
  run(silent_cycles - 2, /*heartbeat=*/false);
  EXPECT_TRUE(reports().empty());
  run(10, /*heartbeat=*/false);
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kFault, ErrorCode::kDeadman));
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionStopped, ErrorCode::kDeadman));
  EXPECT_GE(card->calls(CardCall::kSmoothStop), 1U);
}

TEST_F(ControlLoopTest, FreshHeartbeatsKeepTheMotionGoing) {
  ASSERT_TRUE(loop->post_move({1, 1000, -1000}));
  run(400, /*heartbeat=*/true);  // far longer than the deadman timeout
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionFinished));
  EXPECT_FALSE(has(rs, LoopReportKind::kFault, ErrorCode::kDeadman));
}

TEST_F(ControlLoopTest, DeadmanAlsoWatchesTheArm) {
  loop->heartbeat(now());
  loop->set_arm_moving(true);
  run(static_cast<int>(settings.safety.deadman_timeout_s / 0.002) + 2, false);
  EXPECT_TRUE(has(reports(), LoopReportKind::kFault, ErrorCode::kDeadman));
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kDeadman);
}

TEST_F(ControlLoopTest, IdleWithoutHeartbeatIsNotAFault) {
  run(1000, false);
  EXPECT_TRUE(reports().empty());
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);
}

TEST_F(ControlLoopTest, EmergencyStopReachesTheCardInTheNextCycle) {
  card->stick_next_move();
  ASSERT_TRUE(loop->post_move({1, 100000, -100000}));
  run(2);
  loop->request_emergency_stop();
  EXPECT_EQ(card->calls(CardCall::kEmergencyStop), 0U);
  run(1);
  EXPECT_EQ(card->calls(CardCall::kEmergencyStop), 1U);
  run(2);
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kFault, ErrorCode::kEmergencyStopped));
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionStopped, ErrorCode::kEmergencyStopped));
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kEmergencyStopped);
}

TEST_F(ControlLoopTest, EmergencyStopWhileIdleStillLatches) {
  loop->request_emergency_stop();
  run(1);
  EXPECT_EQ(card->calls(CardCall::kEmergencyStop), 1U);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kEmergencyStopped);
}

TEST_F(ControlLoopTest, StopEndsMotionSmoothlyWithoutFault) {
  card->stick_next_move();
  ASSERT_TRUE(loop->post_move({1, 100000, -100000}));
  run(2);
  loop->request_stop();
  run(5);
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionStopped, ErrorCode::kOk));
  EXPECT_FALSE(has(rs, LoopReportKind::kFault, ErrorCode::kOk));
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);
  EXPECT_FALSE(loop->snapshot().motion_active);
  EXPECT_GE(card->calls(CardCall::kSmoothStop), 1U);
  EXPECT_EQ(card->calls(CardCall::kEmergencyStop), 0U);
}

TEST_F(ControlLoopTest, FaultStopLatchesTheGivenCode) {
  card->stick_next_move();
  ASSERT_TRUE(loop->post_move({1, 100000, -100000}));
  run(2);
  loop->request_fault_stop(ErrorCode::kDeadman);
  run(5);
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kFault, ErrorCode::kDeadman));
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionStopped, ErrorCode::kDeadman));
}

TEST_F(ControlLoopTest, AStopThatNeverEndsBecomesAnEmergencyStop) {
  card->stick_next_move();
  card->set_stops_never_rest(true);
  ASSERT_TRUE(loop->post_move({1, 100000, -100000}));
  run(2);
  loop->request_stop();
  run(5000);  // 10 s of fake time: beyond the stop deadline
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionStopped, ErrorCode::kMotionTimeout));
  EXPECT_TRUE(has(rs, LoopReportKind::kFault, ErrorCode::kMotionTimeout));
  EXPECT_GE(card->calls(CardCall::kEmergencyStop), 1U);
}

// A card that misses one cycle's status reads while nothing runs: its lifecycle wrapper latches
// CARD_COMMUNICATION and refuses every move until recovered, so the loop latches it then, where it
// happened (before: no fault, the card shown active, and the operator's next move, acknowledged,
// failed with CARD_COMMUNICATION at once; found live, tests/attack/card_moves.py).
TEST_F(ControlLoopTest, ACardThatDoesNotAnswerWhileIdleLatchesAtOnce) {
  run(3);
  card->fail_next_calls(2);  // both axis_status reads of the next cycle fail
  run(1);
  EXPECT_TRUE(has(reports(), LoopReportKind::kFault, ErrorCode::kCardCommunication));
  run(5);  // it answers again; the wrapper still refuses moves, and the latch says so
  EXPECT_EQ(managed->state(), drivers::LifecycleState::kFault);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kCardCommunication);
  EXPECT_EQ(loop->snapshot().card_state, drivers::LifecycleState::kFault);

  ASSERT_TRUE(loop->request_recover(1));
  run(4);
  EXPECT_TRUE(has(reports(), LoopReportKind::kRecovered, ErrorCode::kOk));
  EXPECT_EQ(managed->state(), drivers::LifecycleState::kActive);
  ASSERT_TRUE(loop->post_move({2, 1200, -1200}));
  run(30);
  EXPECT_TRUE(has(reports(), LoopReportKind::kMotionFinished));
}

// A following error reported while nothing runs latches at once with its axis, as a drive alarm
// does (before: no fault and the card shown active, while its lifecycle wrapper had latched it; the
// next move, acknowledged, failed with FOLLOWING_ERROR and no axis).
TEST_F(ControlLoopTest, AFollowingErrorWhileIdleLatchesWithItsAxis) {
  run(3);
  card->inject_following_error(settings.base.right.card_axis);
  run(1);
  bool latched = false;
  for (const auto& r : reports()) {
    if (r.kind == LoopReportKind::kFault && r.code == ErrorCode::kFollowingError) {
      latched = true;
      EXPECT_EQ(r.axis, settings.base.right.card_axis);
    }
  }
  EXPECT_TRUE(latched);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kFollowingError);
  EXPECT_EQ(loop->snapshot().card_state, drivers::LifecycleState::kFault);

  ASSERT_TRUE(loop->request_recover(1));  // clears the card's fault
  run(4);
  EXPECT_TRUE(has(reports(), LoopReportKind::kRecovered, ErrorCode::kOk));
  ASSERT_TRUE(loop->post_move({2, 1200, -1200}));
  run(30);
  EXPECT_TRUE(has(reports(), LoopReportKind::kMotionFinished));
}

// The same while a smooth stop runs: latched, and the stop still ends once the wheels rest.
TEST_F(ControlLoopTest, ACardThatDoesNotAnswerWhileTheWheelsStopLatches) {
  card->stick_next_move();
  ASSERT_TRUE(loop->post_move({1, 100000, -100000}));
  run(2);
  loop->request_stop();
  run(1);  // the smooth stop is sent
  card->fail_next_calls(2);
  run(1);
  run(10);
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kFault, ErrorCode::kCardCommunication));
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionStopped, ErrorCode::kOk));
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kCardCommunication);
  EXPECT_FALSE(loop->snapshot().motion_active);
  EXPECT_FALSE(card->any_moving());
}

// A following error seen while a stop runs latches in that cycle, with its axis (before: only a
// flag still set once the wheels rested was seen, by the idle check; a transient one was latched by
// the card's lifecycle wrapper alone, and the next move, acknowledged, failed without the axis).
TEST_F(ControlLoopTest, AFollowingErrorWhileTheWheelsStopLatchesWithItsAxis) {
  ASSERT_TRUE(loop->post_move({1, 100000, -100000}));
  run(2);
  loop->request_stop();
  run(1);  // the smooth stop is sent
  card->inject_following_error(settings.base.left.card_axis);
  run(1);
  bool latched = false;
  for (const auto& r : reports()) {
    if (r.kind == LoopReportKind::kFault && r.code == ErrorCode::kFollowingError) {
      latched = true;
      EXPECT_EQ(r.axis, settings.base.left.card_axis);
    }
  }
  EXPECT_TRUE(latched);
  run(10);
  EXPECT_FALSE(loop->snapshot().motion_active);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kFollowingError);
}

// A smooth stop the card answers with an error: emergency-stopped instead, and the error latches
// (before: nothing latched, while the card's lifecycle wrapper had latched CARD_COMMUNICATION and
// refused every move: the next Drive, acknowledged, failed at once; found live).
TEST_F(ControlLoopTest, AStopTheCardAnswersWithAnErrorLatchesIt) {
  card->stick_next_move();
  ASSERT_TRUE(loop->post_move({1, 100000, -100000}));
  run(2);
  card->fail_after_next_call(CardCall::kSmoothStop);
  loop->request_stop();
  run(1);
  EXPECT_TRUE(has(reports(), LoopReportKind::kFault, ErrorCode::kCardCommunication));
  EXPECT_GE(card->calls(CardCall::kEmergencyStop), 1U);
  run(10);
  EXPECT_FALSE(loop->snapshot().motion_active);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kCardCommunication);
  EXPECT_EQ(managed->state(), drivers::LifecycleState::kFault);
}

TEST_F(ControlLoopTest, CardRefusingTheMoveLatchesAndReports) {
  card->refuse_next_move(ErrorCode::kCardBadParameter);
  ASSERT_TRUE(loop->post_move({4, 10, 10}));
  run(1);
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kMoveRefused, ErrorCode::kCardBadParameter));
  EXPECT_TRUE(has(rs, LoopReportKind::kFault, ErrorCode::kCardBadParameter));
}

TEST_F(ControlLoopTest, ThreadRunsAndHealthFollowsTheLoop) {
  settings.control.realtime = true;  // refused without privileges: a warning, and it still runs
  settings.control.lock_memory = true;
  make_loop(/*real_clock=*/true);
  EXPECT_FALSE(loop->healthy(monotonic_now_ns()));
  const auto warnings = loop->start_thread();
  for (const auto& w : warnings) {
    EXPECT_TRUE(w.find("control.realtime") != std::string::npos ||
                w.find("control.lock_memory") != std::string::npos)
        << w;
  }
  const auto wait_for = [&](auto pred) {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!pred() && std::chrono::steady_clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return pred();
  };
  EXPECT_TRUE(wait_for([&] { return loop->snapshot().cycles > 10; }));
  EXPECT_TRUE(wait_for([&] { return loop->healthy(monotonic_now_ns()); }));
  card->set_block_status(true);  // the loop stalls inside a card call
  EXPECT_TRUE(wait_for([&] { return !loop->healthy(monotonic_now_ns()); }));
  card->set_block_status(false);
  EXPECT_TRUE(wait_for([&] { return loop->healthy(monotonic_now_ns()); }));
  loop->heartbeat(monotonic_now_ns() + 3'600 * 1000 * kMs);  // no deadman in this test
  ASSERT_TRUE(loop->post_move({1, 100, -100}));
  bool finished = false;
  EXPECT_TRUE(wait_for([&] {
    LoopReport r;
    while (loop->pop_report(r))
      finished = finished || r.kind == LoopReportKind::kMotionFinished;
    return finished;
  }));

  loop->stop_thread();
  EXPECT_FALSE(loop->healthy(monotonic_now_ns()));
}

}  // namespace
}  // namespace ajar::daemon
