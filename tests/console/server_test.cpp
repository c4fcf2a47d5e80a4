// The console server without a daemon (nothing listens on the daemon port): HTTP files and their
// guards, the WebSocket's Origin check, frames, hover/pick replies, bad page messages, and the
// deadman gating (the heartbeat is on only while a page is connected and alive).
#include "ajar/console/server.hpp"

// <utility> before any Asio header (asio issue 944).
#include <utility>

#include <gtest/gtest.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "ajar/console/frame.hpp"
#include "wall_source.hpp"

namespace ajar::console {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

struct Fixture : ::testing::Test {
  std::filesystem::path web;
  std::unique_ptr<ConsoleServer> server;
  std::thread runner;
  std::uint16_t port = 0;

  void SetUp() override {
    web =
        std::filesystem::temp_directory_path() / ("ajar-console-web-" + std::to_string(::getpid()));
    std::filesystem::create_directories(web);
    std::ofstream(web / "index.html") << "<html>console</html>";
    ConsoleOptions o;
    o.daemon = {"127.0.0.1", 1};  // nothing listens there: the console keeps retrying
    o.listen_port = 0;
    o.web_dir = web.string();
    // A flat wall 2 m away; the left half has no depth.
    server = std::make_unique<ConsoleServer>(
        o, std::make_unique<testing::WallSource>(64, 48, 57.0, 30.0, true), nullptr);
    port = server->listen();
    runner = std::thread([this] { server->run(); });
  }
  void TearDown() override {
    server->stop();
    runner.join();
    server.reset();
    std::filesystem::remove_all(web);
  }

  http::response<http::string_body> get(const std::string& target, const std::string& host = "") {
    asio::io_context ioc;
    tcp::socket s(ioc);
    s.connect({asio::ip::make_address("127.0.0.1"), port});
    http::request<http::string_body> req{http::verb::get, target, 11};
    req.set(http::field::host, host.empty() ? "127.0.0.1:" + std::to_string(port) : host);
    http::write(s, req);
    beast::flat_buffer b;
    http::response<http::string_body> res;
    http::read(s, b, res);
    return res;
  }

  std::string state_json() { return get("/api/state").body(); }

