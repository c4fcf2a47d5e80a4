// ajarctl's command line on CLI11: the global options (global_parser), then one command with its
// own options and arguments (command_parser); the meaning of the words is checked here.
#include "ajar/client/cli.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <tuple>

#include "ajar/protocol/message_table.hpp"
#include "cli_detail.hpp"

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

// Reads points (3 numbers each) from words; the error names the offending word.
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

CommandParse fail(std::string message) {
  return CommandParse{std::nullopt, std::move(message)};
}

// A CLI11 check: `parse` reads the word; `wanted` says what was wanted when it cannot
// ("--timeout: wants seconds in (0, 3600], got '0'").
template <typename Parse>
CLI::Validator wants(std::string wanted, Parse parse) {
  return CLI::Validator(
      [wanted, parse](std::string& word) {
        return parse(word) ? std::string() : "wants " + wanted + ", got '" + word + "'";
      },
      "");
}

CLI::Validator seconds_check(bool positive) {
  return wants(positive ? "seconds in (0, 1000000]" : "seconds in 0..1000000",
               [positive](const std::string& w) {
                 double s = 0;
                 return parse_seconds(w, s, positive);
               });
}

const CLI::Validator kFiniteCheck = wants("a finite number", [](const std::string& w) {
  double v = 0;
  return parse_double(w, v);
});

// A number option: its value is read into `out` once `check` passed.
CLI::Option* number_option(CLI::App& app, const std::string& name, double& out,
                           const CLI::Validator& check, const std::string& value_name,
                           const std::string& help) {
  return app
      .add_option_function<std::string>(
          name, [&out](const std::string& w) { parse_double(w, out); }, help)
      ->type_name(value_name)
      ->check(check);
}

}  // namespace

