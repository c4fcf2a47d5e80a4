#include "ajar/client/cli.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <tuple>

#include <yaml-cpp/yaml.h>

#include "ajar/version.hpp"

namespace ajar::client {

namespace {

bool parse_double(const std::string& text, double& out) {
  if (text.empty()) return false;
  const char* begin = text.data();
  const char* end = text.data() + text.size();
  if (*begin == '+') ++begin;
  const auto [ptr, ec] = std::from_chars(begin, end, out);
  return ec == std::errc{} && ptr == end && std::isfinite(out);
}

// Durations (s) and rates (Hz) a command accepts: far beyond any use, and small enough that
// now() + duration cannot overflow std::chrono's nanosecond clock (nor a rate the f32 on the wire).
constexpr double kMaxSeconds = 1e6;
constexpr double kMaxRateHz = 1e6;

// A duration in 0..kMaxSeconds (or, with `positive`, in (0, kMaxSeconds]).
bool parse_seconds(const std::string& text, double& out, bool positive = false) {
  return parse_double(text, out) && (positive ? out > 0 : out >= 0) && out <= kMaxSeconds;
}

bool parse_int(const std::string& text, int& out) {
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc{} && ptr == text.data() + text.size();
}

bool parse_frame(const std::string& text, core::Frame& frame) {
  if (text == "camera") {
    frame = core::Frame::kCamera;
  } else if (text == "base") {
    frame = core::Frame::kBase;
  } else {
    return false;
  }
  return true;
}

// Reads `count` points (3 numbers each) from words; error names the offending word.
std::string parse_points(std::span<const std::string> words, core::Frame frame,
                         std::vector<protocol::FramedPoint>& points) {
  if (words.size() % 3 != 0) {
    return "points need three coordinates each (X Y Z in metres); got " +
           std::to_string(words.size()) + " numbers";
  }
  for (std::size_t i = 0; i < words.size(); i += 3) {
    double xyz[3];
    for (std::size_t k = 0; k < 3; ++k) {
      if (!parse_double(words[i + k], xyz[k])) {
        return "not a finite number: '" + words[i + k] + "'";
      }
    }
    points.push_back(framed(frame, xyz[0], xyz[1], xyz[2]));
  }
  return {};
}

// The offending argument for a usage message: the option with its value when it has one
// ("'-i 1e15'"), else the word.
std::string quoted(std::span<const std::string> words, std::size_t i) {
  std::string s = "'" + words[i];
  if (words[i].starts_with('-') && i + 1 < words.size()) s += " " + words[i + 1];
  return s + "'";
}

// --client-config FILE: `connect: HOST:PORT` and `tls: {ca, certificate, private_key,
// server_name}`; relative paths are taken from the file's folder. Empty, or what is wrong.
std::string load_client_config(const std::string& path, GlobalOptions& o) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    return "--client-config " + path + ": " + e.what();
  }
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  auto text = [&](const YAML::Node& map, const char* key, std::string& out,
                  bool is_path) -> std::string {
    const YAML::Node n = map[key];
    if (!n) return {};
    if (!n.IsScalar() || n.Scalar().empty())
      return path + ": " + key + ": must be a non-empty string";
    std::filesystem::path value = n.Scalar();
    out = is_path && value.is_relative() ? (folder / value).string() : value.string();
    return {};
  };
  if (!root.IsMap()) return path + ": must be a map (connect, tls)";
  for (const auto& entry : root) {
    const auto key = entry.first.as<std::string>();
    if (key != "connect" && key != "tls") return path + ": unknown key '" + key + "'";
  }
  std::string connect;
  if (auto e = text(root, "connect", connect, false); !e.empty()) return e;
  if (!connect.empty()) {
    auto endpoint = parse_endpoint(connect);
    if (!endpoint) return path + ": connect: wants HOST:PORT, got '" + connect + "'";
    o.endpoint = *endpoint;
  }
  if (const YAML::Node tls = root["tls"]) {
    if (!tls.IsMap()) return path + ": tls: must be a map";
    for (const auto& entry : tls) {
      const auto key = entry.first.as<std::string>();
      if (key != "ca" && key != "certificate" && key != "private_key" && key != "server_name")
        return path + ": tls." + key + ": unknown key (allowed: ca, certificate, private_key, " +
               "server_name)";
    }
    for (auto [key, out, is_path] :
         {std::tuple<const char*, std::string*, bool>{"ca", &o.tls.ca, true},
          {"certificate", &o.tls.certificate, true},
          {"private_key", &o.tls.private_key, true},
          {"server_name", &o.tls.server_name, false}}) {
      if (auto e = text(tls, key, *out, is_path); !e.empty()) return e;
    }
  }
  return {};
}

