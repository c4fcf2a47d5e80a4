// ajarctl: command-line parsing (CLI11: client/src/cli.cpp) and the commands themselves (ajarctl's
// main() is run_ajarctl).
// docs/ajarctl.md is the user's manual; usage() is the --help text.
#pragma once

#include <iosfwd>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "ajar/client/client.hpp"

namespace ajar::client {

// Exit codes of ajarctl (and of each command in script mode).
inline constexpr int kExitOk = 0;
inline constexpr int kExitRefused = 1;     // the daemon refused (error reply), a check failed
inline constexpr int kExitUsage = 2;       // bad command line
inline constexpr int kExitConnection = 3;  // cannot connect, connection lost, timeout

struct GlobalOptions {
  Endpoint endpoint;                         // --connect HOST:PORT (default 127.0.0.1:7450)
  bool json = false;                         // --json
  core::Frame frame = core::Frame::kCamera;  // --frame camera|base
  double timeout_s = 3.0;                    // --timeout S (per request attempt)
  int retries = 1;                           // --retries N (same request id)
  bool keep = false;                         // --keep: read commands from stdin after COMMAND
  bool keep_going = false;                   // --keep-going: script mode continues after a failure
  bool take_over = false;                    // --take-over: take control from another controller
  bool help = false;                         // --help / -h
  bool version = false;                      // --version
  // --ca FILE --cert FILE --key FILE [--server-name NAME], or --client-config FILE (YAML: connect,
  // tls.{ca, certificate, private_key, server_name}; relative paths from the file's folder).
  TlsOptions tls;
};

struct ParsedArgs {
  GlobalOptions options;
  std::vector<std::string> command;  // COMMAND and its arguments
  std::string error;                 // non-empty: usage error
};

// Parses the global options; stops at the first word that is not a global option.
ParsedArgs parse_global_options(std::span<const std::string> args);

// One command (from the command line, or one line in script mode).
struct Command {
  enum class Kind {
    kPing,
    kStatus,
    kWatch,
    kRequest,
    kAlign,
    kEngage,
    kConformance,
    kSimulate,
    kScript,
    kSleep,
    kDrive,     // drive: keys in a terminal (duration_s == 0), or --linear --angular --for S
    kApproach,  // approach STANDOFF_M: request holds the Approach
    kHelp,      // `help [COMMAND]` or `COMMAND --help`: args holds the COMMAND (or nothing)
    kBlackbox,  // blackbox list|fetch|save|show|export ...: args holds the rest (blackbox_cmd.cpp)
    kReplay,    // replay FILE [--settle S]: args holds the rest (replay.cpp)
  };
  Kind kind = Kind::kStatus;
  std::string name;           // "measure_width", "contact", "align", ...
  protocol::Message request;  // kRequest, kAlign, kEngage
  bool needs_controller = false;
  bool wait = true;             // align / engage / approach: wait for the outcome (--no-wait)
  double wait_timeout_s = 120;  // align / engage / approach: --wait-timeout S
  int count = 4;                // ping -n N
  double interval_s = 0;        // ping -i S
  double duration_s = 0;        // watch --duration S (0: until interrupted); sleep S; drive --for S
  double rate_hz = 10;          // watch --rate HZ
  double linear_m_s = 0;        // drive --linear V (m/s, + forward)
  double angular_rad_s = 0;     // drive --angular W (rad/s, CCW +)
  std::vector<std::string> args;  // conformance / simulate / script / blackbox / replay: theirs
};

struct CommandParse {
  std::optional<Command> command;
  std::string error;  // non-empty: usage error
};

// Parses COMMAND ARGS... Points are in `frame` unless the command says --frame itself.
CommandParse parse_command(std::span<const std::string> words, core::Frame frame);

// Splits a script line into words (blank-separated; '#' starts a comment). Empty: nothing to do.
std::vector<std::string> split_line(const std::string& line);

// The --help text (global options and the list of commands).
std::string usage();
// `ajarctl help COMMAND` / `ajarctl COMMAND --help`; empty if COMMAND is unknown.
std::string command_help(std::string_view command);
std::vector<std::string> command_names();
// "unknown command 'stauts' (did you mean 'status'?)" (the suggestion only when one is close).
std::string unknown_command_message(std::string_view word);
// bash completion (`ajarctl --complete WORD...`): what may follow the words typed so far (the
// options and command after ajarctl, then the command's arguments and options). "@file" / "@dir"
// ask the shell to complete a file or directory name.
std::vector<std::string> completion_words(std::span<const std::string> words_before);

// Where `ajarctl conformance` reads the golden vectors without --vectors: DATADIR/ajar/vectors of
// the install ajarctl runs from (found relative to the executable), else this source tree's
// tests/conformance/vectors (build tree), else ./tests/conformance/vectors.
std::string default_vectors_dir();

// The whole of ajarctl. `in` feeds script mode.
int run_ajarctl(std::span<const std::string> args, std::istream& in, std::ostream& out,
                std::ostream& err);

}  // namespace ajar::client
