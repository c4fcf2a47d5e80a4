// Loop timing: the daemon's control loop (ControlLoop over the drivers the config selects, the
// same class and thread ajard runs) against a cyclictest-style reference thread that only sleeps to
// absolute deadlines at the same period and policy, both running at once in this process on the
// same CPU (the reference half a period out of phase so the two never wake together). Both record
// into LoopStatisticsRecorder, so the figures come from the same histogram; both restart every
// window (20 windows), each window gives one ratio (harness.hpp: the median of the ratios).
// Non-realtime, then SCHED_FIFO at control.priority when this process may use it (skipped with a
// message if not).
#include <pthread.h>
#include <sched.h>

#include <atomic>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/loop_statistics.hpp"
#include "ajar/daemon/realtime.hpp"
#include "ajar/drivers/factory.hpp"
#include "ajar/drivers/lifecycle.hpp"
#include "harness.hpp"

namespace {

using namespace ajar;
using namespace ajar::bench;

// The loop's settings: the config's control (realtime as `fifo` says), safety and base.
daemon::ControlLoopSettings loop_settings(const daemon::Config& config, bool fifo) {
  daemon::ControlLoopSettings s;
  s.control = config.control;
  s.control.realtime = fifo;
  s.safety = config.safety;
  s.base = config.base;
  return s;
}

// The reference thread's work: sleep to deadlines one `period` apart and record each wake-up in
// `reference`, until `stop`; with `fifo` under SCHED_FIFO at `priority`.
void reference_cycles(daemon::LoopStatisticsRecorder& reference, std::int64_t period, bool fifo,
                      int priority, const std::atomic<bool>& stop) {
  if (fifo) {
    sched_param p{};
    p.sched_priority = priority;
    pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
  }
  std::int64_t deadline = now_ns() + period + period / 2;
  while (!stop.load(std::memory_order_relaxed)) {
    daemon::sleep_until_ns(deadline);
    const std::int64_t wake = now_ns();
    reference.record_cycle(deadline, wake, now_ns());
    deadline += period;
    while (deadline <= now_ns())
      deadline += period;
  }
}

void run(const daemon::Config& base_config, bool fifo, double seconds, int blocks,
         const Placement& where) {
  daemon::Config config = base_config;
  config.control.realtime = fifo;
  config.control.lock_memory = false;  // the reference does not lock either
  const std::string mode =
      fifo ? "SCHED_FIFO " + std::to_string(config.control.priority) : std::string("SCHED_OTHER");
  auto set = drivers::make_drivers(config.drivers, config.base);
  const int axes[2] = {config.base.left.card_axis, config.base.right.card_axis};
  drivers::ManagedMotionCard card(std::move(set.card), axes);
  Outcome up = card.configure();
  if (up) up = card.activate();
  if (!up) fail("card bring-up: " + up.error().message);
  daemon::ControlLoop loop(card, loop_settings(config, fifo));

  daemon::LoopStatisticsRecorder reference(config.control.rate_hz);
  const std::int64_t period = reference.nominal_period_ns();
  std::atomic<bool> stop{false};
  // Both threads on the server CPU (created while this thread is pinned there), this reading
  // thread on the client CPU: the same placement for the loop and its reference.
  std::thread ref = created_on(where.server, [&] {
    return std::thread(
        [&] { reference_cycles(reference, period, fifo, config.control.priority, stop); });
  });
  const auto warnings = created_on(where.server, [&] { return loop.start_thread(); });
  for (const auto& w : warnings)
    std::fprintf(stderr, "bench: %s\n", w.c_str());
  // Blocks: both run at once all along; every window both statistics restart (reset) and are
  // read at its end, so each window gives one (reference, loop) pair per statistic.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // both running
  Paired p50, p99, p999, max;
  std::uint64_t cycles = 0;
  std::int64_t execution_p99_ns = 0, execution_max_ns = 0;
  for (int b = 0; b < blocks; ++b) {
    loop.statistics().reset(now_ns());
    reference.reset(now_ns());
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds / blocks));
    const std::int64_t end = now_ns();
    const auto l = loop.statistics().timing(end).all;
    const auto r = reference.timing(end).all;
    p50.add(r.latency.p50_ns / 1e3, l.latency.p50_ns / 1e3);
    p99.add(r.latency.p99_ns / 1e3, l.latency.p99_ns / 1e3);
    p999.add(r.latency.p999_ns / 1e3, l.latency.p999_ns / 1e3);
    max.add(r.latency.max_ns / 1e3, l.latency.max_ns / 1e3);
    cycles += l.samples;
    execution_p99_ns = std::max<std::int64_t>(execution_p99_ns, l.execution.p99_ns);
    execution_max_ns = std::max<std::int64_t>(execution_max_ns, l.execution.max_ns);
  }
  stop = true;
  ref.join();
  loop.stop_thread();
  (void)card.deactivate();
  (void)card.cleanup();
  const std::string note = mode + ", " + std::to_string(cycles) + " cycles at " +
                           std::to_string(static_cast<int>(config.control.rate_hz)) + " Hz in " +
                           std::to_string(blocks) + " windows";
  compare_row("loop wake-up latency p50, " + mode, p50, "us", "", "vs reference thread; " + note);
  compare_row("loop wake-up latency p99, " + mode, p99, "us", "<= 1.2x", "vs reference thread");
  compare_row("loop wake-up latency p99.9, " + mode, p999, "us", "", "vs reference thread");
  compare_row("loop wake-up latency max, " + mode, max, "us", "", "vs reference thread",
              Over::kMax);
  row("loop cycle execution p99 (worst window), " + mode,
      static_cast<double>(execution_p99_ns) / 1e3, "us", std::nullopt, "",
      "max " + std::to_string(execution_max_ns / 1000) + " us");
  row("loop overruns, " + mode, static_cast<double>(loop.statistics().overruns()), "", std::nullopt,
      "", "deadlines missed");
  info("loop timing, " + mode + ": load average " + load_average() + " at the end");
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = Options::parse(argc, argv);
  if (o.config.empty()) fail("--config is required");
  daemon::Config config;
  try {
    config = daemon::load_config(o.config);
  } catch (const std::exception& e) {
    fail(e.what());
  }
  const double seconds = o.smoke ? 0.6 : 20.0;
  const int blocks = o.smoke ? 3 : 2 * kMinBlocks;
  const Placement where = placement();
  pin_this_thread(where.client);
  info("loop timing: load average " + load_average() + " at start; " + std::to_string(seconds) +
       " s per policy in " + std::to_string(blocks) +
       " windows (loop and reference run at once; both statistics restart every window); " +
       where.describe());
  run(config, false, seconds, blocks, where);
  if (fifo_permitted(config.control.priority)) {
    run(config, true, seconds, blocks, where);
  } else {
    info(
        "SKIPPED loop timing with SCHED_FIFO: not permitted here (needs CAP_SYS_NICE or "
        "RLIMIT_RTPRIO >= " +
        std::to_string(config.control.priority) + ")");
  }
  return 0;
}
