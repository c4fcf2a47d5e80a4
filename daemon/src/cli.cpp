#include "ajar/daemon/cli.hpp"

#include <csignal>
#include <cstdio>
#include <exception>
#include <iostream>
#include <memory>
#include <vector>

#include <CLI/CLI.hpp>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/daemon.hpp"
#include "ajar/daemon/logging.hpp"
#include "ajar/protocol/endpoint.hpp"
#include "ajar/protocol/messages.hpp"
#include "ajar/version.hpp"

namespace ajar::daemon {
namespace {

constexpr const char* kUsage =
    R"(Usage: ajard --config FILE [--listen ADDR:PORT] [--port-file FILE] [--state-dir DIR]
  or:  ajard --check-config FILE [--listen ADDR:PORT] [--state-dir DIR]
  or:  ajard --version | --help

ajard is the Ajar door-opening controller daemon: it serves the Ajar wire protocol over TCP and
drives the mobile base (motion card) and the arm (serial) selected by the config.
)";

constexpr const char* kFooter =
    R"(Options take their value as the next argument or after '=' (--listen=127.0.0.1:0).

Signals:
  SIGTERM, SIGINT       stop any motion (Stop and EmergencyStop are still executed and
                        acknowledged meanwhile, anything else gets SHUTTING_DOWN), persist the
                        state with the clean-shutdown mark, close the sessions, exit 0.
  (anything else)       an end without the clean-shutdown mark (kill -9, crash, watchdog
                        abort, power loss): the next start latches UNCLEAN_SHUTDOWN, and
                        nothing moves until an operator's Reset.
  SIGPIPE               ignored.
  SIGHUP                re-read the config file and apply logging.level; no other key is
                        reloaded: the log names the keys applied and the changed keys that need
                        a restart; a config that does not load is logged and ignored
                        (systemctl reload ajard sends SIGHUP).

Logging goes to journald when run by systemd (JOURNAL_STREAM or INVOCATION_ID set), else to
stderr, unless logging.sink says otherwise. Under systemd (Type=notify) ajard sends READY=1 once
it serves, WATCHDOG=1 while its control loop is healthy, and STOPPING=1 on shutdown.

Exit status:
  0  clean shutdown; --check-config: the config is valid; --version, --help
  1  start-up failed (drivers, card library, serial device, socket, state directory or state
     file not writable, port file); the message names what failed
  2  bad command line, or the config file is invalid (the message names file, key, value and
     what is allowed)
  3  shutdown (SIGTERM/SIGINT) with a motion-card call that never returned: the base was
     emergency-stopped out of band and the state persisted; the card was not brought down)";

// CLI11's help with ajard's usage lines and description first.
class HelpFormatter : public CLI::Formatter {
 public:
  HelpFormatter() { column_width(24); }
  std::string make_description(const CLI::App*) const override { return ""; }
  std::string make_usage(const CLI::App*, std::string) const override { return kUsage; }
  std::string make_option_opts(const CLI::Option* option) const override {
    return option->get_type_name().empty() ? "" : " " + option->get_type_name();
  }
};

// What the parser fills in, besides CommandLine's own fields.
struct Flags {
  std::string listen;
  bool version = false;
  bool help = false;
};

// The one description of ajard's options: parse_command_line() parses with it, help_text()
// prints it.
std::unique_ptr<CLI::App> make_parser(CommandLine& cl, Flags& flags) {
  auto app = std::make_unique<CLI::App>("", "ajard");
  app->set_help_flag();  // -h/--help is an action of its own (kHelp), not an exception
  app->formatter(std::make_shared<HelpFormatter>());
  app->footer(kFooter);
  const CLI::Validator non_empty(
      [](const std::string& v) { return v.empty() ? std::string("needs a non-empty value") : ""; },
      "", "non-empty");
  const CLI::Validator listen_address(
      [](const std::string& v) {
        return parse_listen_address(v)
                   ? std::string()
                   : "'" + v + "' is not ADDRESS:PORT (e.g. 127.0.0.1:7450, [::1]:0)";
      },
      "", "ADDR:PORT");
  auto* run =
      app->add_option("--config", cl.config_path, "run the daemon with the YAML config FILE.")
          ->type_name("FILE")
          ->check(non_empty);
  auto* check = app->add_option("--check-config", cl.config_path,
                                "load and validate FILE, print the effective config (every key,\n"
                                "defaults filled in, after the overrides below) as YAML, and exit.")
                    ->type_name("FILE")
                    ->check(non_empty);
  app->add_option("--listen", flags.listen,
                  "listen here instead of network.bind_address/network.port; port 0\n"
                  "lets the kernel choose a free port (see --port-file). IPv6: [::1]:7450.")
      ->type_name("ADDR:PORT")
      ->check(listen_address);
  app->add_option("--port-file", cl.port_file,
                  "once the daemon serves (drivers active, socket listening), write the\n"
                  "bound TCP port to FILE (atomically: a temporary file, then renamed).")
      ->type_name("FILE")
      ->check(non_empty);
  app->add_option("--state-dir", cl.state_dir,
                  "keep the persisted procedure state in DIR instead of state.directory.")
      ->type_name("DIR")
      ->check(non_empty);
  auto* version = app->add_flag("--version", flags.version, "print the version and exit.");
  auto* help = app->add_flag("-h,--help", flags.help, "print this help and exit.");
  // One action: run, check, version or help.
  const std::vector<CLI::Option*> actions = {run, check, version, help};
  for (auto* a : actions) {
    for (auto* b : actions) {
      if (a != b) a->excludes(b);
    }
  }
  return app;
}

}  // namespace

