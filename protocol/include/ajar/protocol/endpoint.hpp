// Where a daemon listens or a client connects: "HOST:PORT" (HOST a name or an IPv4 address) or
// "[IPv6]:PORT". The one parser of ajard --listen, ajarctl --connect (and its client config) and
// the console's --connect / --listen.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace ajar::protocol {

struct HostPort {
  std::string host;  // without the IPv6 brackets
  std::uint16_t port = 0;
};

// Port 0 means "any free port": a listener may take it, a client may not.
enum class PortZero { kRefused, kAllowed };

// Nothing when `text` is not HOST:PORT: no colon, an empty host or port, an IPv6 address without
// brackets, anything after the closing bracket but ":PORT", a port that is not 0..65535 in
// decimal digits (or 0 when refused).
std::optional<HostPort> parse_host_port(std::string_view text, PortZero port_zero);

}  // namespace ajar::protocol
