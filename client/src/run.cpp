// ajarctl's main: the command line, then one command, a script (file or stdin) or both (--keep)
// on one Session (session.hpp).
#include <fstream>
#include <istream>

#include "ajar/client/cli.hpp"
#include "ajar/client/conformance.hpp"
#include "ajar/client/simulate.hpp"
#include "ajar/version.hpp"
#include "blackbox_cmd.hpp"
#include "session.hpp"

namespace ajar::client {

namespace {

int usage_error(std::ostream& err, const std::string& message) {
  err << "ajarctl: " << message << "\n(ajarctl --help lists the commands)\n";
  return kExitUsage;
}

// Commands one per line from `in` on one controller session.
int run_script(Session& session, std::istream& in, const GlobalOptions& options,
               std::ostream& err) {
  if (int rc = session.open(true); rc != kExitOk) return rc;
  session.set_script_mode();
  int worst = kExitOk;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto words = split_line(line);
    if (words.empty()) continue;
    if (words[0] == "quit" || words[0] == "exit") break;
    const CommandParse parsed = parse_command(words, options.frame);
    int rc = kExitOk;
    if (!parsed.command) {
      rc = usage_error(err, "line " + std::to_string(line_number) + ": " + parsed.error);
    } else {
      rc = session.execute(*parsed.command);
    }
    if (rc != kExitOk) {
      if (worst == kExitOk) worst = rc;
      if (!options.keep_going || rc == kExitConnection) return rc;
    }
  }
  return worst;
}

}  // namespace

int run_ajarctl(std::span<const std::string> args, std::istream& in, std::ostream& out,
                std::ostream& err) {
  if (!args.empty() && args[0] == "--complete") {  // bash completion (client/completion/ajarctl)
    for (const auto& word : completion_words(args.subspan(1)))
      out << word << '\n';
    return kExitOk;
  }
  const ParsedArgs parsed = parse_global_options(args);
  if (!parsed.error.empty()) return usage_error(err, parsed.error);
  const GlobalOptions& options = parsed.options;
  if (options.help) {
    out << usage();
    return kExitOk;
  }
  if (options.version) {
    out << "ajarctl " << ajar::kVersion << " (protocol " << int{protocol::kVersionMajor} << "."
        << int{protocol::kVersionMinor} << ")\n";
    return kExitOk;
  }
  catch_interrupts();

  if (parsed.command.empty()) {
    if (!options.keep) return usage_error(err, "no command given");
    Session session(options, out, err);
    return run_script(session, in, options, err);
  }
  const CommandParse command = parse_command(parsed.command, options.frame);
  if (!command.command) return usage_error(err, command.error);
  const Command& c = *command.command;
  switch (c.kind) {
    case Command::Kind::kHelp:
      out << (c.args.empty() ? usage() : command_help(c.args[0]));
      return kExitOk;
    case Command::Kind::kConformance:
      return run_conformance(c, options, out, err);
    case Command::Kind::kSimulate:
      return run_simulate(c, options, out, err);
    case Command::Kind::kBlackbox:
      return run_blackbox(c, options, out, err);
    case Command::Kind::kReplay:
      return run_replay(c, options, out, err);
    case Command::Kind::kScript: {
      Session session(options, out, err);
      if (c.args.empty()) return run_script(session, in, options, err);
      std::ifstream file(c.args[0]);
      if (!file) return usage_error(err, "cannot read script file '" + c.args[0] + "'");
      return run_script(session, file, options, err);
    }
    default:
      break;
  }
  Session session(options, out, err);
  if (options.keep) session.set_script_mode();  // stdin holds the commands that follow
  if (int rc = session.open(c.needs_controller || options.keep); rc != kExitOk) return rc;
  int rc = session.execute(c);
  if (options.keep && (rc == kExitOk || options.keep_going)) {
    const int script_rc = run_script(session, in, options, err);
    if (rc == kExitOk) rc = script_rc;
  }
  return rc;
}

}  // namespace ajar::client
