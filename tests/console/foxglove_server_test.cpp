// The Foxglove WebSocket server (ajar/console/foxglove_server.hpp) on its own, with a Beast client:
// serverInfo then advertise on connect; messageData's layout (opcode 0x01, uint32 subscription id
// and uint64 log time, little-endian, then the payload) and order; a latched channel's last
// message to a new subscriber; unsubscribe; refusals (no subprotocol, off loopback); and the
// bounds: a client that never reads has its oldest messages dropped and is disconnected, counted,
// while publish() keeps returning and another client keeps receiving; connections that never
// finish their upgrade (nothing sent, half a request) hold at most max_clients places and only
// until upgrade_timeout, then a real client gets in; a client beyond max_clients gets HTTP 503.
#include "ajar/console/foxglove_server.hpp"
#include "eventually.hpp"

// <utility> before any Asio header (asio issue 944).
#include <utility>

#include <gtest/gtest.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <boost/asio/write.hpp>
#include <chrono>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

namespace ajar::console::foxglove {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using ajar::test::eventually;
using tcp = asio::ip::tcp;
using Json = nlohmann::json;

std::vector<Channel> channels() {
  Channel a;
  a.id = 1;
  a.topic = "/a";
  a.schema_name = "test.A";
  a.schema = R"({"type":"object"})";
  Channel b = a;
  b.id = 2;
  b.topic = "/latched";
  b.latched = true;
  return {a, b};
}

struct Client {
  asio::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  explicit Client(std::uint16_t port, const char* subprotocol = kSubprotocol) {
    tcp::resolver resolver(ioc);
    asio::connect(ws.next_layer(), resolver.resolve("127.0.0.1", std::to_string(port)));
    ws.set_option(websocket::stream_base::decorator([subprotocol](websocket::request_type& req) {
      if (subprotocol != nullptr) req.set(http::field::sec_websocket_protocol, subprotocol);
    }));
    websocket::response_type res;
    ws.handshake(res, "127.0.0.1:" + std::to_string(port), "/");
    EXPECT_EQ(res[http::field::sec_websocket_protocol], kSubprotocol);
  }
  Json text() {
    beast::flat_buffer b;
    ws.read(b);
    EXPECT_TRUE(ws.got_text());
    return Json::parse(beast::buffers_to_string(b.data()));
  }
  std::string binary() {
    beast::flat_buffer b;
    ws.read(b);
    EXPECT_TRUE(ws.got_binary());
    return beast::buffers_to_string(b.data());
  }
  void send(const Json& j) {
    ws.text(true);
    ws.write(asio::buffer(j.dump()));
  }
};

std::uint64_t little_endian(const std::string& s, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i)
    v = (v << 8) | static_cast<std::uint8_t>(s[at + static_cast<std::size_t>(i)]);
  return v;
}

