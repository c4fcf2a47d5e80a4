#include "ajar/daemon/cli.hpp"

#include <charconv>
#include <csignal>
#include <cstdio>
#include <exception>
#include <iostream>
#include <vector>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/daemon.hpp"
#include "ajar/daemon/logging.hpp"
#include "ajar/protocol/messages.hpp"
#include "ajar/version.hpp"

namespace ajar::daemon {
namespace {

// Options that take a value.
enum class Option { kConfig, kCheckConfig, kListen, kPortFile, kStateDir };

struct OptionName {
  std::string_view name;
  Option option;
};
constexpr OptionName kValueOptions[] = {
    {"--config", Option::kConfig},      {"--check-config", Option::kCheckConfig},
    {"--listen", Option::kListen},      {"--port-file", Option::kPortFile},
    {"--state-dir", Option::kStateDir},
};

}  // namespace

std::optional<ListenAddress> parse_listen_address(std::string_view text) {
  std::string_view host;
  std::string_view port;
  if (!text.empty() && text.front() == '[') {
    const auto close = text.find("]:");
    if (close == std::string_view::npos) return std::nullopt;
    host = text.substr(1, close - 1);
    port = text.substr(close + 2);
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string_view::npos) return std::nullopt;
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
    if (host.find(':') != std::string_view::npos) return std::nullopt;  // IPv6 needs [..]
  }
  if (host.empty() || port.empty()) return std::nullopt;
  unsigned value = 0;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
  if (ec != std::errc() || end != port.data() + port.size() || value > 65535) return std::nullopt;
  return ListenAddress{std::string(host), static_cast<std::uint16_t>(value)};
}

std::variant<CommandLine, UsageError> parse_command_line(std::span<const std::string_view> args) {
  CommandLine cl;
  bool have_action = false;
  auto set_action = [&](CommandLine::Action action,
                        std::string_view flag) -> std::optional<UsageError> {
    if (have_action && cl.action != action) {
      return UsageError{std::string(flag) + " cannot be combined with the other action given"};
    }
    have_action = true;
    cl.action = action;
    return std::nullopt;
  };
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string_view arg = args[i];
    if (arg == "--help" || arg == "-h") {
      if (auto e = set_action(CommandLine::Action::kHelp, arg)) return *e;
      continue;
    }
    if (arg == "--version") {
      if (auto e = set_action(CommandLine::Action::kVersion, arg)) return *e;
      continue;
    }
    std::string_view name = arg;
    std::optional<std::string_view> value;
    if (const auto eq = arg.find('='); arg.starts_with("--") && eq != std::string_view::npos) {
      name = arg.substr(0, eq);
      value = arg.substr(eq + 1);
    }
    const OptionName* known = nullptr;
    for (const auto& o : kValueOptions) {
      if (o.name == name) known = &o;
    }
    if (known == nullptr) {
      return UsageError{"unknown option '" + std::string(arg) + "' (see ajard --help)"};
    }
    if (!value) {
      if (i + 1 >= args.size()) return UsageError{std::string(name) + " needs a value"};
      value = args[++i];
    }
    if (value->empty()) return UsageError{std::string(name) + " needs a non-empty value"};
    switch (known->option) {
      case Option::kConfig:
        if (auto e = set_action(CommandLine::Action::kRun, name)) return *e;
        cl.config_path = std::string(*value);
        break;
      case Option::kCheckConfig:
        if (auto e = set_action(CommandLine::Action::kCheckConfig, name)) return *e;
        cl.config_path = std::string(*value);
        break;
      case Option::kListen:
        cl.listen = parse_listen_address(*value);
        if (!cl.listen) {
          return UsageError{"--listen: '" + std::string(*value) +
                            "' is not ADDRESS:PORT (e.g. 127.0.0.1:7450, [::1]:0)"};
        }
        break;
      case Option::kPortFile:
        cl.port_file = std::string(*value);
        break;
      case Option::kStateDir:
        cl.state_dir = std::string(*value);
        break;
    }
  }
  if (!have_action) return UsageError{"nothing to do: give --config FILE (see ajard --help)"};
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
  return R"(Usage: ajard --config FILE [--listen ADDR:PORT] [--port-file FILE] [--state-dir DIR]
  or:  ajard --check-config FILE [--listen ADDR:PORT] [--state-dir DIR]
  or:  ajard --version | --help

ajard is the Ajar door-opening controller daemon: it serves the Ajar wire protocol over TCP and
drives the mobile base (motion card) and the arm (serial) selected by the config.

Options:
  --config FILE         run the daemon with the YAML config FILE.
  --check-config FILE   load and validate FILE, print the effective config (every key, defaults
                        filled in, after the overrides below) as YAML, and exit.
  --listen ADDR:PORT    listen here instead of network.bind_address/network.port; port 0 lets the
                        kernel choose a free port (see --port-file). IPv6: [::1]:7450.
  --port-file FILE      once the daemon serves (drivers active, socket listening), write the bound
                        TCP port to FILE (atomically: written to a temporary file, then renamed).
  --state-dir DIR       keep the persisted procedure state in DIR instead of state.directory.
  --version             print the version and exit.
  --help, -h            print this help and exit.
Options take their value as the next argument or after '=' (--listen=127.0.0.1:0).

Signals:
  SIGTERM, SIGINT       stop any motion, persist the state, close the sessions, exit 0.
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
  1  start-up failed (drivers, card library, serial device, socket, state directory, port file);
     the message names what failed
  2  bad command line, or the config file is invalid (the message names file, key, value and
     what is allowed)
)";
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
