// ajard's command line (main.cpp only calls ajard_main). Parsing is separate from running so that
// tests check it directly. The options and exit codes are documented in help_text() and
// docs/operations.md.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

namespace ajar::daemon {

struct Config;

// Exit codes of ajard.
inline constexpr int kExitOk = 0;       // clean shutdown (SIGTERM/SIGINT), --check-config OK
inline constexpr int kExitStartup = 1;  // start-up failed (drivers, socket, state directory)
inline constexpr int kExitUsage = 2;    // bad command line or config
inline constexpr int kExitWedged =
    3;  // SIGTERM/SIGINT found a motion-card call that never returned

struct ListenAddress {
  std::string address;
  std::uint16_t port = 0;
};

struct CommandLine {
  enum class Action { kRun, kCheckConfig, kVersion, kHelp };
  Action action = Action::kHelp;
  std::string config_path;               // --config FILE / --check-config FILE
  std::optional<ListenAddress> listen;   // --listen ADDR:PORT
  std::string port_file;                 // --port-file FILE ("" = none)
  std::optional<std::string> state_dir;  // --state-dir DIR
};

struct UsageError {
  std::string message;
};

// `args` excludes argv[0]. Accepts "--opt VALUE" and "--opt=VALUE".
std::variant<CommandLine, UsageError> parse_command_line(std::span<const std::string_view> args);
// "127.0.0.1:7450", "0.0.0.0:0", "[::1]:7450". Port 0 = any free port. protocol::parse_host_port
// (ajar/protocol/endpoint.hpp) with port 0 allowed.
std::optional<ListenAddress> parse_listen_address(std::string_view text);
// Applies --listen and --state-dir to a loaded config.
void apply_overrides(const CommandLine& command_line, Config& config);

std::string help_text();
std::string version_text();

// The whole program: parse, load the config, run. Returns the exit code.
int ajard_main(int argc, char** argv);

}  // namespace ajar::daemon
