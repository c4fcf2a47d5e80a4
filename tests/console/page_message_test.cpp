// The page's WebSocket messages: flat JSON objects, parsed without throwing.
#include "ajar/console/page_message.hpp"

#include <gtest/gtest.h>

namespace ajar::console {
namespace {

TEST(PageMessage, ParsesAFlatObject) {
  std::string error;
  const auto m = PageMessage::parse(
      R"( {"op":"pick", "u": 312.5, "v":-2e1, "on":true, "x":null, "s":"a\"b\u0041"} )", error);
  ASSERT_TRUE(m.has_value()) << error;
  EXPECT_EQ(m->op(), "pick");
  EXPECT_DOUBLE_EQ(*m->number("u"), 312.5);
  EXPECT_DOUBLE_EQ(*m->number("v"), -20.0);
  EXPECT_TRUE(*m->flag("on"));
  EXPECT_FALSE(m->number("x").has_value());
  EXPECT_FALSE(m->number("op").has_value());  // a string is not a number
  EXPECT_EQ(*m->text("s"), "a\"bA");
  EXPECT_EQ(*PageMessage::parse(R"({"s":"\u00e9"})", error)->text("s"), "\xc3\xa9") << "UTF-8";
  EXPECT_TRUE(PageMessage::parse("{}", error).has_value());
}

TEST(PageMessage, RefusesWhatItDoesNotSpeakNamingThePosition) {
  std::string error;
  for (const char* bad : {"", "[]", R"({"op":)", R"({"op":"x" "u":1})", R"({"a":{"b":1}})",
                          R"({"a":[1]})", R"({"a":1e})", R"({"a":1} x)", R"({"a":"\q"})",
                          "{\"a\":\"\x01\"}", R"({"a":"unterminated)"}) {
    EXPECT_FALSE(PageMessage::parse(bad, error).has_value()) << bad;
    EXPECT_NE(error.find("PAGE_MESSAGE"), std::string::npos) << bad;
  }
  PageMessage::parse(R"({"op":"pick","u":tru})", error);
  EXPECT_NE(error.find("at byte 20"), std::string::npos) << error;  // "tru" ends at the '}'
  PageMessage::parse(R"({"op":"pick","where":{"u":1}})", error);
  EXPECT_NE(error.find("\"where\": nested"), std::string::npos) << error;
  EXPECT_FALSE(PageMessage::parse(std::string(5000, ' '), error).has_value());
}

TEST(PageMessage, InfinityIsNotANumber) {
  std::string error;
  EXPECT_FALSE(PageMessage::parse(R"({"u":1e999})", error).has_value());
  EXPECT_NE(error.find("PAGE_MESSAGE: number overflow"), std::string::npos) << error;
}

}  // namespace
}  // namespace ajar::console
