// Footprint: ajard's resident memory idle, after one procedure and with 257 sessions (256
// observers subscribed to telemetry at 100 Hz and a controller), as shipped (config/ajard.yaml)
// and with control.lock_memory (the robot's setting: everything resident is then locked), and
// exec -> serving (spawn until a Hello is answered, median of 5), beside what a process start costs
// on this machine in the same run (`/bin/true`; `ajard --version`: exec, loading ajard's libraries,
// static initialisation, no start), so that a machine whose page faults are slow (a paravirtualised
// VM: docs/performance.md) is told from a slower ajard. Each RSS row comes with a
// /proc/PID/smaps breakdown (binary, libraries, thread stacks, anonymous memory; what is locked)
// as an INFO line. Memory is not a timing: these figures are valid on a loaded machine too.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include "harness.hpp"

extern char** environ;

namespace ajar::bench {
namespace {

using namespace protocol;

core::FramedPoint base_point(double x, double y, double z) {
  return core::FramedPoint{core::Frame::kBase, core::Vec3(x, y, z)};
}

// Door width, handle and plane: the procedure up to AlignBase's check (every command persisted).
void procedure(Conn& c) {
  (void)c.request(Reset{true});
  (void)c.request(MeasureDoorWidth{base_point(1.5, 0.40, 1.0), base_point(1.5, -0.45, 1.0)});
  (void)c.request(MeasureHandle{base_point(1.45, -0.30, 1.0), base_point(1.45, -0.42, 1.0)});
  MeasureDoorPlane p;
  p.count = 3;
  p.points[0] = base_point(1.5, 0.3, 0.8);
  p.points[1] = base_point(1.5, -0.3, 0.8);
  p.points[2] = base_point(1.5, 0.0, 1.4);
  (void)c.request(p);
  (void)c.request(GetStatus{});
}

// Milliseconds from posix_spawn of `argv` (output to /dev/null) to its exit, median of `runs`.
double exec_to_exit_ms(std::vector<std::string> argv, int runs) {
  std::vector<char*> args;
  for (auto& a : argv)
    args.push_back(a.data());
  args.push_back(nullptr);
  posix_spawn_file_actions_t quiet;
  posix_spawn_file_actions_init(&quiet);
  posix_spawn_file_actions_addopen(&quiet, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&quiet, 2, "/dev/null", O_WRONLY, 0);
  std::vector<std::int64_t> took;
  for (int i = 0; i < runs; ++i) {
    const std::int64_t t0 = now_ns();
    pid_t pid = -1;
    if (posix_spawn(&pid, args[0], &quiet, nullptr, args.data(), environ) != 0)
      fail("cannot spawn " + argv[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    took.push_back(now_ns() - t0);
  }
  posix_spawn_file_actions_destroy(&quiet);
  return static_cast<double>(quantiles(took).p50) / 1e6;
}

void measure(const Options& o, const std::string& config, const std::string& mode,
             const std::string& target, int sessions, const Placement& where) {
  Daemon d(o.ajard, config, o.dir + "/footprint", where.server);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  row("RSS idle, " + mode, static_cast<double>(d.rss_kib()) / 1024.0, "MiB");
  Conn controller(d.port());
  (void)controller.hello(Role::kController, "bench-footprint");
  procedure(controller);
  row("RSS after the procedure, " + mode, static_cast<double>(d.rss_kib()) / 1024.0, "MiB");
  std::vector<Conn> observers;
  for (int i = 0; i + 1 < sessions; ++i) {
    observers.emplace_back(d.port());
    (void)observers.back().hello(Role::kObserver, "bench-observer");
    if (!std::holds_alternative<Ack>(observers.back().request(Subscribe{100.0F})))
      fail("Subscribe refused");
  }
  // Telemetry flows for a while (every session's buffers in use), then the figure.
  const std::int64_t until = now_ns() + (o.smoke ? 300'000'000 : 2'000'000'000);
  while (now_ns() < until) {
    for (auto& c : observers)
      while (c.receive(0)) {
      }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  procedure(controller);
  const long rss = d.rss_kib(), locked = d.locked_kib();
  row("RSS with " + std::to_string(sessions) + " sessions, " + mode,
      static_cast<double>(rss) / 1024.0, "MiB", std::nullopt, target,
      locked > 0 ? "locked " + format_number(static_cast<double>(locked) / 1024.0) + " MiB"
                 : std::string(mode == "lock_memory" ? "NOT locked: mlockall refused here" : ""));
  info("smaps, " + std::to_string(sessions) + " sessions, " + mode + ": " + d.smaps_breakdown());
}

}  // namespace
}  // namespace ajar::bench

int main(int argc, char** argv) {
  using namespace ajar::bench;
  const Options o = Options::parse(argc, argv);
  if (o.ajard.empty() || o.config.empty()) fail("--ajard and --config are required");
  const Placement where = placement();
  pin_this_thread(where.client);
  const int sessions = o.smoke ? 17 : 257;

  std::vector<std::int64_t> starts;
  for (int i = 0; i < (o.smoke ? 1 : 5); ++i) {
    Daemon d(o.ajard, o.config, o.dir + "/footprint-start", where.server);
    starts.push_back(d.exec_to_serving_ns());
  }
  row("exec -> serving (median of " + std::to_string(starts.size()) + ")",
      quantiles(starts).p50 / 1e6, "ms", std::nullopt, "<= 20 ms",
      "spawn until Welcome; load average " + load_average());
  created_on(where.server, [&] {
    row("exec of /bin/true to its exit (median of 15)", exec_to_exit_ms({"/bin/true"}, 15), "ms",
        std::nullopt, "", "the machine's floor for any start");
    row("ajard --version to its exit (median of 15)", exec_to_exit_ms({o.ajard, "--version"}, 15),
        "ms", std::nullopt, "", "exec, loading its libraries, static initialisation");
    return 0;
  });

  measure(o, o.config, "as shipped", "<= 12 MiB", sessions, where);
  // lock_memory needs CAP_IPC_LOCK or an RLIMIT_MEMLOCK above the resident size; the daemon logs a
  // warning and runs unlocked otherwise (the row's note then says "NOT locked").
  const std::string locked_config = o.dir + "/lock_memory.yaml";
  write_config(o.config, locked_config, {{"lock_memory: false", "lock_memory: true"}});
  measure(o, locked_config, "lock_memory", "<= 16 MiB", sessions, where);
  return 0;
}
