// Accepting connections and answering HTTP: the page's files from the web folder, /api/state,
// /api/sim/landmarks, /api/foxglove; a request whose Host is not this console's own address is
// refused (DNS rebinding), and a WebSocket only at /ws from the console's own page (Origin).
#include "server_impl.hpp"

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <boost/beast/core.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace ajar::console {
namespace {

std::string content_type(const std::string& name) {
  const auto ext = std::filesystem::path(name).extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  return "application/octet-stream";
}

// A file directly in the web folder: no path, no hidden file.
bool safe_file_name(const std::string& name) {
  if (name.empty() || name[0] == '.') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '-' || c == '_';
  });
}

http::response<http::string_body> respond(const http::request<http::string_body>& req,
                                          http::status code, std::string body,
                                          const std::string& type) {
  http::response<http::string_body> res{code, req.version()};
  res.set(http::field::server, "ajar-console");
  res.set(http::field::content_type, type);
  res.set(http::field::cache_control, "no-store");
  res.set("X-Content-Type-Options", "nosniff");
  res.keep_alive(req.keep_alive());
  res.body() = std::move(body);
  res.prepare_payload();
  return res;
}

}  // namespace

// Foxglove live's counters (docs/console.md): "null" when it is off.
std::string ConsoleServer::Impl::foxglove_json() const {
  if (!foxglove) return "null";
  const auto s = foxglove->stats();
  return client::JsonObject()
      .add("port", static_cast<unsigned>(foxglove_port))
      .add("clients", s.clients)
      .add("upgrades", s.upgrades)
      .add("clients_total", s.clients_total)
      .add("clients_refused", s.clients_refused)
      .add("upgrades_timed_out", s.upgrades_timed_out)
      .add("clients_disconnected_slow", s.clients_disconnected_slow)
      .add("messages_sent", s.messages_sent)
      .add("messages_dropped", s.messages_dropped)
      .str();
}

asio::awaitable<void> ConsoleServer::Impl::accept_loop() {
  for (;;) {
    error_code ec;
    tcp::socket socket(ioc);
    co_await acceptor.async_accept(socket, asio::redirect_error(asio::use_awaitable, ec));
    if (ec) {
      if (ec == asio::error::operation_aborted) co_return;
      continue;
    }
    asio::co_spawn(ioc, serve(std::move(socket)), asio::detached);
  }
}

bool ConsoleServer::Impl::host_allowed(const http::request<http::string_body>& req) const {
  const std::string host(req[http::field::host]);
  const std::string p = ":" + std::to_string(port);
  return host == "127.0.0.1" + p || host == "localhost" + p || host == "[::1]" + p ||
         host == options.listen_host + p;
}

asio::awaitable<void> ConsoleServer::Impl::serve(tcp::socket socket) {
  beast::flat_buffer buffer;
  for (;;) {
    http::request<http::string_body> req;
    error_code ec;
    http::request_parser<http::string_body> parser;
    parser.body_limit(4096);
    co_await http::async_read(socket, buffer, parser,
                              asio::redirect_error(asio::use_awaitable, ec));
    if (ec) co_return;
    req = parser.release();
    if (!host_allowed(req)) {
      auto res = respond(req, http::status::forbidden, "ajar-console: unexpected Host header\n",
                         "text/plain");
      co_await http::async_write(socket, res, asio::redirect_error(asio::use_awaitable, ec));
      co_return;
    }
    if (websocket::is_upgrade(req)) {
      const std::string origin(req[http::field::origin]);
      const std::string host(req[http::field::host]);
      if (req.target() != "/ws" || (!origin.empty() && origin != "http://" + host)) {
        auto res = respond(req, http::status::forbidden,
                           "ajar-console: WebSocket only at /ws from this console's own page\n",
                           "text/plain");
        co_await http::async_write(socket, res, asio::redirect_error(asio::use_awaitable, ec));
        co_return;
      }
      auto session = std::make_shared<WsSession>(std::move(socket));
      session->ws.read_message_max(8192);
      co_await session->ws.async_accept(req, asio::redirect_error(asio::use_awaitable, ec));
      if (ec) co_return;
      co_await run_session(session);
      co_return;
    }
    http::response<http::string_body> res;
    const std::string target(req.target());
    if (req.method() != http::verb::get && req.method() != http::verb::head) {
      res = respond(req, http::status::method_not_allowed, "GET only\n", "text/plain");
    } else if (target == "/api/state") {
      res = respond(req, http::status::ok, snapshot(), "application/json");
    } else if (target == "/api/foxglove") {
      res = respond(req, foxglove ? http::status::ok : http::status::not_found, foxglove_json(),
                    "application/json");
    } else if (target == "/api/sim/landmarks") {
      res = respond(req, sim ? http::status::ok : http::status::not_found, landmarks_json(),
                    "application/json");
    } else {
      const std::string name = target == "/" ? "index.html" : target.substr(1);
      std::string body;
      bool found = false;
      if (safe_file_name(name)) {
        std::ifstream f(std::filesystem::path(options.web_dir) / name, std::ios::binary);
        if (f) {
          std::ostringstream ss;
          ss << f.rdbuf();
          body = ss.str();
          found = true;
        }
      }
      res = found ? respond(req, http::status::ok, std::move(body), content_type(name))
                  : respond(req, http::status::not_found, "not found\n", "text/plain");
    }
    co_await http::async_write(socket, res, asio::redirect_error(asio::use_awaitable, ec));
    if (ec || !req.keep_alive()) co_return;
  }
}

}  // namespace ajar::console
