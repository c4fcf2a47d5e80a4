// Protocol 1.1 loop timing through the engine: Status and Telemetry carry the control loop's
// LoopTiming (wake-up latency, execution time, period; since start and recent), Status the realtime
// state the control thread got, and ResetLoopStatistics restarts the statistics without touching
// the procedure. Never asserts timing values, only what must hold whatever the machine's load.
#include <gtest/gtest.h>

#include "fake_engine_fixture.hpp"

namespace ajar::testing {
namespace {

using protocol::ProcedureState;

TEST_F(EngineTest, StatusAndTelemetryCarryLoopTimingAndResetRestartsIt) {
  start();
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  ASSERT_TRUE(wait_for([&] { return engine->status().timing.all.samples >= 20; }));
  const auto status = engine->status();
  const auto& all = status.timing.all;
  EXPECT_GT(status.timing.window_s, 0.0F);
  EXPECT_GE(all.samples, status.timing.recent.samples);
  EXPECT_GT(all.samples, 0U);
  for (const auto* q : {&all.latency, &all.execution, &all.period}) {
    EXPECT_LE(q->p50_ns, q->p99_ns);
    EXPECT_LE(q->p99_ns, q->p999_ns);
    EXPECT_LE(q->p999_ns, q->max_ns);
  }
  EXPECT_GT(all.period.p50_ns, 0U);  // a 500 Hz loop's period is never 0
  EXPECT_GT(engine->telemetry().timing.all.samples, 0U);
  // The config asks for no realtime: the control thread reports normal scheduling.
  EXPECT_EQ(status.realtime.policy, protocol::SchedulingPolicy::kOther);
  EXPECT_FALSE(status.realtime.memory_locked);

  const std::uint64_t cycles_before_reset = engine->status().loop.cycles;  // since start
  ASSERT_GE(cycles_before_reset, 20U);
  const auto reply = send(protocol::ResetLoopStatistics{});
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(reply));
  EXPECT_EQ(std::get<protocol::Ack>(reply).acknowledged,
            protocol::MessageType::kResetLoopStatistics);
  const auto after = engine->status();
  // Only cycles after the reset count, in loop.cycles too (it restarts with the overruns).
  // (loop is read before timing: it cannot have more cycles than timing.all has samples; before,
  // loop.cycles still held the >= 20 cycles before the reset.)
  EXPECT_LE(after.loop.cycles, after.timing.all.samples + 2);
  EXPECT_LE(after.timing.recent.samples, after.timing.all.samples + 1);
  EXPECT_EQ(after.state, ProcedureState::kAwaitingHandle);  // the procedure is untouched
  EXPECT_TRUE(after.has_width);
  ASSERT_TRUE(wait_for([&] { return engine->status().timing.all.samples >= 5; }));
}

}  // namespace
}  // namespace ajar::testing
