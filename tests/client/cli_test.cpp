// ajarctl's argument parsing (CLI11): global options, every command, and usage errors (exit code 2)
// that name the option and the value that was wrong.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "ajar/client/cli.hpp"

namespace ajar::client {
namespace {

std::vector<std::string> words(std::initializer_list<const char*> w) {
  return {w.begin(), w.end()};
}

CommandParse parse(std::initializer_list<const char*> w, core::Frame frame = core::Frame::kCamera) {
  const auto v = words(w);
  return parse_command(v, frame);
}

TEST(Endpoint, ParsesHostPortAndIpv6) {
  auto e = parse_endpoint("10.0.0.2:7450");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->host, "10.0.0.2");
  EXPECT_EQ(e->port, 7450);
  e = parse_endpoint("[::1]:9");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->host, "::1");
  EXPECT_EQ(e->port, 9);
  for (const char* bad :
       {"", "host", "host:", ":7450", "host:0", "host:65536", "host:12x", "::1:5"}) {
    EXPECT_FALSE(parse_endpoint(bad)) << bad;
  }
}

TEST(GlobalOptions, ParsedUntilTheCommand) {
  const auto args = words({"--connect", "robot:7451", "--json", "--frame", "base", "--timeout",
                           "2.5", "--retries", "3", "--take-over", "status", "--json"});
  const ParsedArgs p = parse_global_options(args);
  ASSERT_TRUE(p.error.empty()) << p.error;
  EXPECT_EQ(p.options.endpoint.host, "robot");
  EXPECT_EQ(p.options.endpoint.port, 7451);
  EXPECT_TRUE(p.options.json);
  EXPECT_EQ(p.options.frame, core::Frame::kBase);
  EXPECT_DOUBLE_EQ(p.options.timeout_s, 2.5);
  EXPECT_EQ(p.options.retries, 3);
  EXPECT_TRUE(p.options.take_over);
  EXPECT_EQ(p.command, words({"status", "--json"}));
}

TEST(GlobalOptions, MistakesAreUsageErrors) {
  for (auto bad : {words({"--frame", "world"}), words({"--connect"}), words({"--timeout", "0"}),
                   words({"--timeout", "x"}), words({"--retries", "-1"}), words({"--bogus"})}) {
    EXPECT_FALSE(parse_global_options(bad).error.empty());
  }
}

TEST(Commands, MeasureWidthInTheGivenFrame) {
  const auto p = parse({"measure", "width", "0.1", "-0.2", "1.5", "0.5", "-0.2", "1.6"});
  ASSERT_TRUE(p.command) << p.error;
  EXPECT_TRUE(p.command->needs_controller);
  EXPECT_EQ(p.command->name, "measure_width");
  const auto& m = std::get<protocol::MeasureDoorWidth>(p.command->request);
  EXPECT_EQ(m.p1_hinge.frame, core::Frame::kCamera);
  EXPECT_EQ(m.p1_hinge.position_m, core::Vec3(0.1, -0.2, 1.5));
  EXPECT_EQ(m.p2_moving_edge.position_m, core::Vec3(0.5, -0.2, 1.6));

  const auto b = parse({"measure", "handle", "1", "0", "0", "1", "0.1", "0"}, core::Frame::kBase);
  ASSERT_TRUE(b.command);
  EXPECT_EQ(std::get<protocol::MeasureHandle>(b.command->request).p2_free_end.frame,
            core::Frame::kBase);
  const auto own = parse({"contact", "1", "0", "0.3", "--frame", "base"});
  ASSERT_TRUE(own.command);
  EXPECT_EQ(std::get<protocol::SetContactPoint>(own.command->request).contact.frame,
            core::Frame::kBase);
}