std::optional<ListenAddress> parse_listen_address(std::string_view text) {
  auto parsed = protocol::parse_host_port(text, protocol::PortZero::kAllowed);
  if (!parsed) return std::nullopt;
  return ListenAddress{std::move(parsed->host), parsed->port};
}

std::variant<CommandLine, UsageError> parse_command_line(std::span<const std::string_view> args) {
  CommandLine cl;
  Flags flags;
  const auto app = make_parser(cl, flags);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them reversed
  try {
    app->parse(reversed);
  } catch (const CLI::ParseError& e) {
    return UsageError{std::string(e.what()) + " (see ajard --help)"};
  }
  if (flags.help) {
    cl.action = CommandLine::Action::kHelp;
  } else if (flags.version) {
    cl.action = CommandLine::Action::kVersion;
  } else if (app->count("--check-config") != 0) {
    cl.action = CommandLine::Action::kCheckConfig;
  } else if (app->count("--config") != 0) {
    cl.action = CommandLine::Action::kRun;
  } else {
    return UsageError{"nothing to do: give --config FILE (see ajard --help)"};
  }
  if (!flags.listen.empty()) cl.listen = parse_listen_address(flags.listen);
  return cl;
}

void apply_overrides(const CommandLine& command_line, Config& config) {
  if (command_line.listen) {
    config.network.bind_address = command_line.listen->address;
    config.network.port = command_line.listen->port;
  }
  if (command_line.state_dir) config.state.directory = *command_line.state_dir;
}

std::string version_text() {
  return std::string("ajard ") + ajar::kVersion + " (protocol " +
         std::to_string(protocol::kVersionMajor) + "." + std::to_string(protocol::kVersionMinor) +
         ")\n";
}

std::string help_text() {
  CommandLine cl;
  Flags flags;
  return make_parser(cl, flags)->help();
}

int ajard_main(int argc, char** argv) {
  std::vector<std::string_view> args;
  for (int i = 1; i < argc; ++i)
    args.emplace_back(argv[i]);
  const auto parsed = parse_command_line(args);
  if (const auto* usage = std::get_if<UsageError>(&parsed)) {
    std::cerr << "ajard: " << usage->message << "\n";
    return kExitUsage;
  }
  const CommandLine cl = std::get<CommandLine>(parsed);
  switch (cl.action) {
    case CommandLine::Action::kHelp:
      std::cout << help_text();
      return kExitOk;
    case CommandLine::Action::kVersion:
      std::cout << version_text();
      return kExitOk;
    default:
      break;
  }

  Config config;
  try {
    config = load_config(cl.config_path);
    apply_overrides(cl, config);
  } catch (const ConfigError& e) {
    std::cerr << e.what() << "\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << cl.config_path << ": " << e.what() << "\n";
    return kExitUsage;
  }
  if (cl.action == CommandLine::Action::kCheckConfig) {
    std::cout << to_yaml(config);
    std::cout.flush();
    return kExitOk;
  }

  // A log line to a closed stderr pipe must not kill the daemon (sockets use MSG_NOSIGNAL anyway).
  std::signal(SIGPIPE, SIG_IGN);
  init_logging(config.logging);
  RunOptions options;
  options.port_file = cl.port_file;
  options.reload_config = [cl] {
    Config fresh = load_config(cl.config_path);
    apply_overrides(cl, fresh);
    return fresh;
  };
  const int code = run_daemon(config, options);
  shutdown_logging();
  return code;
}

}  // namespace ajar::daemon
