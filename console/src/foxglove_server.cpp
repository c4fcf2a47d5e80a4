// The Foxglove WebSocket protocol server (ajar/console/foxglove_server.hpp): its own thread and
// io_context, one coroutine pair (reader, writer) per client, bounded per-client queues. A
// connection's upgrade runs on a beast::tcp_stream whose expiry (a deadline timer) closes it at
// upgrade_timeout; it counts toward max_clients from its accept on.
#include "ajar/console/foxglove_server.hpp"

// <utility> before any Asio header (asio issue 944).
#include <utility>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "net_names.hpp"

namespace ajar::console::foxglove {

using Json = nlohmann::json;

std::uint64_t unix_time_ns() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        std::chrono::system_clock::now().time_since_epoch())
                                        .count());
}

bool is_loopback_address(const std::string& host) {
  error_code ec;
  const auto a = asio::ip::make_address(host, ec);
  return !ec && a.is_loopback();
}

namespace {

struct Data {
  std::uint32_t subscription = 0;
  std::uint64_t log_time_ns = 0;
  std::shared_ptr<const std::string> payload;
};

struct Client {
  explicit Client(beast::tcp_stream stream) : ws(std::move(stream)), wake(ws.get_executor()) {}
  websocket::stream<beast::tcp_stream> ws;
  asio::steady_timer wake;          // cancelled when a queue gets a message
  std::deque<std::string> control;  // serverInfo, advertise, status: never dropped
  std::deque<Data> data;            // messageData waiting; bounded, oldest dropped
  std::size_t data_bytes = 0;
  std::map<std::uint32_t, std::uint32_t> subscriptions;  // subscription id -> channel id
  bool closed = false;
  bool writing = false;
  Clock::time_point write_started{};
};

// "a, b" header lists: whether `wanted` is one of the tokens.
bool lists_token(std::string_view list, std::string_view wanted) {
  while (!list.empty()) {
    const auto comma = list.find(',');
    auto token = list.substr(0, comma);
    while (!token.empty() && token.front() == ' ')
      token.remove_prefix(1);
    while (!token.empty() && token.back() == ' ')
      token.remove_suffix(1);
    if (token == wanted) return true;
    if (comma == std::string_view::npos) break;
    list.remove_prefix(comma + 1);
  }
  return false;
}

// A web page may read this port only when it is Foxglove's own app or a page on this machine;
// clients that are not web pages (Foxglove's desktop app, Node, Python) send no http(s) Origin.
bool origin_allowed(std::string_view origin) {
  if (origin.rfind("http://", 0) != 0 && origin.rfind("https://", 0) != 0) return true;
  const auto host_start = origin.find("://") + 3;
  auto host = origin.substr(host_start);
  if (const auto slash = host.find('/'); slash != std::string_view::npos)
    host = host.substr(0, slash);
  if (host.empty()) return false;
  const auto name =
      host.front() == '[' ? host.substr(0, host.find(']') + 1) : host.substr(0, host.find(':'));
  return name == "app.foxglove.dev" || name == "studio.foxglove.dev" || name == "localhost" ||
         name == "[::1]" || name.rfind("127.", 0) == 0;
}

// A connection counted in `n` while it lives (or until release()): the upgrades in progress and
// the refusals being written. Touches nothing but the counter (declared before the io_context,
// whose destruction may destroy a suspended coroutine holding one).
class Slot {
 public:
  explicit Slot(std::atomic<std::size_t>& n) : n_(&n) { ++n; }
  ~Slot() { release(); }
  Slot(const Slot&) = delete;
  Slot& operator=(const Slot&) = delete;
  void release() {
    if (n_ != nullptr) --*n_;
    n_ = nullptr;
  }

 private:
  std::atomic<std::size_t>* n_;
};

}  // namespace

struct Server::Impl {
  Impl(ServerOptions o, std::vector<Channel> c)
      : options(std::move(o)), channels(std::move(c)), acceptor(ioc), counts(channels.size()) {
    for (std::size_t i = 0; i < channels.size(); ++i)
      index[channels[i].id] = i;
  }

  ServerOptions options;
  std::vector<Channel> channels;
  std::map<std::uint32_t, std::size_t> index;  // channel id -> position
  // Server thread writes, stats() reads; before ioc (Slot).
  std::atomic<std::size_t> upgrades{0};  // connections accepted, not yet clients nor gone
  std::atomic<std::size_t> refusing{0};  // 503s being written
  asio::io_context ioc{1};
  tcp::acceptor acceptor;
  std::uint16_t port = 0;
  std::thread thread;
  std::atomic<bool> stopping{false};
  std::vector<std::atomic<int>> counts;  // subscribers per channel (by position)

