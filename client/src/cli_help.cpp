// ajarctl's help, did-you-mean and bash completion, made from the command table below and the
// parsers of cli.cpp.
#include <algorithm>
#include <sstream>

#include "cli_detail.hpp"

namespace ajar::client {

namespace detail {

namespace {

constexpr CommandInfo kCommands[] = {
    {"ping", "ping [-n N] [-i S]", "round-trip times (min/avg/max/p99)",
     "Sends N Pings (-n, default 4, 1..1000000), S seconds apart (-i, default 0), prints each\n"
     "round trip and then min/avg/max/p99. Observer role.",
     "", ""},
    {"status", "status", "procedure state, stored parameters, drivers, odometry",
     "Prints the procedure state, a latched fault, the stored measurements with their derived\n"
     "values, the base's odometry yaw, the drivers' states and the control loop statistics;\n"
     "from a 1.2 daemon also what moves the base and the black box (mode, file, bytes, records\n"
     "written, dropped and lost to the disk). Observer role.",
     "", ""},
    {"watch", "watch [--rate HZ] [--duration S]", "telemetry and events until interrupted (Ctrl-C)",
     "Subscribes to telemetry at HZ (default 10; 0 = events only) and prints telemetry and events\n"
     "until Ctrl-C, or for S seconds. Observer role.",
     "", ""},
    {"model", "model", "the robot's calibration and limits (RobotModel)",
     "Prints the robot model the daemon validates against: the camera->base transform, wheel\n"
     "radius, turning radius, counts per revolution, gear ratio, wheel axes and polarities, the\n"
     "speed, drive, approach and staleness limits, the arm's workspace and the measurement\n"
     "tolerances (docs/protocol.md 5.22). Observer role.",
     "", ""},
    {"measure", "measure width|handle|plane X Y Z ...", "door width, handle or plane from points",
     "measure width X1 Y1 Z1 X2 Y2 Z2      P1 on the hinge side, P2 near the moving edge\n"
     "measure handle X1 Y1 Z1 X2 Y2 Z2     P1 on the handle's axis, P2 at its free end\n"
     "measure plane X Y Z X Y Z X Y Z [...] 3 to 16 points on the door leaf\n"
     "Points in metres, in the camera frame unless --frame base (global or after the command).\n"
     "The reply shows the derived values (width and direction, handle length, the door normal,\n"
     "the signed yaw, the wheel angles and counts). Controller role.",
     "", "width handle plane"},
    {"contact", "contact X Y Z", "the contact point (after alignment)",
     "Sets the contact point for the arm (metres; camera frame unless --frame base). Accepted\n"
     "after alignment; the reply shows it in the base frame and its reach margin. Controller\n"
     "role.",
     "", ""},
    {"align", "align [--no-wait] [--wait-timeout S]",
     "turn the base square to the door; shows progress, waits",
     "Turns the base in place by the measured yaw. Waits until the motion ends (default at most\n"
     "120 s, --wait-timeout), printing the remaining yaw and the elapsed time every 0.5 s, then\n"
     "the outcome; the waiting feeds the deadman. Ctrl-C while waiting sends Stop. --no-wait\n"
     "returns after the Ack (the deadman then stops a one-shot: use it in script mode).\n"
     "Controller role.",
     "", ""},
    {"engage", "engage [--no-wait] [--wait-timeout S]",
     "hand the door model and contact point to the arm",
     "Hands the door model (width, handle length, direction) and the contact point to the arm and\n"
     "waits until it is engaged, printing the arm's state and the elapsed time every 0.5 s.\n"
     "Options as for align. Controller role.",
     "", ""},
    {"drive", "drive [--linear V --angular W --for S]",
     "jog the base: keys in a terminal, or a velocity for S seconds",
     "Without options: terminal teleop. Up/Down arrows (or w/s) change the linear velocity,\n"
     "Left/Right (or a/d) the angular velocity (left = CCW), in steps of a tenth of the robot\n"
     "model's max_linear_speed_m_s / max_angular_speed_rad_s and clamped to them; space stops\n"
     "(velocity 0 and a Stop); q, Esc or Ctrl-C leave (Drive 0 and Stop, the terminal is\n"
     "restored). While the velocity is not zero the Drive is re-sent every third of the model's\n"
     "drive_command_timeout_s (0.1 s if 0). The line shows the velocity set, what the loop\n"
     "commands, and the live distance and yaw to the door.\n"
     "With --for S (for scripts): drives at --linear V m/s (+ forward) and --angular W rad/s\n"
     "(CCW +) for S seconds, re-sending at the same rate, then Drive 0; waits until the base is\n"
     "at rest and prints the odometry before and after. A refusal exits 1 with the daemon's\n"
     "message. Controller role.",
     "", ""},
    {"approach", "approach STANDOFF_M [--no-wait] [--wait-timeout S]",
     "drive straight to STANDOFF_M from the door; waits",
     "Drives straight (both wheels alike) until the base origin is STANDOFF_M metres from the\n"
     "door plane (from the stored plane, or before one from the width points). Prints the\n"
     "accepted move (travel, start distance, wheel counts), then waits for motion_finished,\n"
     "motion_stopped or fault_latched (default at most 120 s, --wait-timeout), printing the\n"
     "distance to the door every 0.5 s, and reports the final distance. Ctrl-C while waiting\n"
     "sends Stop. Controller role.",
     "", ""},
    {"stop", "stop", "stop motion (any role)", "Smooth stop of any motion. Any role.", "", ""},
    {"estop", "estop", "emergency stop (any role; Reset to continue)",
     "Emergency stop: latches EMERGENCY_STOPPED until `reset`. Any role.", "", ""},
    {"reset", "reset [--clear]", "clear a latched fault; --clear also discards the procedure",
     "Clears a latched fault. --clear also discards every measurement (back to awaiting_width).\n"
     "Controller role.",
     "", ""},
    {"sleep", "sleep S", "(script mode) pause S seconds, keeping the session alive",
     "Script mode: pauses S seconds (0..1000000) while heartbeat Pings keep the session alive.", "",
     ""},
    {"conformance", "conformance [--vectors DIR] [--allow-motion-on-real-robot]",
     "hold the daemon to the protocol; ends \"N passed, N failed\"",
     "Runs the protocol conformance suite against the daemon (takes control) with the golden\n"
     "vectors in DIR (default: the installed vectors, or this source tree's). Prints one line\n"
     "per check (PASS, FAIL, or SKIP with the reason) and ends with \"N passed, N failed\"\n"
     "(\", N skipped\" when some were skipped); exit 0 only with 0 failed. The checks that turn\n"
     "or drive the base or engage the arm are refused (skipped, saying why) when the daemon\n"
     "runs the real robot (Welcome.driver_kind real, or a 1.0 daemon that does not say) unless\n"
     "--allow-motion-on-real-robot. Checks of Drive/Approach are skipped while the daemon\n"
     "refuses them with NOT_SUPPORTED.",
     "--vectors --allow-motion-on-real-robot", ""},
    {"simulate", "simulate SCENARIO.yaml [OPTIONS]",
     "rehearse the whole procedure on a simulated door",
     "Rehearses the whole procedure against the daemon with a simulated door and sensor noise and\n"
     "reports true vs measured values (docs/simulation.md). Options:\n"
     "  --config AJARD.yaml  camera->base transform from this ajard config (else the paper's)\n"
     "  --trace FILE         CSV trace of every step and every telemetry sample\n"
     "  --seeds N            N runs with seeds S, S+1, ..., then a summary\n"
     "  --seed S             override the scenario's seed\n"
     "  --plane-points N     override the scenario's number of plane points (3..16)\n"
     "Scenarios: /usr/share/ajar/examples/scenarios/ (config/scenarios/ in the source tree).",
     "--trace --seeds --seed --plane-points --config", "@file"},
    {"script", "script [FILE]", "commands one per line from FILE or stdin, one session",
     "Runs commands one per line from FILE (or stdin) on one controller session. Blank lines and\n"
     "# comments are ignored; `quit` ends the script; the first failure ends it unless\n"
     "--keep-going.",
     "", "@file"},
    {"blackbox", "blackbox list|fetch NAME [-o FILE]|save S|show FILE|export FILE --csv",
     "the daemon's recordings: list, fetch, save; a file's timeline or loop trace",
     "The black box (docs/blackbox.md). Over the protocol (1.2, observer role):\n"
     "  blackbox list                 the daemon's recordings, newest first: name, size, start\n"
     "                                and end (UTC), (writing), (saved)\n"
     "  blackbox fetch NAME [-o FILE] copies recording NAME into FILE (default: its base name)\n"
     "                                in chunks, progress on stderr; a FILE that exists is a\n"
     "                                partial copy: the fetch resumes at its size\n"
     "  blackbox save S               keeps the recordings of the last S seconds (saved/...)\n"
     "A local recording (an MCAP file; one cut short by a crash reads up to the cut):\n"
     "  blackbox show FILE [--all]    the timeline: sessions, requests, replies, events, faults,\n"
     "                                config, decoded from the recorded frames (--all: also\n"
     "                                pings, status, telemetry and the recorder's counters)\n"
     "  blackbox export FILE --csv [-o OUT]  the loop trace as CSV (stdout unless -o)\n"
     "--json prints one JSON object per line instead.",
     "-o --csv --all", "list fetch save show export"},
    {"replay", "replay FILE [--settle S]",
     "re-send a recording's controller requests; report what differs",
     "Re-sends the requests of every controller session recorded in FILE (an MCAP recording of\n"
     "ajard) to the daemon, with their recorded timing (and, before each request, waiting at\n"
     "most S seconds, default 2, for the events the recorded session had seen), then reports\n"
     "every reply and event that differs from the recording, one DIFFERENCE line each, and ends\n"
     "with \"no difference\" or \"N difference(s)\". Times, session ids, sequence numbers and\n"
     "texts are not compared (docs/blackbox.md, \"Replay\"). Exit 0: no difference; 1: some.\n"
     "Run it against a daemon on simulated drivers: it moves what the recording moved.",
     "--settle", "@file"},
    {"help", "help [COMMAND]", "this list, or one command's help",
     "Prints the list of commands, or what COMMAND does (same as `ajarctl COMMAND --help`).", "",
     ""},
};

}  // namespace

std::span<const CommandInfo> commands() {
  return kCommands;
}

const CommandInfo* find_command(std::string_view name) {
  for (const auto& c : kCommands) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

namespace {

// Optimal string alignment distance (a transposition counts as one edit).
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i)
    d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j)
    d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

}  // namespace

std::string closest(std::string_view word, const std::vector<std::string>& names) {
  std::string best;
  std::size_t best_distance = std::clamp<std::size_t>(word.size() / 3, 1, 3) + 1;
  for (const std::string& n : names) {
    const std::size_t dist = n.starts_with(word) && word.size() >= 2 ? 1 : edit_distance(word, n);
    if (dist < best_distance) {
      best_distance = dist;
      best = n;
    }
  }
  return best;
}

}  // namespace detail

