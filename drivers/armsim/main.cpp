// ajar-armsim [--task-ms N] [--reply-delay-ms N] [--refuse] [--fault WORD] [--silent-ms N]
// Runs ArmControllerSimulator on a pseudo-terminal, prints the device path to open, and serves
// until SIGINT or SIGTERM. Requests and counters are printed once a second when they change.
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

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

int parse_ms(const char* text, const char* flag) {
  char* end = nullptr;
  const long v = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || v < 0 || v > 3'600'000) {
    std::fprintf(stderr, "ajar-armsim: %s wants milliseconds 0..3600000, not '%s'\n", flag, text);
    std::exit(2);
  }
  return static_cast<int>(v);
}

}  // namespace

int main(int argc, char** argv) {
  ajar::drivers::ArmSimulatorSettings settings;
  bool refuse = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--task-ms" && i + 1 < argc) {
      settings.task_duration_ms = parse_ms(argv[++i], "--task-ms");
    } else if (arg == "--reply-delay-ms" && i + 1 < argc) {
      settings.reply_delay_ms = parse_ms(argv[++i], "--reply-delay-ms");
    } else if (arg == "--silent-ms" && i + 1 < argc) {
      settings.silent_ms = parse_ms(argv[++i], "--silent-ms");
    } else if (arg == "--fault" && i + 1 < argc) {
      const std::string word = argv[++i];
      using ajar::drivers::ArmSimFault;
      if (word == "none") {
        settings.fault = ArmSimFault::kNone;
      } else if (word == "silent-mid-task") {
        settings.fault = ArmSimFault::kSilentMidTask;
      } else if (word == "silent-mid-stop") {
        settings.fault = ArmSimFault::kSilentMidStop;
      } else if (word == "reset-mid-task") {
        settings.fault = ArmSimFault::kResetMidTask;
      } else if (word == "stop-ignored") {
        settings.fault = ArmSimFault::kStopIgnored;
      } else {
        std::fprintf(stderr,
                     "ajar-armsim: --fault wants none, silent-mid-task, silent-mid-stop, "
                     "reset-mid-task or stop-ignored, not '%s'\n",
                     word.c_str());
        return 2;
      }
    } else if (arg == "--refuse") {
      refuse = true;
    } else if (arg == "--help" || arg == "-h") {
      std::fputs(kHelp, stdout);
      return 0;
    } else if (arg == "--version") {
      std::printf("ajar-armsim %s\n", ajar::kVersion);
      return 0;
    } else {
      std::fprintf(stderr, "ajar-armsim: unknown argument '%s' (see ajar-armsim --help)\n",
                   arg.c_str());
      return 2;
    }
  }

  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // before the simulator's thread starts

  try {
    ajar::drivers::ArmControllerSimulator sim(settings);
    sim.set_refuse_tasks(refuse);
    std::printf("%s\n", sim.device_path().c_str());
    std::fflush(stdout);
    ajar::drivers::ArmControllerSimulator::Counters last{};
    timespec tick{1, 0};
    for (;;) {
      siginfo_t info;
      if (sigtimedwait(&signals, &info, &tick) > 0) break;
      const auto c = sim.counters();
      if (c.requests != last.requests || c.tasks_completed != last.tasks_completed) {
        std::fprintf(stderr,
                     "requests %llu, duplicates %llu, tasks executed %llu, completed %llu, "
                     "stops %llu, bad lines %llu, unanswered %llu, phase %s\n",
                     static_cast<unsigned long long>(c.requests),
                     static_cast<unsigned long long>(c.duplicates_ignored),
                     static_cast<unsigned long long>(c.tasks_executed),
                     static_cast<unsigned long long>(c.tasks_completed),
                     static_cast<unsigned long long>(c.stops),
                     static_cast<unsigned long long>(c.bad_requests),
                     static_cast<unsigned long long>(c.unanswered),
                     ajar::drivers::arm::to_string(sim.phase()));
        last = c;
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ajar-armsim: %s\n", e.what());
    return 1;
  }
  return 0;
}