  // ---- the server's thread ----
  std::set<std::shared_ptr<Client>> clients;
  std::map<std::uint32_t, Data> latched;  // channel id -> its last message

  mutable std::mutex stats_mutex;
  ServerStats stats;

  void count(const std::function<void(ServerStats&)>& f) {
    const std::lock_guard lock(stats_mutex);
    f(stats);
  }

  std::string server_info() const {
    Json j{{"op", "serverInfo"},
           {"name", options.name},
           {"capabilities", Json::array()},
           {"sessionId", std::to_string(unix_time_ns())}};
    return j.dump();
  }
  std::string advertise() const {
    Json list = Json::array();
    for (const auto& c : channels) {
      list.push_back({{"id", c.id},
                      {"topic", c.topic},
                      {"encoding", c.encoding},
                      {"schemaName", c.schema_name},
                      {"schemaEncoding", c.schema_encoding},
                      {"schema", c.schema}});
    }
    return Json{{"op", "advertise"}, {"channels", list}}.dump();
  }
  static std::string status(int level, const std::string& message) {
    return Json{{"op", "status"}, {"level", level}, {"message", message}}.dump();
  }

  void send_control(const std::shared_ptr<Client>& c, std::string text) {
    if (c->closed) return;
    if (c->control.size() >= 64) {  // a client flooding us with bad requests
      close(c);
      return;
    }
    c->control.push_back(std::move(text));
    c->wake.cancel();
  }
  void send_data(const std::shared_ptr<Client>& c, Data d) {
    if (c->closed) return;
    c->data_bytes += d.payload->size();
    c->data.push_back(std::move(d));
    std::uint64_t dropped = 0;
    while (c->data.size() > 1 && (c->data.size() > options.max_queued_messages ||
                                  c->data_bytes > options.max_queued_bytes)) {
      c->data_bytes -= c->data.front().payload->size();
      c->data.pop_front();
      ++dropped;
    }
    if (dropped > 0) count([dropped](ServerStats& s) { s.messages_dropped += dropped; });
    c->wake.cancel();
  }
  void close(const std::shared_ptr<Client>& c) {
    if (c->closed) return;
    c->closed = true;
    for (const auto& [sub, channel] : c->subscriptions)
      --counts[index.at(channel)];
    c->subscriptions.clear();
    error_code ec;
    auto& socket = beast::get_lowest_layer(c->ws).socket();
    socket.shutdown(tcp::socket::shutdown_both, ec);
    socket.close(ec);
    c->wake.cancel();
  }

  void fan_out(std::uint32_t channel, std::uint64_t t, std::shared_ptr<const std::string> payload) {
    if (channels[index.at(channel)].latched) latched[channel] = Data{0, t, payload};
    for (const auto& c : clients) {
      for (const auto& [sub, ch] : c->subscriptions) {
        if (ch == channel) send_data(c, Data{sub, t, payload});
      }
    }
  }