namespace detail {

std::unique_ptr<CLI::App> global_parser(GlobalOptions& o) {
  auto app = std::make_unique<CLI::App>("", "ajarctl");
  app->set_help_flag();  // --help is a flag of its own: run_ajarctl prints usage()
  app->prefix_command();
  app->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  // Each value applies as it is read, so that the later of --connect and --client-config wins.
  auto text = [&](const char* name, const char* value_name, const char* help, auto apply,
                  CLI::Validator check) {
    app->add_option_function<std::string>(name, apply, help)
        ->type_name(value_name)
        ->check(check)
        ->trigger_on_parse();
  };
  const auto non_empty = wants("a value", [](const std::string& w) { return !w.empty(); });
  text(
      "--connect", "HOST:PORT", "daemon address (default 127.0.0.1:7450)",
      [&o](const std::string& v) { o.endpoint = *parse_endpoint(v); },
      wants("HOST:PORT", [](const std::string& w) { return parse_endpoint(w).has_value(); }));
  for (auto [name, value_name, help, field] :
       {std::tuple{"--ca", "FILE", "speak TLS; the CA the daemon's certificate must chain to (PEM)",
                   &TlsOptions::ca},
        std::tuple{"--cert", "FILE", "this operator's certificate (PEM; docs/security.md)",
                   &TlsOptions::certificate},
        std::tuple{"--key", "FILE", "its private key (PEM, mode 0600: others' access is refused)",
                   &TlsOptions::private_key},
        std::tuple{"--server-name", "NAME",
                   "name the daemon's certificate must carry (default: HOST)",
                   &TlsOptions::server_name}}) {
    text(
        name, value_name, help, [&o, field = field](const std::string& v) { o.tls.*field = v; },
        non_empty);
  }
  text(
      "--client-config", "FILE", "connect and tls settings from YAML (docs/ajarctl.md)",
      [&o](const std::string& v) {
        if (auto e = detail::load_client_config(v, o); !e.empty()) throw CLI::ValidationError(e);
      },
      non_empty);
  app->add_flag("--json", o.json, "one JSON object per line per reply or event (docs/ajarctl.md)");
  text(
      "--frame", "camera|base", "frame of the points given to measure/contact (default camera)",
      [&o](const std::string& v) { parse_frame(v, o.frame); },
      wants("camera or base", [](const std::string& w) {
        core::Frame f{};
        return parse_frame(w, f);
      }));
  text(
      "--timeout", "S", "seconds to wait for each reply attempt (default 3)",
      [&o](const std::string& v) { parse_double(v, o.timeout_s); },
      wants("seconds in (0, 3600]", [](const std::string& w) {
        double s = 0;
        return parse_double(w, s) && s > 0 && s <= 3600;
      }));
  text(
      "--retries", "N", "re-sends of a timed-out request, same request id (default 1)",
      [&o](const std::string& v) { parse_int(v, o.retries); },
      wants("0..100", [](const std::string& w) {
        int n = 0;
        return parse_int(w, n) && n >= 0 && n <= 100;
      }));
  app->add_flag("--take-over", o.take_over, "take control from the current controller");
  app->add_flag("--keep", o.keep, "after COMMAND, read more commands from stdin (one session)");
  app->add_flag("--keep-going", o.keep_going, "in script mode, continue after a failed command");
  app->add_flag("--version", o.version, "print the version and exit");
  app->add_flag("-h,--help", o.help, "this help (-h); `ajarctl help COMMAND` for one command");
  return app;
}

std::unique_ptr<CLI::App> command_parser(const CommandInfo& info, core::Frame& frame,
                                         CommandArgs& a) {
  const std::string_view n = info.name;
  if (n == "help" || n == "conformance" || n == "simulate" || n == "script" || n == "blackbox" ||
      n == "replay")
    return nullptr;
  auto app = std::make_unique<CLI::App>("", std::string(n));
  app->set_help_flag();  // COMMAND --help is found before parsing
  app->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  Command& c = a.command;
  auto words = [&](const char* value_name) {
    app->add_option("words", a.words)
        ->type_name(value_name)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  };
  auto wait_options = [&] {
    app->add_flag("--no-wait", a.no_wait, "return after the Ack");
    number_option(*app, "--wait-timeout", c.wait_timeout_s, seconds_check(true), "S",
                  "wait at most S seconds (default 120)");
  };
  if (n == "ping") {
    app->add_option_function<std::string>(
           "-n", [&c](const std::string& w) { parse_int(w, c.count); }, "Pings to send")
        ->type_name("N")
        ->check(wants("a count in 1..1000000", [](const std::string& w) {
          int count = 0;
          return parse_int(w, count) && count > 0 && count <= 1000000;
        }));
    number_option(*app, "-i", c.interval_s, seconds_check(false), "S", "seconds between Pings");
  } else if (n == "watch") {
    number_option(*app, "--rate", c.rate_hz,
                  wants("HZ in 0..1000000",
                        [](const std::string& w) {
                          double hz = 0;
                          return parse_double(w, hz) && hz >= 0 && hz <= kMaxRateHz;
                        }),
                  "HZ", "telemetry rate");
    number_option(*app, "--duration", c.duration_s, seconds_check(false), "S", "watch S seconds");
  } else if (n == "measure" || n == "contact") {
    app->add_option_function<std::string>(
           "--frame", [&frame](const std::string& v) { parse_frame(v, frame); },
           "frame of these points")
        ->type_name("camera|base")
        ->check(wants("camera or base", [](const std::string& w) {
          core::Frame f{};
          return parse_frame(w, f);
        }));
    words(n == "measure" ? "WHAT X Y Z" : "X Y Z");
  } else if (n == "align" || n == "engage") {
    wait_options();
  } else if (n == "approach") {
    words("STANDOFF_M");
    wait_options();
  } else if (n == "drive") {
    for (auto [option, out, value_name, help] :
         {std::tuple{"--linear", &c.linear_m_s, "V", "m/s, + forward"},
          std::tuple{"--angular", &c.angular_rad_s, "W", "rad/s, CCW +"}}) {
      number_option(*app, option, *out, kFiniteCheck, value_name, help)
          ->each([&a](const std::string&) { a.velocity = true; });
    }
    number_option(*app, "--for", c.duration_s, seconds_check(true), "S", "drive S seconds");
  } else if (n == "reset") {
    app->add_flag("--clear", a.clear, "also discard the procedure");
  } else if (n == "sleep") {
    words("S");
  }
  // status, model, stop, estop: no options, no arguments.
  return app;
}

}  // namespace detail

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
  const auto app = detail::global_parser(parsed.options);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them reversed
  try {
    app->parse(reversed);
  } catch (const CLI::ParseError& e) {
    parsed.error = e.what();
    return parsed;
  }
  parsed.command = app->remaining();
  // An unknown option stops the parse like a command would: refuse it, with a guess.
  if (!parsed.command.empty() && parsed.command[0].size() > 1 &&
      parsed.command[0].starts_with('-')) {
    const std::string& word = parsed.command[0];
    std::vector<std::string> names;
    for (const CLI::Option* option : app->get_options()) {
      names.push_back(option->get_name());
    }
    parsed.error = "unknown option '" + word + "'";
    const std::string guess = detail::closest(word.substr(0, word.find('=')), names);
    if (!guess.empty()) parsed.error += " (did you mean '" + guess + "'?)";
  }
  return parsed;
}