CommandParse fail(std::string message) {
  return CommandParse{std::nullopt, std::move(message)};
}

}  // namespace

namespace {

// Every ajarctl command, once: the --help list, `ajarctl help CMD` / `CMD --help`, did-you-mean and
// the bash completion (ajarctl --complete) are all made from this table. `options` lists the
// command's own options for completion; `words` its fixed first arguments, or "@file" / "@dir".
struct CommandInfo {
  std::string_view name;
  std::string_view synopsis;  // one line: "ping [-n N] [-i S]"
  std::string_view summary;   // one line, for the list in --help
  std::string_view details;   // `ajarctl help CMD`: what it does, its arguments, its role
  std::string_view options;   // space-separated, for completion
  std::string_view words;     // first-argument words, "@file" or "@dir", for completion
};

constexpr CommandInfo kCommands[] = {
    {"ping", "ping [-n N] [-i S]", "round-trip times (min/avg/max/p99)",
     "Sends N Pings (-n, default 4, 1..1000000), S seconds apart (-i, default 0), prints each\n"
     "round trip and then min/avg/max/p99. Observer role.",
     "-n -i", ""},
    {"status", "status", "procedure state, stored parameters, drivers, odometry",
     "Prints the procedure state, a latched fault, the stored measurements with their derived\n"
     "values, the base's odometry yaw, the drivers' states and the control loop statistics.\n"
     "Observer role.",
     "", ""},
    {"watch", "watch [--rate HZ] [--duration S]", "telemetry and events until interrupted (Ctrl-C)",
     "Subscribes to telemetry at HZ (default 10; 0 = events only) and prints telemetry and events\n"
     "until Ctrl-C, or for S seconds. Observer role.",
     "--rate --duration", ""},
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
     "--frame", "width handle plane"},
    {"contact", "contact X Y Z", "the contact point (after alignment)",
     "Sets the contact point for the arm (metres; camera frame unless --frame base). Accepted\n"
     "after alignment; the reply shows it in the base frame and its reach margin. Controller\n"
     "role.",
     "--frame", ""},
    {"align", "align [--no-wait] [--wait-timeout S]",
     "turn the base square to the door; shows progress, waits",
     "Turns the base in place by the measured yaw. Waits until the motion ends (default at most\n"
     "120 s, --wait-timeout), printing the remaining yaw and the elapsed time every 0.5 s, then\n"
     "the outcome; the waiting feeds the deadman. Ctrl-C while waiting sends Stop. --no-wait\n"
     "returns after the Ack (the deadman then stops a one-shot: use it in script mode).\n"
     "Controller role.",
     "--no-wait --wait-timeout", ""},
    {"engage", "engage [--no-wait] [--wait-timeout S]",
     "hand the door model and contact point to the arm",
     "Hands the door model (width, handle length, direction) and the contact point to the arm and\n"
     "waits until it is engaged, printing the arm's state and the elapsed time every 0.5 s.\n"
     "Options as for align. Controller role.",
     "--no-wait --wait-timeout", ""},
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
     "--linear --angular --for", ""},
    {"approach", "approach STANDOFF_M [--no-wait] [--wait-timeout S]",
     "drive straight to STANDOFF_M from the door; waits",
     "Drives straight (both wheels alike) until the base origin is STANDOFF_M metres from the\n"
     "door plane (from the stored plane, or before one from the width points). Prints the\n"
     "accepted move (travel, start distance, wheel counts), then waits for motion_finished,\n"
     "motion_stopped or fault_latched (default at most 120 s, --wait-timeout), printing the\n"
     "distance to the door every 0.5 s, and reports the final distance. Ctrl-C while waiting\n"
     "sends Stop. Controller role.",
     "--no-wait --wait-timeout", ""},
    {"stop", "stop", "stop motion (any role)", "Smooth stop of any motion. Any role.", "", ""},
    {"estop", "estop", "emergency stop (any role; Reset to continue)",
     "Emergency stop: latches EMERGENCY_STOPPED until `reset`. Any role.", "", ""},
    {"reset", "reset [--clear]", "clear a latched fault; --clear also discards the procedure",
     "Clears a latched fault. --clear also discards every measurement (back to awaiting_width).\n"
     "Controller role.",
     "--clear", ""},
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
    {"help", "help [COMMAND]", "this list, or one command's help",
     "Prints the list of commands, or what COMMAND does (same as `ajarctl COMMAND --help`).", "",
     ""},
};