TEST(Commands, MeasurePlaneTakesThreeToSixteenPoints) {
  std::vector<std::string> w{"measure", "plane"};
  for (int i = 0; i < 9; ++i)
    w.push_back(std::to_string(i + 1));
  auto p = parse_command(w, core::Frame::kCamera);
  ASSERT_TRUE(p.command) << p.error;
  EXPECT_EQ(std::get<protocol::MeasureDoorPlane>(p.command->request).count, 3);
  EXPECT_EQ(std::get<protocol::MeasureDoorPlane>(p.command->request).points[2].position_m,
            core::Vec3(7, 8, 9));
  for (int n : {2, 17}) {
    std::vector<std::string> v{"measure", "plane"};
    for (int i = 0; i < 3 * n; ++i)
      v.push_back("1");
    EXPECT_FALSE(parse_command(v, core::Frame::kCamera).command) << n << " points";
  }
  EXPECT_FALSE(parse({"measure", "plane", "1", "2", "3", "4", "5", "6", "7", "8"}).command);
}

TEST(Commands, NumbersMustBeFinite) {
  EXPECT_FALSE(parse({"contact", "nan", "0", "1"}).command);
  EXPECT_FALSE(parse({"contact", "inf", "0", "1"}).command);
  EXPECT_FALSE(parse({"contact", "1x", "0", "1"}).command);
  EXPECT_TRUE(parse({"contact", "+1", "-0", "1e-1"}).command);
}

TEST(Commands, EveryCommandParses) {
  auto ping = parse({"ping", "-n", "10", "-i", "0.1"});
  ASSERT_TRUE(ping.command);
  EXPECT_EQ(ping.command->count, 10);
  EXPECT_FALSE(ping.command->needs_controller);
  EXPECT_TRUE(std::holds_alternative<protocol::GetStatus>(parse({"status"}).command->request));
  auto watch = parse({"watch", "--rate", "5", "--duration", "2"});
  ASSERT_TRUE(watch.command);
  EXPECT_DOUBLE_EQ(watch.command->rate_hz, 5);
  auto align = parse({"align", "--no-wait"});
  ASSERT_TRUE(align.command);
  EXPECT_EQ(align.command->kind, Command::Kind::kAlign);
  EXPECT_FALSE(align.command->wait);
  EXPECT_TRUE(parse({"align"}).command->wait);
  EXPECT_EQ(parse({"engage", "--wait-timeout", "5"}).command->wait_timeout_s, 5);
  EXPECT_TRUE(std::holds_alternative<protocol::Stop>(parse({"stop"}).command->request));
  EXPECT_FALSE(parse({"stop"}).command->needs_controller);  // any role may stop
  EXPECT_TRUE(std::holds_alternative<protocol::EmergencyStop>(parse({"estop"}).command->request));
  EXPECT_FALSE(std::get<protocol::Reset>(parse({"reset"}).command->request).clear_parameters);
  EXPECT_TRUE(
      std::get<protocol::Reset>(parse({"reset", "--clear"}).command->request).clear_parameters);
  EXPECT_EQ(parse({"conformance", "--vectors", "d"}).command->args, words({"--vectors", "d"}));
  EXPECT_EQ(parse({"simulate", "s.yaml"}).command->kind, Command::Kind::kSimulate);
  EXPECT_EQ(parse({"sleep", "0.5"}).command->kind, Command::Kind::kSleep);
  EXPECT_TRUE(std::holds_alternative<protocol::GetRobotModel>(parse({"model"}).command->request));
  auto keys = parse({"drive"});
  ASSERT_TRUE(keys.command);
  EXPECT_EQ(keys.command->kind, Command::Kind::kDrive);
  EXPECT_EQ(keys.command->duration_s, 0) << "no --for: keys";
  EXPECT_TRUE(keys.command->needs_controller);
  auto timed = parse({"drive", "--linear", "0.2", "--angular", "-0.1", "--for", "1.5"});
  ASSERT_TRUE(timed.command);
  EXPECT_EQ(timed.command->linear_m_s, 0.2);
  EXPECT_EQ(timed.command->angular_rad_s, -0.1);
  EXPECT_EQ(timed.command->duration_s, 1.5);
  auto approach = parse({"approach", "0.75", "--wait-timeout", "30"});
  ASSERT_TRUE(approach.command);
  EXPECT_EQ(approach.command->kind, Command::Kind::kApproach);
  EXPECT_EQ(std::get<protocol::Approach>(approach.command->request).standoff_m, 0.75);
  EXPECT_EQ(approach.command->wait_timeout_s, 30);
  EXPECT_TRUE(approach.command->needs_controller);
  EXPECT_EQ(parse({"conformance", "--allow-motion-on-real-robot"}).command->args,
            words({"--allow-motion-on-real-robot"}));
}