  void handle_text(const std::shared_ptr<Client>& c, const std::string& text) {
    if (c->closed) return;  // read before the watchdog closed it: no subscription after close()
    const Json j = Json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("op") || !j["op"].is_string()) {
      send_control(c, status(2, "not a JSON object with a string \"op\""));
      return;
    }
    const std::string op = j["op"];
    if (op == "subscribe") {
      if (!j.contains("subscriptions") || !j["subscriptions"].is_array()) {
        send_control(c, status(2, "subscribe: \"subscriptions\" must be an array"));
        return;
      }
      for (const auto& s : j["subscriptions"]) {
        if (!s.is_object() || !s.contains("id") || !s["id"].is_number_unsigned() ||
            !s.contains("channelId") || !s["channelId"].is_number_unsigned()) {
          send_control(c, status(2,
                                 "subscribe: each subscription needs unsigned \"id\" and "
                                 "\"channelId\""));
          continue;
        }
        const auto sub = s["id"].get<std::uint64_t>();
        const auto channel = s["channelId"].get<std::uint64_t>();
        if (sub > UINT32_MAX || !index.count(static_cast<std::uint32_t>(channel))) {
          send_control(c, status(2, "subscribe: no channel " + std::to_string(channel)));
          continue;
        }
        const auto sub_id = static_cast<std::uint32_t>(sub);
        const auto channel_id = static_cast<std::uint32_t>(channel);
        if (c->subscriptions.count(sub_id)) {
          send_control(
              c, status(2, "subscribe: subscription id " + std::to_string(sub_id) + " is in use"));
          continue;
        }
        bool already = false;
        for (const auto& [other, ch] : c->subscriptions)
          already = already || ch == channel_id;
        if (already) {
          send_control(c, status(2, "subscribe: channel " + std::to_string(channel_id) +
                                        " is already subscribed"));
          continue;
        }
        c->subscriptions[sub_id] = channel_id;
        ++counts[index.at(channel_id)];
        if (const auto it = latched.find(channel_id); it != latched.end())
          send_data(c, Data{sub_id, it->second.log_time_ns, it->second.payload});
      }
    } else if (op == "unsubscribe") {
      if (!j.contains("subscriptionIds") || !j["subscriptionIds"].is_array()) {
        send_control(c, status(2, "unsubscribe: \"subscriptionIds\" must be an array"));
        return;
      }
      for (const auto& s : j["subscriptionIds"]) {
        if (!s.is_number_unsigned()) continue;
        const auto it = c->subscriptions.find(static_cast<std::uint32_t>(s.get<std::uint64_t>()));
        if (it == c->subscriptions.end()) continue;
        --counts[index.at(it->second)];
        // Messages already queued for it are not sent after the unsubscribe.
        std::erase_if(c->data, [sub = it->first, c](const Data& d) {
          if (d.subscription != sub) return false;
          c->data_bytes -= d.payload->size();
          return true;
        });
        c->subscriptions.erase(it);
      }
    } else {
      send_control(c, status(1, "\"" + op +
                                    "\" is not supported: this server is read-only "
                                    "(no publishing, parameters or services)"));
    }
  }

  asio::awaitable<void> write_loop(std::shared_ptr<Client> c) {
    error_code ec;
    while (!c->closed) {
      if (c->control.empty() && c->data.empty()) {
        c->wake.expires_at(Clock::time_point::max());
        co_await c->wake.async_wait(asio::redirect_error(asio::use_awaitable, ec));
        continue;
      }
      c->writing = true;
      c->write_started = Clock::now();
      if (!c->control.empty()) {
        const std::string text = std::move(c->control.front());
        c->control.pop_front();
        c->ws.text(true);
        co_await c->ws.async_write(asio::buffer(text),
                                   asio::redirect_error(asio::use_awaitable, ec));
      } else {
        const Data d = std::move(c->data.front());
        c->data.pop_front();
        c->data_bytes -= d.payload->size();
        std::array<std::uint8_t, 13> header{};
        header[0] = 0x01;  // messageData
        for (int i = 0; i < 4; ++i)
          header[static_cast<std::size_t>(1 + i)] =
              static_cast<std::uint8_t>((d.subscription >> (8 * i)) & 0xFFU);
        for (int i = 0; i < 8; ++i)
          header[static_cast<std::size_t>(5 + i)] =
              static_cast<std::uint8_t>((d.log_time_ns >> (8 * i)) & 0xFFU);
        const std::array<asio::const_buffer, 2> buffers{asio::buffer(header),
                                                        asio::buffer(*d.payload)};
        c->ws.binary(true);
        co_await c->ws.async_write(buffers, asio::redirect_error(asio::use_awaitable, ec));
        if (!ec) count([](ServerStats& s) { ++s.messages_sent; });
      }
      c->writing = false;
      if (ec) break;
    }
    close(c);
  }

  static http::response<http::string_body> refusal_response(http::status code, unsigned version,
                                                            const std::string& why) {
    http::response<http::string_body> res{code, version};
    res.set(http::field::server, "ajar-console");
    res.set(http::field::content_type, "text/plain");
    res.body() = "ajar-console: " + why + "\n";
    res.keep_alive(false);
    res.prepare_payload();
    return res;
  }

  // Why an upgrade request is refused, with its status; empty `why`: it may become a client.
  struct UpgradeRefusal {
    http::status code = http::status::bad_request;
    std::string why;
  };
  UpgradeRefusal upgrade_refusal(const http::request<http::string_body>& req) const {
    const std::string host(req[http::field::host]);
    const std::string protocols(req[http::field::sec_websocket_protocol]);
    const std::string origin(req[http::field::origin]);
    const std::string p = ":" + std::to_string(port);
    if (host != "127.0.0.1" + p && host != "localhost" + p && host != "[::1]" + p &&
        host != options.host + p) {
      return {http::status::forbidden, "unexpected Host header"};
    }
    if (!websocket::is_upgrade(req)) {
      return {http::status::bad_request, "this is a Foxglove WebSocket port (" +
                                             std::string(kSubprotocol) +
                                             "): connect Foxglove Studio to ws://" + host + "/"};
    }
    if (!lists_token(protocols, kSubprotocol)) {
      return {http::status::bad_request,
              "the WebSocket subprotocol " + std::string(kSubprotocol) + " is required"};
    }
    if (!origin_allowed(origin)) {
      return {http::status::forbidden,
              "a web page from " + origin + " may not read this port (docs/console.md, Foxglove)"};
    }
    return {};
  }

  // One connection from its accept to a client (or its refusal), within upgrade_timeout.
  asio::awaitable<void> serve(tcp::socket socket, std::unique_ptr<Slot> upgrade) {
    beast::tcp_stream stream(std::move(socket));
    stream.expires_after(options.upgrade_timeout);  // the deadline of the whole upgrade
    const auto timed_out = [this](const error_code& e) {
      if (e == beast::error::timeout) count([](ServerStats& s) { ++s.upgrades_timed_out; });
    };
    beast::flat_buffer buffer;
    error_code ec;
    http::request_parser<http::string_body> parser;
    parser.body_limit(4096);
    co_await http::async_read(stream, buffer, parser,
                              asio::redirect_error(asio::use_awaitable, ec));
    if (ec) {
      timed_out(ec);
      co_return;
    }
    const auto req = parser.release();
    if (const UpgradeRefusal refusal = upgrade_refusal(req); !refusal.why.empty()) {
      count([](ServerStats& s) { ++s.clients_refused; });
      auto res = refusal_response(refusal.code, req.version(), refusal.why);
      co_await http::async_write(stream, res, asio::redirect_error(asio::use_awaitable, ec));
      co_return;
    }
    auto c = std::make_shared<Client>(std::move(stream));
    c->ws.read_message_max(65536);
    c->ws.set_option(websocket::stream_base::decorator([](websocket::response_type& res) {
      res.set(http::field::sec_websocket_protocol, kSubprotocol);
      res.set(http::field::server, "ajar-console");
    }));
    co_await c->ws.async_accept(req, asio::redirect_error(asio::use_awaitable, ec));
    if (ec) {
      timed_out(ec);
      co_return;
    }
    // A client now: no deadline on its reads (it may only listen); the watchdog bounds its writes.
    beast::get_lowest_layer(c->ws).expires_never();
    clients.insert(c);
    upgrade->release();
    count([this](ServerStats& s) {
      s.clients = clients.size();
      ++s.clients_total;
    });
    co_await serve_client(c);
  }

  // A client, from its first messages (serverInfo, advertise) until it or the server closes: its
  // writer runs beside; what it sends is read here.
  asio::awaitable<void> serve_client(std::shared_ptr<Client> c) {
    send_control(c, server_info());
    send_control(c, advertise());
    asio::co_spawn(ioc, write_loop(c), asio::detached);
    beast::flat_buffer in;
    error_code ec;
    while (!c->closed) {
      in.clear();
      co_await c->ws.async_read(in, asio::redirect_error(asio::use_awaitable, ec));
      if (ec) break;
      if (c->ws.got_text()) {
        handle_text(c, beast::buffers_to_string(in.data()));
      } else {
        send_control(c, status(1,
                               "binary client messages are not supported: this server is "
                               "read-only"));
      }
    }
    close(c);
    clients.erase(c);
    count([this](ServerStats& s) { s.clients = clients.size(); });
  }

  // A connection beyond max_clients: HTTP 503 at once (its request unread), then what it sends is
  // read and dropped until it closes (so that it gets the 503, not a reset), within the deadline.
  asio::awaitable<void> refuse_busy(tcp::socket socket,
                                    [[maybe_unused]] std::unique_ptr<Slot> refusal) {
    beast::tcp_stream stream(std::move(socket));
    stream.expires_after(options.upgrade_timeout);
    error_code ec;
    auto res =
        refusal_response(http::status::service_unavailable, 11,
                         "too many Foxglove clients (" + std::to_string(options.max_clients) + ")");
    co_await http::async_write(stream, res, asio::redirect_error(asio::use_awaitable, ec));
    if (ec) co_return;
    stream.socket().shutdown(tcp::socket::shutdown_send, ec);
    stream.expires_after(
        std::min<std::chrono::milliseconds>(options.upgrade_timeout, std::chrono::seconds(2)));
    std::array<char, 4096> sink{};
    while (!ec) {
      co_await stream.async_read_some(asio::buffer(sink),
                                      asio::redirect_error(asio::use_awaitable, ec));
    }
  }

  asio::awaitable<void> accept_loop() {
    for (;;) {
      error_code ec;
      tcp::socket socket(ioc);
      co_await acceptor.async_accept(socket, asio::redirect_error(asio::use_awaitable, ec));
      if (ec) {
        if (ec == asio::error::operation_aborted || stopping) co_return;
        continue;
      }
      socket.set_option(tcp::no_delay(true), ec);
      // Clients and upgrades in progress count alike: connections that never upgrade cannot
      // hold more than max_clients places, and only until upgrade_timeout.
      if (clients.size() + upgrades >= options.max_clients) {
        count([](ServerStats& s) { ++s.clients_refused; });
        if (refusing < options.max_clients) {
          auto slot = std::make_unique<Slot>(refusing);
          asio::co_spawn(ioc, refuse_busy(std::move(socket), std::move(slot)), asio::detached);
        }  // else closed unanswered
        continue;
      }
      auto slot = std::make_unique<Slot>(upgrades);  // counted now, before the next accept
      asio::co_spawn(ioc, serve(std::move(socket), std::move(slot)), asio::detached);
    }
  }

  // Once a second: a client whose write has made no progress for stalled_write_timeout goes.
  asio::awaitable<void> watchdog() {
    asio::steady_timer timer(ioc);
    error_code ec;
    while (!stopping) {
      timer.expires_after(std::chrono::seconds(1));
      co_await timer.async_wait(asio::redirect_error(asio::use_awaitable, ec));
      const auto now = Clock::now();
      for (const auto& c : clients) {
        if (!c->closed && c->writing && now - c->write_started > options.stalled_write_timeout) {
          count([](ServerStats& s) { ++s.clients_disconnected_slow; });
          close(c);
        }
      }
    }
  }
};