namespace {

std::string pad(std::string_view text, std::size_t width) {
  std::string s(text);
  if (s.size() < width) s.append(width - s.size(), ' ');
  return s;
}

// The options a parser defines, by name (the long one where there is one).
std::vector<const CLI::Option*> named_options(const CLI::App& app) {
  return app.get_options([](const CLI::Option* o) { return o->nonpositional(); });
}

}  // namespace

std::string usage() {
  std::string u = R"(Usage: ajarctl [OPTIONS] COMMAND [ARGS...]
  or:  ajarctl [OPTIONS] script [FILE]      (commands one per line, from FILE or stdin)
  or:  ajarctl [OPTIONS] --keep [COMMAND]   (run COMMAND, then commands from stdin)
  or:  ajarctl help COMMAND | ajarctl COMMAND --help

Drives and inspects ajard over its TCP protocol. Points are in metres, in the camera frame
unless --frame base.

Options:
)";
  GlobalOptions o;
  const auto parser = detail::global_parser(o);
  for (const CLI::Option* option : named_options(*parser)) {
    std::string left = option->get_name();
    if (!option->get_type_name().empty()) left += " " + option->get_type_name();
    u += "  " + pad(left, 22) + option->get_description() + "\n";
  }
  u += "\nCommands:\n";
  // Synopsis, at least two spaces, summary (help2man reads this layout for the man page).
  constexpr std::size_t kColumn = 40;
  for (const auto& c : detail::commands()) {
    if (c.synopsis.size() + 2 <= kColumn) {
      u += "  " + pad(c.synopsis, kColumn) + std::string(c.summary) + "\n";
    } else {
      u += "  " + std::string(c.synopsis) + "\n  " + pad("", kColumn) + std::string(c.summary) +
           "\n";
    }
  }
  u += R"(
