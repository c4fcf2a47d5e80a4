// Randomized interleavings of the engine and its control loop on a fake clock, with every command
// going through the real session layer (SessionHub over fake links): commands arrive in reads of
// several frames between two loop cycles (begin/end read batch), with Stop, EmergencyStop and Reset
// at random points, Drive (a held key re-sent, released with a zero Drive, or simply no longer sent
// so that the command timeout must end the jog), Approach (various standoffs, some refused),
// duplicates (same client instance and request id: executed once, the same reply again, also
// after a reconnect), observers that send commands (refused, never executed) and stops (executed),
// controller loss (disconnect) and take-over by a second controller session, silence (deadman),
// card faults at random cycles (the mock card's test menu: also a card that drops a command,
// answers an error after taking one, reports stale status or is silent), a slow state store (held
// durable Acks), and arm outcomes (done, fault, disconnect, a controller that resets mid-task,
// stops answering mid-task or at a stop, or answers stops but stays busy: world_arm.cpp). The
// loop runs by hand (EngineOptions::manual_loop), so a seed replays exactly. After every command
// and every cycle the invariants are checked (docs/control-loop.md, "Proof"); a campaign also
// asserts that the interesting situations were actually reached (coverage counters, printed).
//
//   AJAR_SEED=<n>     replay one seed (prints its trace)
//   AJAR_SEEDS=<n>    number of seeds (default 2000, 400 under sanitizers; a campaign: 200000)
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>

#include "ajar/daemon/logging.hpp"
#include "campaign_seeds.hpp"
#include "det_mock_card.hpp"
#include "fake_door.hpp"
#include "fake_engine_fixture.hpp"
#include "interleaving/world.hpp"

namespace ajar::testing::interleaving {
namespace {

// CI's campaign (campaign_seeds.hpp: shorter under a sanitizer).
constexpr std::uint64_t kCiSeeds = test::ci_size(2000, 400);

TEST(Interleaving, RandomCommandSequencesKeepTheSafetyInvariants) {
  daemon::set_log_level(daemon::LogLevel::kNone);  // the hub logs every command
  const std::string dir = shm_dir();
  const auto [first, count, replay] = test::seed_range(kCiSeeds);
  int failures = 0;
  Coverage total;
  for (std::uint64_t seed = first; seed < first + count && failures < 3; ++seed) {
    World world(seed, dir, replay);
    const std::string violation = world.run(60);
    total.add(world.coverage());
    if (!violation.empty()) {
      ++failures;
      std::ostringstream out;
      const auto& t = world.trace();
      for (std::size_t i = t.size() > 40 ? t.size() - 40 : 0; i < t.size(); ++i)
        out << "  " << t[i] << "\n";
      ADD_FAILURE() << "seed " << seed << ": " << violation << "\n"
                    << out.str() << "replay with AJAR_SEED=" << seed;
    }
  }
  daemon::set_log_level(daemon::LogLevel::kInfo);
  std::filesystem::remove_all(dir);
  std::ostringstream counters;
  for (const auto& [k, v] : total.counts)
    counters << "  " << k << ": " << v << "\n";
  std::cout << "coverage over " << count << " seeds:\n" << counters.str();
  if (replay || count < 2000) return;
  // Over a CI campaign every interesting situation is reached a few times at least.
  for (const char* what :
       {"aligning", "alignment finished", "engaging", "arm task finished", "jog stopped by a Stop",
        "jog ended by the command timeout", "jog ended by a zero Drive", "approach finished",
        "approach stopped", "move cancelled before it started", "recovery (Reset of a fault)",
        "card fault mid-motion", "deadman", "duplicate executed once", "take-over",
        "durable ack held",
        // The card side (world_card.cpp): each misbehaviour mid-motion, and caught.
        "approach at the card", "card drops a move", "card drops jog updates mid-jog",
        "stale status mid-motion", "card silent mid-motion", "fault VELOCITY_MISMATCH",
        "fault MOTION_TIMEOUT", "jog held at the door's standoff"}) {
    EXPECT_GE(total.get(what), 10) << "the campaign no longer reaches: " << what;
  }
  // The arm controller's faults and the arm interlock (world_arm.cpp).
  for (const char* what :
       {"arm silent mid-task", "arm silent mid-stop", "arm reset mid-task", "arm stop ignored",
        "fault ARM_NOT_CLEAR", "Reset refused: the arm not clear",
        "wheel motion refused: the arm not clear", "cycles with the arm at the door"}) {
    EXPECT_GE(total.get(what), 10) << "the campaign no longer reaches: " << what;
  }
}

// The reported case: AlignBase and Stop in one read (before the loop's next cycle). The Stop is
// acknowledged, so the wheels must never turn.
TEST(Interleaving, AlignBaseAndStopInOneReadNeverTurn) {
  const std::string dir = shm_dir();
  FakeClock clock;
  auto config = test_config(dir);
  drivers::MockManipulator* arm = nullptr;
  drivers::DriverSet set;
  set.card = make_det_card(clock);
  const drivers::MockMotionCard& card = static_cast<drivers::MockMotionCard&>(*set.card);
  set.arm = make_mock_arm(arm);
  daemon::EngineOptions options;
  options.now_ns = clock.clock();
  options.manual_loop = true;
  auto engine = daemon::make_engine(config, std::move(set), std::move(options));
  std::vector<protocol::Event> events;
  engine->set_event_sink([&](const protocol::Event& e) { events.push_back(e); });
  engine->start();
  const auto cycle = [&] {
    clock.advance_ns(kPeriodNs);
    engine->controller_heartbeat();
    engine->run_loop_cycle();
    engine->poll();
  };
  for (int i = 0; i < 3; ++i)
    cycle();
  engine->handle_command(good_width());
  engine->handle_command(good_handle());
  engine->handle_command(plane_at_yaw(0.1));
  cycle();
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(engine->handle_command(protocol::AlignBase{})));
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(engine->handle_command(protocol::Stop{})));
  for (int i = 0; i < 200; ++i)
    cycle();
  EXPECT_EQ(card.calls(CardCall::kMoveRelative), 0U)
      << "the wheels turned after an acknowledged Stop";
  EXPECT_EQ(engine->status().state, ProcedureState::kReadyToAlign);
  int started = 0, closed = 0;
  for (const auto& e : events) {
    started += e.kind == EventKind::kMotionStarted ? 1 : 0;
    closed += e.kind == EventKind::kMotionStopped || e.kind == EventKind::kMotionFinished ? 1 : 0;
  }
  EXPECT_EQ(started, 1);
  EXPECT_EQ(closed, 1);
  engine->shutdown();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ajar::testing::interleaving
