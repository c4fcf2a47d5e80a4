// ajarctl's argument parsing: global options, every command, and usage errors (exit code 2).
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