TEST(FoxgloveServer, RefusesAnAddressOffLoopback) {
  ServerOptions o;
  o.host = "0.0.0.0";
  o.port = 0;
  Server s(o, channels());
  try {
    s.listen();
    FAIL() << "listened on 0.0.0.0";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--foxglove 0.0.0.0:0: not a loopback address"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(is_loopback_address("127.0.0.1"));
  EXPECT_TRUE(is_loopback_address("::1"));
  EXPECT_FALSE(is_loopback_address("192.168.1.5"));
  EXPECT_FALSE(is_loopback_address("localhost"));  // a name is not an address
}

TEST(FoxgloveServer, ServerInfoAdvertiseMessageDataLatchedUnsubscribe) {
  ServerOptions o;
  o.port = 0;
  Server server(o, channels());
  const auto port = server.listen();
  server.start();
  server.publish(2, 42, [] { return std::string(R"({"latched":1})"); });  // nobody subscribes yet

  Client c(port);
  const Json info = c.text();
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_EQ(info["capabilities"], Json::array());
  const Json adv = c.text();
  ASSERT_EQ(adv["op"], "advertise");
  ASSERT_EQ(adv["channels"].size(), 2U);
  EXPECT_EQ(adv["channels"][0]["id"], 1);
  EXPECT_EQ(adv["channels"][0]["topic"], "/a");
  EXPECT_EQ(adv["channels"][0]["encoding"], "json");
  EXPECT_EQ(adv["channels"][0]["schemaName"], "test.A");
  EXPECT_EQ(adv["channels"][0]["schemaEncoding"], "jsonschema");
  EXPECT_EQ(adv["channels"][0]["schema"], R"({"type":"object"})");

  EXPECT_FALSE(server.subscribed(1));
  c.send(
      {{"op", "subscribe"},
       {"subscriptions", {{{"id", 0x01020304}, {"channelId", 1}}, {{"id", 7}, {"channelId", 2}}}}});
  // The latched channel's last message at once.
  const std::string latched = c.binary();
  ASSERT_EQ(latched.size(), 13U + 13U);
  EXPECT_EQ(static_cast<std::uint8_t>(latched[0]), 0x01);
  EXPECT_EQ(little_endian(latched, 1, 4), 7U);
  EXPECT_EQ(little_endian(latched, 5, 8), 42U);
  EXPECT_EQ(latched.substr(13), R"({"latched":1})");

  ASSERT_TRUE(eventually([&] { return server.subscribed(1); }));
  const std::uint64_t t = 0x1122334455667788ULL;
  for (int i = 0; i < 3; ++i)
    server.publish(1, t + static_cast<std::uint64_t>(i), [i] { return std::to_string(i); });
  for (int i = 0; i < 3; ++i) {
    const std::string m = c.binary();
    ASSERT_EQ(m.size(), 14U);
    EXPECT_EQ(static_cast<std::uint8_t>(m[0]), 0x01);
    EXPECT_EQ(m.substr(1, 4), std::string("\x04\x03\x02\x01", 4));  // little-endian
    EXPECT_EQ(little_endian(m, 5, 8), t + static_cast<std::uint64_t>(i));
    EXPECT_EQ(m.substr(13), std::to_string(i));  // in order
  }

  // Errors are status messages; the subscription id in use is refused.
  c.send({{"op", "subscribe"}, {"subscriptions", {{{"id", 7}, {"channelId", 1}}}}});
  EXPECT_NE(c.text()["message"].get<std::string>().find("subscription id 7 is in use"),
            std::string::npos);
  c.send({{"op", "setParameters"}, {"parameters", Json::array()}});
  const Json st = c.text();
  EXPECT_EQ(st["op"], "status");
  EXPECT_EQ(st["level"], 1);

  c.send({{"op", "unsubscribe"}, {"subscriptionIds", {0x01020304}}});
  ASSERT_TRUE(eventually([&] { return !server.subscribed(1); }));
  server.publish(1, t, [] { return std::string("after"); });
  server.publish(2, 43, [] { return std::string("latched again"); });
  const std::string next = c.binary();  // the latched one: nothing came on the unsubscribed one
  EXPECT_EQ(little_endian(next, 1, 4), 7U);
  EXPECT_EQ(next.substr(13), "latched again");
  server.stop();
}

TEST(FoxgloveServer, RefusesAClientWithoutTheSubprotocol) {
  ServerOptions o;
  o.port = 0;
  Server server(o, channels());
  const auto port = server.listen();
  server.start();
  EXPECT_THROW(Client(port, nullptr), beast::system_error);
  EXPECT_TRUE(eventually([&] { return server.stats().clients_refused == 1; }));
  server.stop();
}

// A client that never reads: its queue drops the oldest, then it is disconnected; publish() keeps
// returning and a reading client gets every message published after the stall.
TEST(FoxgloveServer, AStalledClientIsDroppedFromThenDisconnectedOthersGoOn) {
  ServerOptions o;
  o.port = 0;
  o.max_queued_messages = 8;
  o.max_queued_bytes = 1U << 20;
  o.stalled_write_timeout = std::chrono::milliseconds(300);
  Server server(o, channels());
  const auto port = server.listen();
  server.start();
  Client stalled(port);
  stalled.text();
  stalled.text();
  stalled.send({{"op", "subscribe"}, {"subscriptions", {{{"id", 1}, {"channelId", 1}}}}});
  ASSERT_TRUE(eventually([&] { return server.subscribed(1); }));
  // 64 KiB messages, as a camera would send them, until the kernel's socket buffers and then the
  // queue overflow and the write stalls. The server's watchdog looks once a second, so the loop is
  // bounded by time, not by a count (a count ran out before the watchdog's turn on a loaded CI
  // machine under ASan); memory stays bounded by the queue (8 messages).
  const std::string big(64 * 1024, 'x');
  int published = 0;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  for (;
       std::chrono::steady_clock::now() < give_up && server.stats().clients_disconnected_slow == 0;
       ++published) {
    server.publish(1, 1, [&big] { return big; });
    if (published % 32 == 31) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const auto s = server.stats();
  EXPECT_GT(s.messages_dropped, 0U) << "published " << published;
  EXPECT_EQ(s.clients_disconnected_slow, 1U) << "published " << published;
  EXPECT_TRUE(eventually([&] { return server.stats().clients == 0; }));

  Client reader(port);
  reader.text();
  reader.text();
  reader.send({{"op", "subscribe"}, {"subscriptions", {{{"id", 5}, {"channelId", 1}}}}});
  ASSERT_TRUE(eventually([&] { return server.subscribed(1); }));
  for (int i = 0; i < 5; ++i)
    server.publish(1, 2, [i] { return "m" + std::to_string(i); });
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(reader.binary().substr(13), "m" + std::to_string(i));
  server.stop();
}

// A TCP connection to the server that sends `bytes` and then nothing.
struct Idle {
  asio::io_context ioc;
  tcp::socket socket{ioc};
  bool closed = false;  // the server closed it (a read ended: EOF or a reset)
  std::string answer;   // what the server sent before (a 503)
  Idle(std::uint16_t port, const std::string& bytes) {
    socket.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    if (!bytes.empty()) asio::write(socket, asio::buffer(bytes));
    socket.non_blocking(true);
  }
  void poll() {
    std::array<char, 512> buf{};
    for (;;) {
      if (closed) return;
      boost::system::error_code ec;
      const std::size_t n = socket.read_some(asio::buffer(buf), ec);
      if (ec == asio::error::would_block) return;
      if (ec) closed = true;
      answer.append(buf.data(), n);
    }
  }
};
using Idles = std::vector<std::unique_ptr<Idle>>;

// 20 connections: ten send nothing, ten half a request.
Idles idle_connections(std::uint16_t port) {
  const std::string half = "GET / HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) + "\r\n";
  Idles idle;
  for (int i = 0; i < 20; ++i)
    idle.push_back(std::make_unique<Idle>(port, i % 2 == 0 ? "" : half));
  return idle;
}
// Polls them until `n` are closed by the server (a generous bound); how many are.
std::size_t until_closed(Idles& idle, std::size_t n) {
  std::size_t closed = 0;
  eventually([&] {
    closed = 0;
    for (auto& c : idle) {
      c->poll();
      closed += c->closed ? 1U : 0U;
    }
    return closed >= n;
  });
  return closed;
}

// 20 connections that never upgrade against 8 places: 8 wait in their upgrade, 12 are refused at
// once (a 503, or closed unanswered beyond 8 refusals in flight); while the 8 wait a real client
// is refused too; closed from the client side, their places come back and a real client gets in.
TEST(FoxgloveServer, ConnectionsThatNeverUpgradeHoldAtMostMaxClientsPlaces) {
  ServerOptions o;
  o.port = 0;
  o.upgrade_timeout = std::chrono::hours(1);  // only the clients end them here
  Server server(o, channels());
  const auto port = server.listen();
  server.start();
  Idles idle = idle_connections(port);
  ASSERT_TRUE(eventually([&] {
    const auto s = server.stats();
    return s.upgrades == 8 && s.clients_refused == 12;
  })) << server.stats().upgrades
      << " upgrading, " << server.stats().clients_refused << " refused";
  EXPECT_EQ(until_closed(idle, 12), 12U) << "the 8 in their upgrade stay open";
  std::size_t got_503 = 0;
  for (std::size_t i = 0; i < idle.size(); ++i) {
    EXPECT_EQ(idle[i]->closed, i >= 8) << "connection " << i;
    got_503 += idle[i]->answer.starts_with("HTTP/1.1 503 ") ? 1U : 0U;
  }
  EXPECT_GE(got_503, 8U) << "refused with a 503 (up to 8 refusals at once), not a silent reset";
  EXPECT_THROW(Client real(port), beast::system_error) << "a real client while 8 upgrades wait";
  EXPECT_EQ(server.stats().clients, 0U);
  EXPECT_EQ(server.stats().upgrades, 8U);
  idle.clear();  // the client side closes them: their places come back
  ASSERT_TRUE(eventually([&] { return server.stats().upgrades == 0; }));
  Client real(port);
  EXPECT_EQ(real.text()["op"], "serverInfo");
  EXPECT_TRUE(eventually([&] { return server.stats().clients == 1; }));
  EXPECT_EQ(server.stats().upgrades_timed_out, 0U);
  server.stop();
}

// The same connections against a short upgrade deadline: the server closes them itself (counted),
// then a real client gets in; eight real clients fill the places and a ninth is refused with 503
// until one of them leaves.
TEST(FoxgloveServer, AnUpgradeNotDoneInTimeIsClosedAndTheRealClientsGetIn) {
  ServerOptions o;
  o.port = 0;
  o.upgrade_timeout = std::chrono::milliseconds(200);
  Server server(o, channels());
  const auto port = server.listen();
  server.start();
  Idles idle = idle_connections(port);
  EXPECT_EQ(until_closed(idle, 20), 20U) << "an upgrade that never ends is closed by the server";
  ASSERT_TRUE(eventually([&] { return server.stats().upgrades == 0; }));
  const auto s = server.stats();
  EXPECT_EQ(s.upgrades_timed_out + s.clients_refused, 20U)
      << s.upgrades_timed_out << " timed out, " << s.clients_refused << " refused";
  EXPECT_GE(s.upgrades_timed_out, 1U);

  std::vector<std::unique_ptr<Client>> real;
  for (int i = 0; i < 8; ++i) {
    real.push_back(std::make_unique<Client>(port));
    EXPECT_EQ(real.back()->text()["op"], "serverInfo");
  }
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 8; }));
  {
    asio::io_context ioc;
    websocket::stream<tcp::socket> ninth{ioc};
    ninth.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    ninth.set_option(websocket::stream_base::decorator([](websocket::request_type& req) {
      req.set(http::field::sec_websocket_protocol, kSubprotocol);
    }));
    websocket::response_type res;
    beast::error_code ec;
    ninth.handshake(res, "127.0.0.1:" + std::to_string(port), "/", ec);
    // An HTTP answer that is not the upgrade (the 503: Beast 1.74 does not hand its status over).
    EXPECT_EQ(ec, websocket::error::upgrade_declined) << ec.message() << ": a ninth client got in?";
  }
  real.pop_back();  // one leaves: its place comes back
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 7; }));
  Client ninth(port);
  EXPECT_EQ(ninth.text()["op"], "serverInfo");
  EXPECT_TRUE(eventually([&] { return server.stats().clients == 8; }));
  server.stop();
}

}  // namespace
}  // namespace ajar::console::foxglove