TEST(Commands, UsageErrors) {
  for (auto w : {words({"frobnicate"}), words({"measure"}), words({"measure", "door"}),
                 words({"measure", "width", "1", "2", "3"}), words({"ping", "-n", "0"}),
                 words({"status", "now"}), words({"reset", "--all"}), words({"align", "--later"}),
                 words({"simulate"}), words({"sleep"}), words({"model", "x"}),
                 words({"drive", "--linear", "0.1"}), words({"drive", "--for", "1"}),
                 words({"drive", "--linear", "nan", "--for", "1"}),
                 words({"drive", "--linear", "0.1", "--for", "0"}), words({"approach"}),
                 words({"approach", "near"}), words({"approach", "0.75", "--soon"})}) {
    const auto p = parse_command(w, core::Frame::kCamera);
    EXPECT_FALSE(p.command) << w[0];
    EXPECT_FALSE(p.error.empty());
  }
}

// Durations become std::chrono deadlines (now + ms, in ns): an absurd value would overflow the
// clock (undefined behaviour), so the parser refuses it as a usage error. A rate is sent as f32.
TEST(Commands, DurationsAndRatesAreBounded) {
  for (auto w :
       {words({"watch", "--duration", "1e12"}), words({"watch", "--rate", "1e300"}),
        words({"sleep", "1e300"}), words({"ping", "-i", "1e15"}),
        words({"align", "--wait-timeout", "1e13"}), words({"engage", "--wait-timeout", "1e300"})}) {
    const auto p = parse_command(w, core::Frame::kCamera);
    EXPECT_FALSE(p.command) << w[0] << " " << w.back();
    EXPECT_FALSE(p.error.empty());
  }
  // A day of watching, a long wait and a fast rate stay allowed.
  EXPECT_TRUE(parse({"watch", "--duration", "86400", "--rate", "1000"}).command);
  EXPECT_TRUE(parse({"align", "--wait-timeout", "3600"}).command);
  EXPECT_TRUE(parse({"sleep", "600"}).command);
}

// Every option takes its value as the next word or after '='; given twice, the last one counts.
TEST(GlobalOptions, ValueAfterEqualsAndTheLastOneCounts) {
  const auto args = words({"--connect=robot:1", "--timeout=1.5", "--connect", "other:2",
                           "--retries", "2", "--retries=4", "ping", "-n", "2", "-n", "3"});
  const ParsedArgs p = parse_global_options(args);
  ASSERT_TRUE(p.error.empty()) << p.error;
  EXPECT_EQ(p.options.endpoint.host, "other");
  EXPECT_EQ(p.options.endpoint.port, 2);
  EXPECT_DOUBLE_EQ(p.options.timeout_s, 1.5);
  EXPECT_EQ(p.options.retries, 4);
  const auto ping = parse_command(p.command, p.options.frame);
  ASSERT_TRUE(ping.command) << ping.error;
  EXPECT_EQ(ping.command->count, 3);
}