// Global options: the --help text and completion. `value` names the option's value ("" if none).
struct OptionInfo {
  std::string_view name;
  std::string_view value;
  std::string_view help;
};
constexpr OptionInfo kGlobalOptions[] = {
    {"--connect", "HOST:PORT", "daemon address (default 127.0.0.1:7450)"},
    {"--ca", "FILE", "speak TLS; the CA the daemon's certificate must chain to (PEM)"},
    {"--cert", "FILE", "this operator's certificate (PEM; docs/security.md)"},
    {"--key", "FILE", "its private key (PEM, mode 0600: others' access is refused)"},
    {"--server-name", "NAME", "name the daemon's certificate must carry (default: HOST)"},
    {"--client-config", "FILE", "connect and tls settings from YAML (docs/ajarctl.md)"},
    {"--json", "", "one JSON object per line per reply or event (docs/ajarctl.md)"},
    {"--frame", "camera|base", "frame of the points given to measure/contact (default camera)"},
    {"--timeout", "S", "seconds to wait for each reply attempt (default 3)"},
    {"--retries", "N", "re-sends of a timed-out request, same request id (default 1)"},
    {"--take-over", "", "take control from the current controller"},
    {"--keep", "", "after COMMAND, read more commands from stdin (one session)"},
    {"--keep-going", "", "in script mode, continue after a failed command"},
    {"--version", "", "print the version and exit"},
    {"--help", "", "this help (-h); `ajarctl help COMMAND` for one command"},
};