measure, contact, align, engage, drive, approach, reset and script mode take the controller
role; a one-shot 'align --no-wait' disconnects during the motion, which the deadman stops: use it
in script mode.

exit codes: 0 success, 1 the daemon refused (or a check/tolerance failed), 2 usage,
            3 connection failure or timeout.
)";
  return u;
}

std::string command_help(std::string_view name) {
  const detail::CommandInfo* c = detail::find_command(name);
  if (c == nullptr) return {};
  std::string text = "Usage: ajarctl [OPTIONS] " + std::string(c->synopsis);
  text += "\n\n" + std::string(c->details) + "\n\n(ajarctl --help lists the global options)\n";
  return text;
}

std::vector<std::string> command_names() {
  std::vector<std::string> names;
  for (const auto& c : detail::commands())
    names.emplace_back(c.name);
  return names;
}

std::string unknown_command_message(std::string_view word) {
  std::string m = "unknown command '" + std::string(word) + "'";
  const std::string guess = detail::closest(word, command_names());
  if (!guess.empty()) m += " (did you mean '" + guess + "'?)";
  return m;
}

std::vector<std::string> completion_words(std::span<const std::string> before) {
  GlobalOptions o;
  const auto parser = detail::global_parser(o);
  const auto global = named_options(*parser);
  auto takes_value = [&](std::string_view word) {
    return std::any_of(global.begin(), global.end(), [word](const CLI::Option* option) {
      return option->get_name() == word && !option->get_type_name().empty();
    });
  };
  std::vector<std::string> out;
  std::size_t i = 0;
  for (; i < before.size(); ++i) {
    if (!before[i].starts_with('-')) break;
    if (takes_value(before[i])) ++i;  // skip its value
  }
  if (i > before.size()) i = before.size();
  const std::string_view previous = before.empty() ? "" : std::string_view(before.back());
  if (previous == "--frame") return {"camera", "base"};
  if (i == before.size()) {
    if (takes_value(previous)) return {};  // a value: nothing to offer
    for (const CLI::Option* option : global)
      out.push_back(option->get_name());
    for (const auto& c : detail::commands())
      out.emplace_back(c.name);
    return out;
  }
  const detail::CommandInfo* c = detail::find_command(before[i]);
  if (c == nullptr) return {};
  if (c->name == "help") {
    if (before.size() == i + 1) return command_names();
    return {};
  }
  if (previous == "--vectors") return {"@dir"};
  if (previous == "--trace" || previous == "--config") return {"@file"};
  if (before.size() == i + 1 && !c->words.empty()) {
    std::istringstream words{std::string(c->words)};
    for (std::string w; words >> w;)
      out.push_back(w);
  }
  core::Frame frame{};
  detail::CommandArgs args;
  if (const auto command = detail::command_parser(*c, frame, args)) {
    for (const CLI::Option* option : named_options(*command))
      out.push_back(option->get_name());
  }
  std::istringstream options{std::string(c->own_options)};
  for (std::string w; options >> w;)
    out.push_back(w);
  out.emplace_back("--help");
  return out;
}

}  // namespace ajar::client