// A usage error names the option and the value that was wrong.
TEST(GlobalOptions, EachMistakeNamesTheOptionAndItsValue) {
  const std::pair<std::vector<std::string>, std::vector<std::string>> cases[] = {
      {words({"--frame", "world", "status"}), {"--frame", "camera or base", "'world'"}},
      {words({"--connect", "nohostport"}), {"--connect", "HOST:PORT", "'nohostport'"}},
      {words({"--connect", "robot:0"}), {"--connect", "'robot:0'"}},
      {words({"--connect"}), {"--connect"}},
      {words({"--timeout", "0"}), {"--timeout", "(0, 3600]", "'0'"}},
      {words({"--timeout", "3601"}), {"--timeout", "'3601'"}},
      {words({"--timeout", "x"}), {"--timeout", "'x'"}},
      {words({"--retries", "-1"}), {"--retries", "0..100", "'-1'"}},
      {words({"--retries", "101"}), {"--retries", "'101'"}},
      {words({"--retries", "1.5"}), {"--retries", "'1.5'"}},
      {words({"--ca", ""}), {"--ca", "a value"}},
      {words({"--bogus", "status"}), {"unknown option '--bogus'"}},
      {words({"--json", "--tiemout=3", "status"}), {"unknown option '--tiemout=3'", "'--timeout'"}},
      {words({"--client-config", "/nonexistent/ajarctl.yaml"}), {"/nonexistent/ajarctl.yaml"}},
  };
  for (const auto& [args, wanted] : cases) {
    const ParsedArgs p = parse_global_options(args);
    for (const auto& w : wanted) {
      EXPECT_NE(p.error.find(w), std::string::npos) << args[0] << ": '" << p.error << "'";
    }
  }
}

// --client-config and the options it sets apply in command-line order.
TEST(GlobalOptions, ClientConfigAndOptionsInCommandLineOrder) {
  const std::string path = ::testing::TempDir() + "ajarctl_client_config_test.yaml";
  {
    std::ofstream f(path);
    f << "connect: robot.site:7451\ntls:\n  ca: ca.crt\n";
  }
  const auto later = parse_global_options(words(
      {"--client-config", path.c_str(), "--connect", "other:2", "--ca", "/etc/ca.crt", "status"}));
  ASSERT_TRUE(later.error.empty()) << later.error;
  EXPECT_EQ(later.options.endpoint.host, "other");
  EXPECT_EQ(later.options.tls.ca, "/etc/ca.crt");
  const auto earlier = parse_global_options(
      words({"--connect", "other:2", "--client-config", path.c_str(), "status"}));
  ASSERT_TRUE(earlier.error.empty()) << earlier.error;
  EXPECT_EQ(earlier.options.endpoint.host, "robot.site");
  EXPECT_EQ(earlier.options.endpoint.port, 7451);
  EXPECT_EQ(earlier.options.tls.ca,
            (std::filesystem::path(path).parent_path() / "ca.crt").string());
  std::filesystem::remove(path);
}

TEST(Commands, EachMistakeNamesTheCommandTheOptionAndItsValue) {
  const std::pair<std::vector<std::string>, std::vector<std::string>> cases[] = {
      {words({"ping", "-n", "0"}), {"ping: ", "-n", "1..1000000", "'0'", "usage: ping"}},
      {words({"ping", "-n", "010x"}), {"-n", "'010x'"}},
      {words({"ping", "-n"}), {"ping: ", "-n"}},
      {words({"ping", "-i", "1e15"}), {"-i", "'1e15'"}},
      {words({"ping", "-x", "1"}), {"ping: ", "-x"}},
      {words({"watch", "--rate", "-1"}), {"watch: ", "--rate", "'-1'"}},
      {words({"watch", "--duration", "1e12"}), {"--duration", "'1e12'"}},
      {words({"align", "--wait-timeout", "0"}), {"align: ", "--wait-timeout", "'0'"}},
      {words({"align", "--later"}), {"align: ", "--later"}},
      {words({"engage", "now"}), {"engage: ", "now"}},
      {words({"drive", "--linear", "nan", "--for", "1"}), {"drive: ", "--linear", "'nan'"}},
      {words({"drive", "--for", "0", "--linear", "1"}), {"--for", "'0'"}},
      {words({"drive", "--linear", "0.1"}), {"--for"}},
      {words({"reset", "--all"}), {"reset: ", "--all"}},
      {words({"status", "now"}), {"status: ", "now"}},
      {words({"stop", "--now"}), {"stop: ", "--now"}},
      {words({"measure", "width", "1", "2", "3", "4", "5", "x"}), {"measure width", "'x'"}},
      {words({"contact", "1", "2", "3", "--frame", "world"}), {"contact: ", "--frame", "'world'"}},
      {words({"approach", "0.5", "--soon"}), {"approach: ", "--soon"}},
      {words({"sleep", "-1"}), {"sleep wants SECONDS"}},
  };
  for (const auto& [args, wanted] : cases) {
    const auto p = parse_command(args, core::Frame::kCamera);
    EXPECT_FALSE(p.command) << args[0];
    for (const auto& w : wanted) {
      EXPECT_NE(p.error.find(w), std::string::npos) << args[0] << ": '" << p.error << "'";
    }
  }
}