namespace {

// `help [COMMAND]`.
CommandParse parse_help(Command c, std::span<const std::string> rest) {
  if (rest.size() > 1) return fail("help takes at most one COMMAND");
  if (rest.size() == 1 && (rest[0] == "--help" || rest[0] == "-h")) {
    c.kind = Command::Kind::kHelp;
    c.args = {"help"};
    return {c, {}};
  }
  if (rest.size() == 1 && detail::find_command(rest[0]) == nullptr) {
    return fail(unknown_command_message(rest[0]));
  }
  c.kind = Command::Kind::kHelp;
  c.args.assign(rest.begin(), rest.end());
  return {c, {}};
}

// conformance, simulate, script: their words go on to the command's own parser.
CommandParse parse_passthrough(Command c, std::span<const std::string> rest) {
  c.kind = c.name == "conformance" ? Command::Kind::kConformance
           : c.name == "simulate"  ? Command::Kind::kSimulate
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

// `measure width|handle|plane X Y Z ...`: the request, in `frame`.
CommandParse parse_measure(Command c, const std::vector<std::string>& args, core::Frame frame) {
  if (args.empty()) return fail("measure wants width, handle or plane");
  const std::string& what = args[0];
  std::vector<protocol::FramedPoint> points;
  if (auto e = parse_points(std::span(args).subspan(1), frame, points); !e.empty()) {
    return fail("measure " + what + ": " + e);
  }
  c.kind = Command::Kind::kRequest;
  c.needs_controller = protocol::needs_controller(protocol::MessageType::kMeasureDoorWidth);
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

// The commands whose words are read after CLI11 (contact, drive, approach, reset, sleep).
CommandParse parse_arguments(Command c, const detail::CommandArgs& a, core::Frame frame) {
  const std::string& name = c.name;
  const std::vector<std::string>& args = a.words;
  if (name == "contact") {
    std::vector<protocol::FramedPoint> points;
    if (auto e = parse_points(args, frame, points); !e.empty()) return fail("contact: " + e);
    if (points.size() != 1) return fail("contact wants one point: X Y Z");
    c.kind = Command::Kind::kRequest;
    c.request = protocol::SetContactPoint{points[0]};
    c.needs_controller = protocol::needs_controller(protocol::type_of(c.request));
    return {c, {}};
  }
  if (name == "drive") {
    c.kind = Command::Kind::kDrive;
    c.needs_controller = protocol::needs_controller(protocol::MessageType::kDrive);
    if (a.velocity && c.duration_s <= 0) return fail("drive --linear/--angular needs --for S");
    if (!a.velocity && c.duration_s > 0) return fail("drive --for needs --linear and/or --angular");
    return {c, {}};
  }
  if (name == "approach") {
    double standoff_m = 0;
    if (args.size() != 1 || !parse_double(args[0], standoff_m)) {
      return fail("approach wants STANDOFF_M: the distance to the door plane in metres");
    }
    c.kind = Command::Kind::kApproach;
    c.request = protocol::Approach{standoff_m};
    c.needs_controller = protocol::needs_controller(protocol::type_of(c.request));
    return {c, {}};
  }
  if (name == "reset") {
    protocol::Reset reset;
    reset.clear_parameters = a.clear;
    c.request = reset;
    c.kind = Command::Kind::kRequest;
    c.needs_controller = protocol::needs_controller(protocol::type_of(c.request));
    return {c, {}};
  }
  if (name == "sleep") {
    if (args.size() != 1 || !parse_seconds(args[0], c.duration_s)) {
      return fail("sleep wants SECONDS (0..1000000)");
    }
    c.kind = Command::Kind::kSleep;
    return {c, {}};
  }
  return fail(unknown_command_message(name) + " (try --help)");
}

}  // namespace

CommandParse parse_command(std::span<const std::string> words, core::Frame frame) {
  if (words.empty()) return fail("no command given (try --help)");
  const std::string& name = words[0];
  const std::span<const std::string> rest = words.subspan(1);
  Command c;
  c.name = name;

  // `help [COMMAND]` and `COMMAND --help` (or -h) anywhere after a known command.
  if (name == "help") return parse_help(c, rest);
  const detail::CommandInfo* info = detail::find_command(name);
  if (info == nullptr) return fail(unknown_command_message(name) + " (try --help)");
  if (std::any_of(rest.begin(), rest.end(),
                  [](const std::string& w) { return w == "--help" || w == "-h"; })) {
    c.kind = Command::Kind::kHelp;
    c.args = {name};
    return {c, {}};
  }
  if (name == "conformance" || name == "simulate" || name == "script") {
    return parse_passthrough(c, rest);  // their own parsers read the words
  }
  if (name == "blackbox" || name == "replay") {  // their own parsers (blackbox_cmd.cpp, replay.cpp)
    c.kind = name == "blackbox" ? Command::Kind::kBlackbox : Command::Kind::kReplay;
    c.args.assign(rest.begin(), rest.end());
    if (c.args.empty()) {
      return fail(name == "blackbox" ? "blackbox wants list, fetch, save, show or export"
                                     : "replay wants FILE");
    }
    return {c, {}};
  }

  detail::CommandArgs a;
  a.command = c;
  {
    const auto app = detail::command_parser(*info, frame, a);
    std::vector<std::string> reversed(rest.rbegin(), rest.rend());
    try {
      app->parse(reversed);
    } catch (const CLI::ParseError& e) {
      return fail(name + ": " + e.what() + " (usage: " + std::string(info->synopsis) + ")");
    }
  }
  c = a.command;
  c.wait = !a.no_wait;
  const std::vector<std::string>& args = a.words;

  // The commands that are one request with nothing more to read: kind, request. Whether a command
  // connects as the controller is its request's row in the message table (message_table.hpp).
  using Kind = Command::Kind;
  static const std::tuple<std::string_view, Kind, protocol::Message> kFixed[] = {
      {"ping", Kind::kPing, protocol::Ping{}},
      {"status", Kind::kStatus, protocol::GetStatus{}},
      {"model", Kind::kRequest, protocol::GetRobotModel{}},
      {"align", Kind::kAlign, protocol::AlignBase{}},
      {"engage", Kind::kEngage, protocol::Engage{}},
      {"stop", Kind::kRequest, protocol::Stop{}},
      {"estop", Kind::kRequest, protocol::EmergencyStop{}},
  };
  for (const auto& [fixed, kind, request] : kFixed) {
    if (fixed == name) {
      c.kind = kind;
      c.request = request;
      c.needs_controller = protocol::needs_controller(protocol::type_of(request));
      return {c, {}};
    }
  }
  if (name == "watch") {
    c.kind = Command::Kind::kWatch;
    return {c, {}};
  }
  if (name == "measure") return parse_measure(c, args, frame);
  return parse_arguments(c, a, frame);
}

}  // namespace ajar::client
