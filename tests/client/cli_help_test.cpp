// ajarctl is discoverable: `help CMD` and `CMD --help` for every command, a did-you-mean for a
// mistyped command or option, the --help list made from the same table, and the words the bash
// completion offers.
#include <algorithm>
#include <sstream>

#include <gtest/gtest.h>

#include "ajar/client/cli.hpp"

namespace ajar::client {
namespace {

struct Result {
  int code;
  std::string out;
  std::string err;
};

Result ajarctl(std::vector<std::string> args) {
  std::istringstream in;
  std::ostringstream out;
  std::ostringstream err;
  const int code = run_ajarctl(args, in, out, err);
  return {code, out.str(), err.str()};
}

bool contains(const std::vector<std::string>& v, const std::string& w) {
  return std::find(v.begin(), v.end(), w) != v.end();
}

TEST(CommandHelp, EveryCommandHasHelpBothWaysAndIsListed) {
  const auto names = command_names();
  ASSERT_GE(names.size(), 14u);
  const std::string list = usage();
  for (const auto& name : names) {
    const Result a = ajarctl({"help", name});
    const Result b = ajarctl({name, "--help"});
    EXPECT_EQ(a.code, kExitOk) << name << a.err;
    EXPECT_EQ(b.code, kExitOk) << name << b.err;
    EXPECT_EQ(a.out, b.out) << name;
    EXPECT_NE(a.out.find("Usage: ajarctl [OPTIONS] " + name), std::string::npos) << a.out;
    EXPECT_NE(list.find("\n  " + name), std::string::npos) << name << " missing from --help";
  }
  // -h works too, anywhere after the command; `help` alone is --help.
  EXPECT_EQ(ajarctl({"measure", "width", "-h"}).out, ajarctl({"help", "measure"}).out);
  EXPECT_EQ(ajarctl({"help"}).out, usage());
}

TEST(CommandHelp, AMistypedCommandGetsADidYouMean) {
  const Result r = ajarctl({"stauts"});
  EXPECT_EQ(r.code, kExitUsage);
  EXPECT_NE(r.err.find("unknown command 'stauts' (did you mean 'status'?)"), std::string::npos)
      << r.err;
  EXPECT_NE(ajarctl({"algin"}).err.find("did you mean 'align'?"), std::string::npos);
  EXPECT_NE(ajarctl({"conform"}).err.find("did you mean 'conformance'?"), std::string::npos);
  EXPECT_NE(ajarctl({"help", "engag"}).err.find("did you mean 'engage'?"), std::string::npos);
  EXPECT_NE(ajarctl({"--jsno", "status"}).err.find("did you mean '--json'?"), std::string::npos);
  // Nothing close: no guess.
  const Result far = ajarctl({"frobnicate"});
  EXPECT_EQ(far.code, kExitUsage);
  EXPECT_EQ(far.err.find("did you mean"), std::string::npos) << far.err;
}

TEST(Completion, OffersOptionsCommandsAndEachCommandsWords) {
  const auto first = completion_words({});
  EXPECT_TRUE(contains(first, "--connect"));
  EXPECT_TRUE(contains(first, "status"));
  EXPECT_TRUE(contains(first, "conformance"));
  const std::vector<std::string> after_options{"--connect", "robot:7450", "--json"};
  EXPECT_EQ(completion_words(after_options), first);
  // A value is expected: nothing (or the two frames).
  EXPECT_TRUE(completion_words(std::vector<std::string>{"--connect"}).empty());
  EXPECT_EQ(completion_words(std::vector<std::string>{"--frame"}),
            (std::vector<std::string>{"camera", "base"}));
  const auto measure = completion_words(std::vector<std::string>{"measure"});
  EXPECT_TRUE(contains(measure, "width") && contains(measure, "plane"));
  const auto align = completion_words(std::vector<std::string>{"--json", "align"});
  EXPECT_TRUE(contains(align, "--no-wait") && contains(align, "--wait-timeout"));
  EXPECT_EQ(completion_words(std::vector<std::string>{"conformance", "--vectors"}),
            std::vector<std::string>{"@dir"});
  EXPECT_TRUE(contains(completion_words(std::vector<std::string>{"simulate"}), "@file"));
  EXPECT_EQ(completion_words(std::vector<std::string>{"help"}), command_names());
  // Through the command line, as the completion script calls it.
  const Result r = ajarctl({"--complete", "ping"});
  EXPECT_EQ(r.code, kExitOk);
  EXPECT_EQ(r.out, "-n\n-i\n--help\n");
}

}  // namespace
}  // namespace ajar::client
