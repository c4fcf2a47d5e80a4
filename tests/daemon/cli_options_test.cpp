// ajard's command line parsing and overrides.
#include <gtest/gtest.h>

#include <vector>

#include "ajar/daemon/cli.hpp"
#include "ajar/daemon/config.hpp"

namespace ajar::daemon {
namespace {

std::variant<CommandLine, UsageError> parse(std::vector<std::string_view> args) {
  return parse_command_line(args);
}

TEST(CommandLine, RunWithEveryOverride) {
  const auto parsed = parse({"--config", "a.yaml", "--listen", "127.0.0.1:0", "--port-file=/x/port",
                             "--state-dir", "/var/lib/x"});
  ASSERT_TRUE(std::holds_alternative<CommandLine>(parsed)) << std::get<UsageError>(parsed).message;
  const auto& cl = std::get<CommandLine>(parsed);
  EXPECT_EQ(cl.action, CommandLine::Action::kRun);
  EXPECT_EQ(cl.config_path, "a.yaml");
  ASSERT_TRUE(cl.listen);
  EXPECT_EQ(cl.listen->address, "127.0.0.1");
  EXPECT_EQ(cl.listen->port, 0);
  EXPECT_EQ(cl.port_file, "/x/port");
  EXPECT_EQ(cl.state_dir, "/var/lib/x");

  Config config;
  apply_overrides(cl, config);
  EXPECT_EQ(config.network.bind_address, "127.0.0.1");
  EXPECT_EQ(config.network.port, 0);
  EXPECT_EQ(config.state.directory, "/var/lib/x");
}

TEST(CommandLine, Actions) {
  EXPECT_EQ(std::get<CommandLine>(parse({"--check-config", "a.yaml"})).action,
            CommandLine::Action::kCheckConfig);
  EXPECT_EQ(std::get<CommandLine>(parse({"--version"})).action, CommandLine::Action::kVersion);
  EXPECT_EQ(std::get<CommandLine>(parse({"-h"})).action, CommandLine::Action::kHelp);
}

TEST(CommandLine, UsageErrorsSayWhatIsWrong) {
  auto message = [](std::vector<std::string_view> args) {
    const auto parsed = parse(std::move(args));
    return std::holds_alternative<UsageError>(parsed) ? std::get<UsageError>(parsed).message
                                                      : std::string();
  };
  EXPECT_NE(message({}).find("--config"), std::string::npos);
  EXPECT_NE(message({"--bogus"}).find("--bogus"), std::string::npos);
  EXPECT_NE(message({"--config"}).find("--config: 1 required FILE missing"), std::string::npos);
  EXPECT_NE(message({"--config", "a", "--listen", "nowhere"}).find("--listen"), std::string::npos);
  EXPECT_FALSE(message({"--config", "a", "--check-config", "b"}).empty());
  EXPECT_FALSE(message({"--config="}).empty());
}

TEST(CommandLine, ListenAddresses) {
  EXPECT_EQ(parse_listen_address("0.0.0.0:7450")->port, 7450);
  EXPECT_EQ(parse_listen_address("[::1]:7450")->address, "::1");
  EXPECT_FALSE(parse_listen_address("::1:7450"));
  EXPECT_FALSE(parse_listen_address("127.0.0.1:65536"));
  EXPECT_FALSE(parse_listen_address("127.0.0.1:"));
  EXPECT_FALSE(parse_listen_address(":80"));
  EXPECT_FALSE(parse_listen_address("127.0.0.1:8x"));
}

TEST(CommandLine, HelpNamesEveryOptionAndExitCode) {
  const std::string help = help_text();
  for (const char* s : {"--config", "--check-config", "--listen", "--port-file", "--state-dir",
                        "--version", "--help", "SIGHUP", "SIGTERM", "Exit status"}) {
    EXPECT_NE(help.find(s), std::string::npos) << s;
  }
}

}  // namespace
}  // namespace ajar::daemon