  bool wait_for(const std::function<bool()>& pred) {
    for (int i = 0; i < 100; ++i) {
      if (pred()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }
};

struct Ws {
  asio::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  explicit Ws(std::uint16_t port, const std::string& origin = "") {
    ws.next_layer().connect({asio::ip::make_address("127.0.0.1"), port});
    if (!origin.empty()) {
      ws.set_option(websocket::stream_base::decorator(
          [origin](websocket::request_type& r) { r.set(http::field::origin, origin); }));
    }
    ws.handshake("127.0.0.1:" + std::to_string(port), "/ws");
  }
  void send(const std::string& text) {
    ws.text(true);
    ws.write(asio::buffer(text));
  }
  // Reads until a text message containing `needle` (skipping frames and other messages).
  std::string read_until(const std::string& needle) {
    for (int i = 0; i < 200; ++i) {
      beast::flat_buffer b;
      ws.read(b);
      if (!ws.got_text()) continue;
      auto s = beast::buffers_to_string(b.data());
      if (s.find(needle) != std::string::npos) return s;
    }
    return {};
  }
  bool read_binary_frame() {
    for (int i = 0; i < 200; ++i) {
      beast::flat_buffer b;
      ws.read(b);
      if (!ws.got_text()) {
        const auto s = beast::buffers_to_string(b.data());
        return s.size() > 13 && s[0] == 1 && s.substr(5, 4) == "\x89PNG";
      }
    }
    return false;
  }
};

TEST_F(Fixture, ServesItsPageOnlyToItsOwnHostAndOnlyItsFiles) {
  auto r = get("/");
  EXPECT_EQ(r.result(), http::status::ok);
  EXPECT_EQ(r.body(), "<html>console</html>");
  EXPECT_EQ(get("/", "evil.example:80").result(), http::status::forbidden);  // DNS rebinding
  EXPECT_EQ(get("/../etc/passwd").result(), http::status::not_found);
  EXPECT_EQ(get("/.hidden").result(), http::status::not_found);
  EXPECT_EQ(get("/api/sim/landmarks").result(), http::status::not_found);  // not simulated
  EXPECT_NE(state_json().find("\"connected\":false"), std::string::npos);
}

// The page disables an observer's buttons for the ops whose request the message table says needs
// the controller (protocol/message_table.hpp); a stop never does.
TEST_F(Fixture, TellsThePageWhichOpsNeedTheControllerFromTheMessageTable) {
  const std::string state = state_json();
  for (const char* op : {"send", "align", "engage", "reset", "drive", "approach"}) {
    EXPECT_NE(state.find("\"" + std::string(op) + "\":true"), std::string::npos) << op << state;
  }
  for (const char* op : {"stop", "estop", "save_recording"}) {
    EXPECT_NE(state.find("\"" + std::string(op) + "\":false"), std::string::npos) << op << state;
  }
  EXPECT_NE(state.find("\"controller_only\":{\"send\":true"), std::string::npos) << state;
}

TEST_F(Fixture, RefusesAWebSocketFromAnotherSite) {
  EXPECT_THROW(Ws(port, "http://evil.example"), boost::system::system_error);
  Ws ok(port, "http://127.0.0.1:" + std::to_string(port));
  EXPECT_FALSE(ok.read_until("\"type\":\"state\"").empty());
}

TEST_F(Fixture, SendsFramesAndAnswersHoverAndPicks) {
  Ws ws(port);
  EXPECT_TRUE(ws.read_binary_frame());
  // Right half: the wall at 2 m. Pixel (47.5, 23.5) is 16 px right of the centre: x = 16 * 2 / 57.
  ws.send(R"({"op":"hover","u":47.5,"v":23.5})");
  const auto hover = ws.read_until("\"hover\"");
  EXPECT_NE(hover.find("\"ok\":true"), std::string::npos) << hover;
  EXPECT_NE(hover.find("\"camera_m\":[0.561403508771929"), std::string::npos) << hover;
  // Left half: a hole with no valid neighbours is refused, naming the problem.
  ws.send(R"({"op":"pick","u":5,"v":5})");
  const auto refused = ws.read_until("pick_refused");
  EXPECT_NE(refused.find("\"field\":\"depth\""), std::string::npos) << refused;
  EXPECT_NE(refused.find("pick a measurable area"), std::string::npos) << refused;
  // A pick with depth, but no telemetry from ajard: where the base was is unknown, so the pick
  // could never be checked against a later motion (issue 23): refused, nothing picked.
  ws.send(R"({"op":"pick","u":40,"v":20})");
  const auto no_pose = ws.read_until("pick_refused");
  EXPECT_NE(no_pose.find("where the base was is unknown"), std::string::npos) << no_pose;
  EXPECT_NE(state_json().find("\"width\":[]"), std::string::npos);
  // Send with no pick: the page is told what is missing; nothing goes to the robot.
  ws.send(R"({"op":"send"})");
  EXPECT_NE(ws.read_until("notice").find("P2"), std::string::npos);
}

TEST_F(Fixture, BadPageMessagesGetANoticeAndTheSessionContinues) {
  Ws ws(port);
  ws.send("{not json");
  EXPECT_NE(ws.read_until("notice").find("PAGE_MESSAGE"), std::string::npos);
  ws.send(R"({"op":"fly"})");
  EXPECT_NE(ws.read_until("notice").find("unknown op 'fly'"), std::string::npos);
  ws.send(R"({"op":"step","step":"nowhere"})");
  EXPECT_NE(ws.read_until("notice").find("unknown step"), std::string::npos);
  ws.send(R"({"op":"hover","u":47.5,"v":23.5})");
  EXPECT_FALSE(ws.read_until("\"hover\"").empty());
}

TEST_F(Fixture, TheDeadmanIsFedOnlyWhileAPageIsConnectedAndAlive) {
  const auto heartbeat = [&] {
    return state_json().find("\"heartbeat\":true") != std::string::npos;
  };
  EXPECT_FALSE(heartbeat());
  {
    Ws ws(port);
    EXPECT_FALSE(heartbeat());  // connected but silent: not fed
    ws.send(R"({"op":"alive"})");
    EXPECT_TRUE(wait_for(heartbeat));
    // A page that stops saying alive (hung) stops feeding it within the timeout.
    EXPECT_TRUE(wait_for([&] { return !heartbeat(); }));
    ws.send(R"({"op":"alive"})");
    EXPECT_TRUE(wait_for(heartbeat));
  }  // the WebSocket closes: stopped at once
  EXPECT_TRUE(wait_for([&] { return !heartbeat(); }));
}

}  // namespace
}  // namespace ajar::console
