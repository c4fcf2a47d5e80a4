// The short names the console's network code uses for Boost.Asio and Beast (server_impl.hpp and
// foxglove_server.cpp): one list.
#pragma once

// <utility> before any Asio header (asio issue 944).
#include <utility>

#include <boost/asio/ip/tcp.hpp>
#include <boost/system/error_code.hpp>
#include <chrono>

namespace boost::beast::http {}
namespace boost::beast::websocket {}

namespace ajar::console {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using boost::system::error_code;
using Clock = std::chrono::steady_clock;

}  // namespace ajar::console
