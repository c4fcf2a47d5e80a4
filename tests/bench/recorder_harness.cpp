// The recorder's cost on the control loop (docs/blackbox.md, docs/performance.md): the daemon's
// ControlLoop over the config's drivers, run in alternating blocks with the black box off and on
// (the recorder of the config's recorder.* keys, writing into --dir, fed by the loop every
// loop_decimation-th cycle and by nothing else), under SCHED_OTHER and, when permitted, SCHED_FIFO.
// Alternating short blocks (off, on, off, on, ...) rather than one long run each, so that the
// machine's load drifts into both sides alike. Row: wake-up latency p99 with the recorder on vs
// off; the target is <= 1.1x under SCHED_FIFO. Timing is reported, never asserted.
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <filesystem>

#include "ajar/daemon/blackbox.hpp"
#include "ajar/daemon/config.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/loop_statistics.hpp"
#include "ajar/daemon/realtime.hpp"
#include "ajar/drivers/factory.hpp"
#include "ajar/drivers/lifecycle.hpp"
#include "ajar/recorder/recorder.hpp"
#include "harness.hpp"

namespace {

using namespace ajar;
using namespace ajar::bench;

struct Block {
  std::uint32_t p99_ns = 0, max_ns = 0;
  std::uint64_t samples = 0, overruns = 0;
};

// One block: a fresh loop (and a fresh recorder when `record`) for `seconds`.
Block run_block(const daemon::Config& config, bool fifo, bool record, double seconds,
                const std::string& dir, recorder::RecorderCounters* counters) {
  auto set = drivers::make_drivers(config.drivers, config.base);
  const int axes[2] = {config.base.left.card_axis, config.base.right.card_axis};
  daemon::ControlLoopSettings s;
  s.control = config.control;
  s.control.realtime = fifo;
  s.control.lock_memory = false;
  s.safety = config.safety;
  s.base = config.base;
  drivers::ManagedMotionCard card(std::move(set.card), axes);
  Outcome up = card.configure();
  if (up) up = card.activate();
  if (!up) fail("card bring-up: " + up.error().message);
  daemon::ControlLoop loop(card, s);
  std::unique_ptr<recorder::Recorder> rec;
  if (record) {
    daemon::Config c = config;
    c.recorder.directory = dir;
    rec = std::make_unique<recorder::Recorder>(daemon::recorder_settings(c, now_ns()),
                                               [](std::string_view w) { info(std::string(w)); });
    rec->start();
    loop.set_recorder(rec.get());
  }
  for (const auto& w : loop.start_thread())
    std::fprintf(stderr, "bench: %s\n", w.c_str());
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  loop.stop_thread();
  if (rec) {
    rec->stop();
    *counters = rec->counters();
  }
  (void)card.deactivate();
  (void)card.cleanup();
  const auto t = loop.statistics().timing(now_ns()).all;
  return {t.latency.p99_ns, t.latency.max_ns, t.samples, loop.statistics().overruns()};
}

void run(const daemon::Config& base_config, bool fifo, double seconds, int blocks,
         const std::string& dir) {
  daemon::Config config = base_config;
  config.control.realtime = fifo;
  config.control.lock_memory = false;
  const std::string mode =
      fifo ? "SCHED_FIFO " + std::to_string(config.control.priority) : std::string("SCHED_OTHER");
  Paired p99;  // per block pair: (recorder off, recorder on)
  double off_block = 0;
  std::uint64_t on_samples = 0, off_samples = 0, on_overruns = 0, off_overruns = 0;
  recorder::RecorderCounters counters, total;
  for (int b = 0; b < 2 * blocks; ++b) {
    const bool record = b % 2 == 1;
    const Block r = run_block(config, fifo, record, seconds / blocks, dir, &counters);
    if (record)
      p99.add(off_block, r.p99_ns / 1e3);
    else
      off_block = r.p99_ns / 1e3;
    (record ? on_samples : off_samples) += r.samples;
    (record ? on_overruns : off_overruns) += r.overruns;
    if (record) {
      total.loop_samples += counters.loop_samples;
      total.loop_dropped += counters.loop_dropped;
      total.bytes_written += counters.bytes_written;
    }
  }
  // The median of the block ratios (harness.hpp): a block disturbed by the machine does not
  // decide it.
  compare_row("loop wake-up p99, recorder on vs off, " + mode, p99, "us", fifo ? "<= 1.1x" : "",
              std::to_string(blocks) + " alternating blocks each; " + std::to_string(on_samples) +
                  "/" + std::to_string(off_samples) + " cycles");
  row("loop overruns, recorder on vs off, " + mode, static_cast<double>(on_overruns), "",
      static_cast<double>(off_overruns), "", "deadlines missed");
  row("recorder loop samples dropped, " + mode, static_cast<double>(total.loop_dropped), "",
      std::nullopt, "0",
      "of " + std::to_string(total.loop_samples) + "; " + std::to_string(total.bytes_written) +
          " bytes written");
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
  const double seconds = o.smoke ? 0.4 : 40.0;
  const int blocks = o.smoke ? 1 : kMinBlocks;
  // The loop and the recorder's threads on the server CPU, like the loop harness's.
  const Placement where = placement();
  pin_this_thread(where.server);
  const std::string dir = o.dir + "/recordings";
  std::filesystem::remove_all(dir);
  info("recorder cost on the loop: load average " + load_average() + " at start; " +
       std::to_string(seconds) + " s per side and policy in " + std::to_string(blocks) +
       " blocks; " + where.describe());
  run(config, false, seconds, blocks, dir);
  if (fifo_permitted(config.control.priority)) {
    run(config, true, seconds, blocks, dir);
  } else {
    info(
        "SKIPPED recorder cost with SCHED_FIFO: not permitted here (needs CAP_SYS_NICE or "
        "RLIMIT_RTPRIO >= " +
        std::to_string(config.control.priority) + ")");
  }
  std::filesystem::remove_all(dir);
  return 0;
}