const CommandInfo* find_command(std::string_view name) {
  for (const auto& c : kCommands) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

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

// The closest candidate within a third of the word's length (at least 1, at most 3 edits), or a
// candidate the word is a prefix of; empty if none is close.
template <typename Range, typename Name>
std::string closest(std::string_view word, const Range& candidates, Name name) {
  std::string best;
  std::size_t best_distance = std::clamp<std::size_t>(word.size() / 3, 1, 3) + 1;
  for (const auto& c : candidates) {
    const std::string_view n = name(c);
    const std::size_t dist = n.starts_with(word) && word.size() >= 2 ? 1 : edit_distance(word, n);
    if (dist < best_distance) {
      best_distance = dist;
      best = std::string(n);
    }
  }
  return best;
}

std::string pad(std::string_view text, std::size_t width) {
  std::string s(text);
  if (s.size() < width) s.append(width - s.size(), ' ');
  return s;
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
  for (const auto& o : kGlobalOptions) {
    const std::string left =
        std::string(o.name) + (o.value.empty() ? "" : " ") + std::string(o.value);
    u += "  " + pad(left, 22) + std::string(o.help) + "\n";
  }
  u += "\nCommands:\n";
  // Synopsis, at least two spaces, summary (help2man reads this layout for the man page).
  constexpr std::size_t kColumn = 40;
  for (const auto& c : kCommands) {
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
  const CommandInfo* c = find_command(name);
  if (c == nullptr) return {};
  std::string text = "Usage: ajarctl [OPTIONS] " + std::string(c->synopsis);
  text += "\n\n" + std::string(c->details) + "\n\n(ajarctl --help lists the global options)\n";
  return text;
}

std::vector<std::string> command_names() {
  std::vector<std::string> names;
  for (const auto& c : kCommands)
    names.emplace_back(c.name);
  return names;
}

std::string unknown_command_message(std::string_view word) {
  std::string m = "unknown command '" + std::string(word) + "'";
  const std::string guess = closest(word, kCommands, [](const CommandInfo& c) { return c.name; });
  if (!guess.empty()) m += " (did you mean '" + guess + "'?)";
  return m;
}

std::vector<std::string> completion_words(std::span<const std::string> before) {
  std::vector<std::string> out;
  auto option_value = [](std::string_view word) -> const OptionInfo* {
    for (const auto& o : kGlobalOptions) {
      if (o.name == word && !o.value.empty()) return &o;
    }
    return nullptr;
  };
  std::size_t i = 0;
  for (; i < before.size(); ++i) {
    if (!before[i].starts_with('-')) break;
    if (option_value(before[i]) != nullptr) ++i;  // skip its value
  }
  if (i > before.size()) i = before.size();
  const std::string_view previous = before.empty() ? "" : std::string_view(before.back());
  if (previous == "--frame") return {"camera", "base"};
  if (i == before.size()) {
    if (option_value(previous) != nullptr) return {};  // a value: nothing to offer
    for (const auto& o : kGlobalOptions)
      out.emplace_back(o.name);
    for (const auto& c : kCommands)
      out.emplace_back(c.name);
    return out;
  }
  const CommandInfo* c = find_command(before[i]);
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
  std::istringstream options{std::string(c->options)};
  for (std::string w; options >> w;)
    out.push_back(w);
  out.emplace_back("--help");
  return out;
}

std::vector<std::string> split_line(const std::string& line) {
  std::vector<std::string> words;
  std::istringstream in(line.substr(0, line.find('#')));
  std::string word;
  while (in >> word)
    words.push_back(word);
  return words;
}

ParsedArgs parse_global_options(std::span<const std::string> args) {
  ParsedArgs parsed;
  auto& o = parsed.options;
  std::size_t i = 0;
  auto value = [&](const std::string& name) -> const std::string* {
    if (i + 1 >= args.size()) {
      parsed.error = name + " needs a value";
      return nullptr;
    }
    return &args[++i];
  };
  for (; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a.empty() || a[0] != '-') break;
    if (a == "--json") {
      o.json = true;
    } else if (a == "--keep") {
      o.keep = true;
    } else if (a == "--keep-going") {
      o.keep_going = true;
    } else if (a == "--take-over") {
      o.take_over = true;
    } else if (a == "-h" || a == "--help") {
      o.help = true;
    } else if (a == "--version") {
      o.version = true;
    } else if (a == "--connect") {
      const auto* v = value(a);
      if (!v) return parsed;
      auto endpoint = parse_endpoint(*v);
      if (!endpoint) {
        parsed.error = "--connect wants HOST:PORT, got '" + *v + "'";
        return parsed;
      }
      o.endpoint = *endpoint;
    } else if (a == "--ca" || a == "--cert" || a == "--key" || a == "--server-name") {
      const auto* v = value(a);
      if (!v) return parsed;
      if (v->empty()) {
        parsed.error = a + " wants a value";
        return parsed;
      }
      (a == "--ca"     ? o.tls.ca
       : a == "--cert" ? o.tls.certificate
       : a == "--key"  ? o.tls.private_key
                       : o.tls.server_name) = *v;
    } else if (a == "--client-config") {
      const auto* v = value(a);
      if (!v) return parsed;
      if (auto e = load_client_config(*v, o); !e.empty()) {
        parsed.error = e;
        return parsed;
      }
    } else if (a == "--frame") {
      const auto* v = value(a);
      if (!v) return parsed;
      if (!parse_frame(*v, o.frame)) {
        parsed.error = "--frame wants camera or base, got '" + *v + "'";
        return parsed;
      }
    } else if (a == "--timeout") {
      const auto* v = value(a);
      if (!v) return parsed;
      if (!parse_double(*v, o.timeout_s) || o.timeout_s <= 0 || o.timeout_s > 3600) {
        parsed.error = "--timeout wants seconds in (0, 3600], got '" + *v + "'";
        return parsed;
      }
    } else if (a == "--retries") {
      const auto* v = value(a);
      if (!v) return parsed;
      if (!parse_int(*v, o.retries) || o.retries < 0 || o.retries > 100) {
        parsed.error = "--retries wants 0..100, got '" + *v + "'";
        return parsed;
      }
    } else {
      parsed.error = "unknown option '" + a + "'";
      const std::string guess =
          closest(a, kGlobalOptions, [](const OptionInfo& option) { return option.name; });
      if (!guess.empty()) parsed.error += " (did you mean '" + guess + "'?)";
      return parsed;
    }
  }
  parsed.command.assign(args.begin() + static_cast<std::ptrdiff_t>(i), args.end());
  return parsed;
}

CommandParse parse_command(std::span<const std::string> words_in, core::Frame frame) {
  if (words_in.empty()) return fail("no command given (try --help)");
  // A per-command --frame F may appear anywhere after the command word.
  std::vector<std::string> words;
  for (std::size_t i = 0; i < words_in.size(); ++i) {
    if (i > 0 && words_in[i] == "--frame") {
      if (i + 1 >= words_in.size() || !parse_frame(words_in[i + 1], frame)) {
        return fail("--frame wants camera or base");
      }
      ++i;
      continue;
    }
    words.push_back(words_in[i]);
  }
  const std::string& name = words[0];
  const std::span<const std::string> rest(words.data() + 1, words.size() - 1);
  Command c;
  c.name = name;

  // `help [COMMAND]` and `COMMAND --help` (or -h) anywhere after a known command.
  if (name == "help") {
    if (rest.size() > 1) return fail("help takes at most one COMMAND");
    if (rest.size() == 1 && (rest[0] == "--help" || rest[0] == "-h")) {
      c.kind = Command::Kind::kHelp;
      c.args = {"help"};
      return {c, {}};
    }
    if (rest.size() == 1 && find_command(rest[0]) == nullptr) {
      return fail(unknown_command_message(rest[0]));
    }
    c.kind = Command::Kind::kHelp;
    c.args.assign(rest.begin(), rest.end());
    return {c, {}};
  }
  if (find_command(name) != nullptr &&
      std::any_of(rest.begin(), rest.end(),
                  [](const std::string& w) { return w == "--help" || w == "-h"; })) {
    c.kind = Command::Kind::kHelp;
    c.args = {name};
    return {c, {}};
  }

  auto wait_options = [&](std::span<const std::string> opts) -> std::string {
    for (std::size_t i = 0; i < opts.size(); ++i) {
      if (opts[i] == "--no-wait") {
        c.wait = false;
      } else if (opts[i] == "--wait-timeout" && i + 1 < opts.size() &&
                 parse_seconds(opts[i + 1], c.wait_timeout_s, true)) {
        ++i;
      } else {
        return name + " takes [--no-wait] [--wait-timeout S (0 < S <= 1000000)], got " +
               quoted(opts, i);
      }
    }
    return {};
  };

  if (name == "ping") {
    c.kind = Command::Kind::kPing;
    for (std::size_t i = 0; i < rest.size(); ++i) {
      if (rest[i] == "-n" && i + 1 < rest.size() && parse_int(rest[i + 1], c.count) &&
          c.count > 0 && c.count <= 1000000) {
        ++i;
      } else if (rest[i] == "-i" && i + 1 < rest.size() &&
                 parse_seconds(rest[i + 1], c.interval_s)) {
        ++i;
      } else {
        return fail("ping takes [-n COUNT (1..1000000)] [-i SECONDS (0..1000000)], got " +
                    quoted(rest, i));
      }
    }
    c.request = protocol::Ping{};
    return {c, {}};
  }
  if (name == "status") {
    if (!rest.empty()) return fail("status takes no arguments");
    c.kind = Command::Kind::kStatus;
    c.request = protocol::GetStatus{};
    return {c, {}};
  }
  if (name == "model") {
    if (!rest.empty()) return fail("model takes no arguments");
    c.kind = Command::Kind::kRequest;
    c.request = protocol::GetRobotModel{};
    return {c, {}};
  }
  if (name == "watch") {
    c.kind = Command::Kind::kWatch;
    for (std::size_t i = 0; i < rest.size(); ++i) {
      if (rest[i] == "--rate" && i + 1 < rest.size() && parse_double(rest[i + 1], c.rate_hz) &&
          c.rate_hz >= 0 && c.rate_hz <= kMaxRateHz) {
        ++i;
      } else if (rest[i] == "--duration" && i + 1 < rest.size() &&
                 parse_seconds(rest[i + 1], c.duration_s)) {
        ++i;
      } else {
        return fail("watch takes [--rate HZ (0..1000000)] [--duration S (0..1000000)], got " +
                    quoted(rest, i));
      }
    }
    return {c, {}};
  }
  if (name == "measure") {
    if (rest.empty()) return fail("measure wants width, handle or plane");
    const std::string& what = rest[0];
    std::vector<protocol::FramedPoint> points;
    if (auto e = parse_points(rest.subspan(1), frame, points); !e.empty()) {
      return fail("measure " + what + ": " + e);
    }
    c.kind = Command::Kind::kRequest;
    c.needs_controller = true;
    if (what == "width" || what == "handle") {
      if (points.size() != 2) {
        return fail("measure " + what + " wants two points: X1 Y1 Z1 X2 Y2 Z2");
      }
      if (what == "width") {
        c.name = "measure_width";
        c.request = protocol::MeasureDoorWidth{points[0], points[1]};
      } else {
        c.name = "measure_handle";
        c.request = protocol::MeasureHandle{points[0], points[1]};
      }
      return {c, {}};
    }
    if (what == "plane") {
      if (points.size() < protocol::kMinPlanePoints || points.size() > protocol::kMaxPlanePoints) {
        return fail("measure plane wants 3 to 16 points (X Y Z each), got " +
                    std::to_string(points.size()));
      }
      protocol::MeasureDoorPlane plane;
      plane.count = static_cast<std::uint8_t>(points.size());
      std::copy(points.begin(), points.end(), plane.points.begin());
      c.name = "measure_plane";
      c.request = plane;
      return {c, {}};
    }
    return fail("measure wants width, handle or plane, got '" + what + "'");
  }
  if (name == "contact") {
    std::vector<protocol::FramedPoint> points;
    if (auto e = parse_points(rest, frame, points); !e.empty()) return fail("contact: " + e);
    if (points.size() != 1) return fail("contact wants one point: X Y Z");
    c.kind = Command::Kind::kRequest;
    c.needs_controller = true;
    c.request = protocol::SetContactPoint{points[0]};
    return {c, {}};
  }
  if (name == "align" || name == "engage") {
    if (auto e = wait_options(rest); !e.empty()) return fail(e);
    c.kind = name == "align" ? Command::Kind::kAlign : Command::Kind::kEngage;
    c.needs_controller = true;
    if (name == "align") {
      c.request = protocol::AlignBase{};
    } else {
      c.request = protocol::Engage{};
    }
    return {c, {}};
  }
  if (name == "drive") {
    c.kind = Command::Kind::kDrive;
    c.needs_controller = true;
    bool velocity = false;
    for (std::size_t i = 0; i < rest.size(); ++i) {
      if ((rest[i] == "--linear" || rest[i] == "--angular") && i + 1 < rest.size() &&
          parse_double(rest[i + 1], rest[i] == "--linear" ? c.linear_m_s : c.angular_rad_s)) {
        velocity = true;
        ++i;
      } else if (rest[i] == "--for" && i + 1 < rest.size() &&
                 parse_seconds(rest[i + 1], c.duration_s, true)) {
        ++i;
      } else {
        return fail(
            "drive takes nothing (keys), or [--linear M/S] [--angular RAD/S] --for S "
            "(0 < S <= 1000000), got " +
            quoted(rest, i));
      }
    }
    if (velocity && c.duration_s <= 0) return fail("drive --linear/--angular needs --for S");
    if (!velocity && c.duration_s > 0) return fail("drive --for needs --linear and/or --angular");
    return {c, {}};
  }
  if (name == "approach") {
    double standoff_m = 0;
    if (rest.empty() || !parse_double(rest[0], standoff_m)) {
      return fail("approach wants STANDOFF_M: the distance to the door plane in metres");
    }
    if (auto e = wait_options(rest.subspan(1)); !e.empty()) return fail(e);
    c.kind = Command::Kind::kApproach;
    c.needs_controller = true;
    c.request = protocol::Approach{standoff_m};
    return {c, {}};
  }
  if (name == "stop" || name == "estop") {
    if (!rest.empty()) return fail(name + " takes no arguments");
    c.kind = Command::Kind::kRequest;
    if (name == "stop") {
      c.request = protocol::Stop{};
    } else {
      c.request = protocol::EmergencyStop{};
    }
    return {c, {}};
  }
  if (name == "reset") {
    protocol::Reset reset;
    for (const auto& a : rest) {
      if (a != "--clear") return fail("reset takes [--clear], got '" + a + "'");
      reset.clear_parameters = true;
    }
    c.kind = Command::Kind::kRequest;
    c.needs_controller = true;
    c.request = reset;
    return {c, {}};
  }
  if (name == "sleep") {
    if (rest.size() != 1 || !parse_seconds(rest[0], c.duration_s)) {
      return fail("sleep wants SECONDS (0..1000000)");
    }
    c.kind = Command::Kind::kSleep;
    return {c, {}};
  }
  if (name == "conformance" || name == "simulate" || name == "script") {
    c.kind = name == "conformance" ? Command::Kind::kConformance
             : name == "simulate"  ? Command::Kind::kSimulate
                                   : Command::Kind::kScript;
    c.args.assign(rest.begin(), rest.end());
    if (c.kind == Command::Kind::kSimulate && c.args.empty()) {
      return fail("simulate wants SCENARIO.yaml");
    }
    if (c.kind == Command::Kind::kScript && c.args.size() > 1) {
      return fail("script takes at most one FILE");
    }
    return {c, {}};
  }
  return fail(unknown_command_message(name) + " (try --help)");
}

}  // namespace ajar::client