Server::Server(ServerOptions options, std::vector<Channel> channels)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(channels))) {}

Server::~Server() {
  stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::uint16_t Server::listen() {
  auto& d = *impl_;
  const std::string where = d.options.host + ":" + std::to_string(d.options.port);
  if (!is_loopback_address(d.options.host)) {
    throw std::runtime_error(
        "--foxglove " + where +
        ": not a loopback address; the Foxglove port serves the camera and the robot's state "
        "without authentication: keep it on 127.0.0.1 and reach it through an SSH tunnel");
  }
  error_code ec;
  const tcp::endpoint ep(asio::ip::make_address(d.options.host), d.options.port);
  d.acceptor.open(ep.protocol(), ec);
  if (!ec) d.acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) d.acceptor.bind(ep, ec);
  if (!ec) d.acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error("--foxglove: cannot listen on " + where + ": " + ec.message());
  d.port = d.acceptor.local_endpoint().port();
  return d.port;
}

void Server::start() {
  auto& d = *impl_;
  asio::co_spawn(d.ioc, d.accept_loop(), asio::detached);
  asio::co_spawn(d.ioc, d.watchdog(), asio::detached);
  d.thread = std::thread([&d] { d.ioc.run(); });
}

void Server::stop() {
  auto& d = *impl_;
  if (d.stopping.exchange(true)) return;
  asio::post(d.ioc, [&d] {
    error_code ec;
    d.acceptor.close(ec);
    for (const auto& c : d.clients)
      d.close(c);
    d.ioc.stop();
  });
}

bool Server::subscribed(std::uint32_t channel_id) const {
  const auto it = impl_->index.find(channel_id);
  return it != impl_->index.end() && impl_->counts[it->second].load() > 0;
}

void Server::publish(std::uint32_t channel_id, std::uint64_t log_time_ns,
                     std::function<std::string()> build) {
  auto& d = *impl_;
  const auto it = d.index.find(channel_id);
  if (it == d.index.end() || d.stopping) return;
  if (!d.channels[it->second].latched && d.counts[it->second].load() == 0) return;
  asio::post(d.ioc, [&d, channel_id, log_time_ns, build = std::move(build)] {
    d.fan_out(channel_id, log_time_ns, std::make_shared<const std::string>(build()));
  });
}

ServerStats Server::stats() const {
  const std::lock_guard lock(impl_->stats_mutex);
  ServerStats s = impl_->stats;
  s.upgrades = impl_->upgrades.load();
  return s;
}

}  // namespace ajar::console::foxglove