TEST(Commands, NegativeNumbersAreValuesNotOptions) {
  const auto contact = parse({"contact", "-0.5", "-1", "-2e-1", "--frame", "base"});
  ASSERT_TRUE(contact.command) << contact.error;
  const auto& point = std::get<protocol::SetContactPoint>(contact.command->request).contact;
  EXPECT_EQ(point.position_m, core::Vec3(-0.5, -1, -0.2));
  EXPECT_EQ(point.frame, core::Frame::kBase);
  const auto drive = parse({"drive", "--angular", "-0.3", "--linear=-0.1", "--for", "2"});
  ASSERT_TRUE(drive.command) << drive.error;
  EXPECT_EQ(drive.command->angular_rad_s, -0.3);
  EXPECT_EQ(drive.command->linear_m_s, -0.1);
  const auto zero = parse({"drive", "--linear", "0", "--for", "1"});
  ASSERT_TRUE(zero.command) << "a zero velocity is still a velocity: " << zero.error;
}

TEST(Commands, TheFrameOfOneCommandIsItsOwn) {
  const auto p = parse({"measure", "--frame", "base", "width", "1", "0", "0", "1", "0.5", "0"});
  ASSERT_TRUE(p.command) << p.error;
  EXPECT_EQ(std::get<protocol::MeasureDoorWidth>(p.command->request).p1_hinge.frame,
            core::Frame::kBase);
  EXPECT_FALSE(parse({"status", "--frame", "base"}).command) << "no points: no --frame";
}

TEST(Script, SplitsWordsAndDropsComments) {
  EXPECT_EQ(split_line("  measure width 1 2 3  4 5 6 # P1 then P2"),
            words({"measure", "width", "1", "2", "3", "4", "5", "6"}));
  EXPECT_TRUE(split_line("   # only a comment").empty());
  EXPECT_TRUE(split_line("").empty());
}

TEST(Run, HelpVersionAndUsageExitCodes) {
  std::istringstream in;
  std::ostringstream out, err;
  EXPECT_EQ(run_ajarctl(words({"--help"}), in, out, err), kExitOk);
  EXPECT_NE(out.str().find("exit codes"), std::string::npos);
  EXPECT_NE(out.str().find("measure width|handle|plane"), std::string::npos);
  EXPECT_EQ(run_ajarctl(words({"--version"}), in, out, err), kExitOk);
  EXPECT_EQ(run_ajarctl(words({}), in, out, err), kExitUsage);
  EXPECT_EQ(run_ajarctl(words({"measure", "width"}), in, out, err), kExitUsage);
  EXPECT_EQ(run_ajarctl(words({"--frame", "x", "status"}), in, out, err), kExitUsage);
  EXPECT_EQ(run_ajarctl(words({"simulate", "/nonexistent/scenario.yaml"}), in, out, err),
            kExitUsage);
}

}  // namespace
}  // namespace ajar::client
