// ajar-armsim [--task-ms N] [--reply-delay-ms N] [--refuse] [--fault WORD] [--silent-ms N]
// Runs ArmControllerSimulator on a pseudo-terminal, prints the device path to open, and serves
// until SIGINT or SIGTERM. Requests and counters are printed once a second when they change.
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <map>
#include <string>

#include <CLI/CLI.hpp>

#include "ajar/drivers/arm_simulator.hpp"
#include "ajar/version.hpp"

namespace {

// --help (also the source of the ajar-armsim(1) man page, cmake/AjarManPages.cmake).
constexpr const char* kHelp =
    "Usage: ajar-armsim [--task-ms N] [--reply-delay-ms N] [--refuse] [--fault WORD]\n"
    "                   [--silent-ms N]\n"
    "\n"
    "Runs the arm-controller simulator on a pseudo-terminal: prints the device path to open (a\n"
    "stable symlink to the pseudo-terminal), then serves the arm's serial protocol\n"
    "(docs/manipulator-serial.md) until SIGINT or SIGTERM. Requests and counters are printed on\n"
    "stderr once a second when they change. Point drivers.arm.device at the path, or open it with\n"
    "a terminal program (picocom PATH).\n"
    "\n"
    "Options:\n"
    "  --task-ms N           a door task runs N ms before the controller reports DONE (default\n"
    "                        200; 0..3600000)\n"
    "  --reply-delay-ms N    delay every reply by N ms (a slow controller; default 0)\n"
    "  --refuse              refuse every task (the controller's refusal path)\n"
    "  --fault WORD          the controller's own fault in every task: silent-mid-task (stops\n"
    "                        answering half way through), silent-mid-stop (the first STOP is\n"
    "                        not answered: it falls silent), reset-mid-task (half way through it\n"
    "                        comes back IDLE, the task forgotten), stop-ignored (STOP answered,\n"
    "                        the arm stays BUSY); default none\n"
    "  --silent-ms N         a silence lasts N ms (default 0: for good)\n"
    "  --version             print the version and exit\n"
    "  --help, -h            print this help and exit\n";

// Milliseconds 0..3600000 (CLI11 names the flag before the message; main exits 2).
CLI::Validator milliseconds() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const long v = std::strtol(text.c_str(), &end, 10);
        if (end == text.c_str() || *end != '\0' || v < 0 || v > 3'600'000) {
          return "wants milliseconds 0..3600000, not '" + text + "'";
        }
        return {};
      },
      "MS");
}

using ajar::drivers::ArmControllerSimulator;
using ajar::drivers::ArmSimFault;

struct Options {
  ajar::drivers::ArmSimulatorSettings settings;
  bool refuse = false;
  bool help = false;
  bool version = false;
};

// The command line into `options`; false on a bad one (CLI11's message printed).
bool parse_command_line(int argc, char** argv, Options& options) {
  std::string fault = "none";
  const std::map<std::string, ArmSimFault> faults{{"none", ArmSimFault::kNone},
                                                  {"silent-mid-task", ArmSimFault::kSilentMidTask},
                                                  {"silent-mid-stop", ArmSimFault::kSilentMidStop},
                                                  {"reset-mid-task", ArmSimFault::kResetMidTask},
                                                  {"stop-ignored", ArmSimFault::kStopIgnored}};
  CLI::App app("", "ajar-armsim");
  app.set_help_flag();  // --help prints kHelp (the man page's source), not CLI11's
  app.add_option("--task-ms", options.settings.task_duration_ms)->check(milliseconds());
  app.add_option("--reply-delay-ms", options.settings.reply_delay_ms)->check(milliseconds());
  app.add_option("--silent-ms", options.settings.silent_ms)->check(milliseconds());
  app.add_option("--fault", fault)
      ->check(CLI::Validator(
          [&faults](std::string& word) -> std::string {
            if (faults.count(word) != 0) return {};
            return "wants none, silent-mid-task, silent-mid-stop, reset-mid-task or stop-ignored, "
                   "not '" +
                   word + "'";
          },
          "WORD"));
  app.add_flag("--refuse", options.refuse);
  app.add_flag("-h,--help", options.help);
  app.add_flag("--version", options.version);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "ajar-armsim: %s (see ajar-armsim --help)\n", e.what());
    return false;
  }
  options.settings.fault = faults.at(fault);
  return true;
}

// The simulator's counters on stderr, when its requests or completed tasks changed since `last`.
void print_counters_on_change(const ArmControllerSimulator& sim,
                              ArmControllerSimulator::Counters& last) {
  const auto c = sim.counters();
  if (c.requests == last.requests && c.tasks_completed == last.tasks_completed) return;
  std::fprintf(
      stderr,
      "requests %llu, duplicates %llu, tasks executed %llu, completed %llu, "
      "stops %llu, bad lines %llu, unanswered %llu, phase %s\n",
      static_cast<unsigned long long>(c.requests),
      static_cast<unsigned long long>(c.duplicates_ignored),
      static_cast<unsigned long long>(c.tasks_executed),
      static_cast<unsigned long long>(c.tasks_completed), static_cast<unsigned long long>(c.stops),
      static_cast<unsigned long long>(c.bad_requests),
      static_cast<unsigned long long>(c.unanswered), ajar::drivers::arm::to_string(sim.phase()));
  last = c;
}

// Runs the simulator until SIGINT or SIGTERM: main's exit status.
int serve(const Options& options) {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // before the simulator's thread starts

  try {
    ArmControllerSimulator sim(options.settings);
    sim.set_refuse_tasks(options.refuse);
    std::printf("%s\n", sim.device_path().c_str());
    std::fflush(stdout);
    ArmControllerSimulator::Counters last{};
    timespec tick{1, 0};
    for (;;) {
      siginfo_t info;
      if (sigtimedwait(&signals, &info, &tick) > 0) break;
      print_counters_on_change(sim, last);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ajar-armsim: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (!parse_command_line(argc, argv, options)) return 2;
  if (options.help) {
    std::fputs(kHelp, stdout);
    return 0;
  }
  if (options.version) {
    std::printf("ajar-armsim %s\n", ajar::kVersion);
    return 0;
  }
  return serve(options);
}
