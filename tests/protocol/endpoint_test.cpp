// The one HOST:PORT parser (ajard --listen, ajarctl --connect, the console): what it takes and
// every kind of bad input it refuses.
#include <gtest/gtest.h>

#include "ajar/protocol/endpoint.hpp"

namespace ajar::protocol {
namespace {

TEST(HostPort, NamesIpv4AndBracketedIpv6) {
  auto e = parse_host_port("robot.local:7450", PortZero::kRefused);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->host, "robot.local");
  EXPECT_EQ(e->port, 7450);
  e = parse_host_port("10.0.0.2:65535", PortZero::kRefused);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->host, "10.0.0.2");
  EXPECT_EQ(e->port, 65535);
  e = parse_host_port("[::1]:9", PortZero::kRefused);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->host, "::1");
  EXPECT_EQ(e->port, 9);
  e = parse_host_port("[fe80::1%eth0]:7450", PortZero::kRefused);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->host, "fe80::1%eth0");
}

TEST(HostPort, PortZeroOnlyWhereAllowed) {
  EXPECT_FALSE(parse_host_port("127.0.0.1:0", PortZero::kRefused));
  const auto any = parse_host_port("0.0.0.0:0", PortZero::kAllowed);
  ASSERT_TRUE(any);
  EXPECT_EQ(any->host, "0.0.0.0");
  EXPECT_EQ(any->port, 0);
  EXPECT_EQ(parse_host_port("[::]:0", PortZero::kAllowed)->host, "::");
}

TEST(HostPort, BadInputsAreRefused) {
  for (const PortZero zero : {PortZero::kRefused, PortZero::kAllowed}) {
    for (const char* bad : {"",
                            ":",
                            "host",
                            "host:",
                            ":7450",
                            "host:65536",
                            "host:99999999999",
                            "host:12x",
                            "host:-1",
                            "host:+1",
                            "host: 1",
                            "host:0x10",
                            "::1:5",
                            "::1",
                            "[::1]",
                            "[::1]:",
                            "[::1]5",
                            "[::1]x:5",
                            "[]:5",
                            "[::1:5",
                            "a:b:5"}) {
      EXPECT_FALSE(parse_host_port(bad, zero)) << "'" << bad << "'";
    }
  }
}

}  // namespace
}  // namespace ajar::protocol
