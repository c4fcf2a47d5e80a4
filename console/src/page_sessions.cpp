// One WebSocket per open page: its send queue (text always, binary frames skipped when two wait),
// its writer and its reader; which pages want the depth overlay; and the deadman's gate: the
// heartbeat to ajard is on only while a connected page said "alive" within kPageAliveTimeout.
#include "server_impl.hpp"

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <boost/beast/core.hpp>

#include <algorithm>

#include "ajar/client/json.hpp"
#include "daemon_json.hpp"

namespace ajar::console {

void ConsoleServer::Impl::enqueue(const std::shared_ptr<WsSession>& s, bool binary,
                                  std::shared_ptr<const std::string> data) {
  if (s->closed || !data) return;
  if (binary) {
    if (s->frames_queued >= 2) return;  // a slow page skips frames, never text
    ++s->frames_queued;
  }
  s->queue.push_back({binary, std::move(data)});
  s->wake.cancel();
}

void ConsoleServer::Impl::broadcast_text(const std::string& text) {
  const auto data = std::make_shared<const std::string>(text);
  for (const auto& s : sessions)
    enqueue(s, false, data);
}

void ConsoleServer::Impl::reply(const std::shared_ptr<WsSession>& s, const std::string& text) {
  enqueue(s, false, std::make_shared<const std::string>(text));
}

void ConsoleServer::Impl::notice(const std::shared_ptr<WsSession>& s, const std::string& text) {
  reply(s, client::JsonObject().add("type", "notice").add("text", text).str());
}

asio::awaitable<void> ConsoleServer::Impl::write_loop(std::shared_ptr<WsSession> s) {
  error_code ec;
  while (!s->closed) {
    if (s->queue.empty()) {
      s->wake.expires_at(Clock::time_point::max());
      co_await s->wake.async_wait(asio::redirect_error(asio::use_awaitable, ec));
      continue;
    }
    auto m = std::move(s->queue.front());
    s->queue.pop_front();
    if (m.binary) --s->frames_queued;
    s->ws.binary(m.binary);
    co_await s->ws.async_write(asio::buffer(*m.data),
                               asio::redirect_error(asio::use_awaitable, ec));
    if (ec) {
      s->closed = true;
      break;
    }
  }
}

asio::awaitable<void> ConsoleServer::Impl::run_session(std::shared_ptr<WsSession> s) {
  sessions.insert(s);
  any_page = true;
  enqueue(s, false, std::make_shared<const std::string>(snapshot()));
  client::JsonArray entries;
  for (const auto& e : log)
    entries.add(e);
  enqueue(s, false,
          std::make_shared<const std::string>(
              client::JsonObject().add("type", "log").add("entries", entries).str()));
  if (!frames.empty() && frames.back()->colour) {
    enqueue(s, false, std::make_shared<const std::string>(frame_json(*frames.back())));
    enqueue(s, true, frames.back()->colour);
  }
  asio::co_spawn(ioc, write_loop(s), asio::detached);
  beast::flat_buffer buffer;
  for (;;) {
    error_code ec;
    buffer.clear();
    co_await s->ws.async_read(buffer, asio::redirect_error(asio::use_awaitable, ec));
    if (ec) break;
    if (!s->ws.got_text()) continue;
    handle_page(s, beast::buffers_to_string(buffer.data()));
  }
  s->closed = true;
  s->wake.cancel();
  sessions.erase(s);
  any_page = !sessions.empty();
  update_overlay();
  update_heartbeat();  // a closed page stops feeding the deadman at once
}

void ConsoleServer::Impl::update_heartbeat() {
  const auto now = Clock::now();
  bool alive = false;
  for (const auto& s : sessions)
    alive = alive || (now - s->last_alive < kPageAliveTimeout);
  if (alive != heartbeat_on) {
    heartbeat_on = alive;
    std::chrono::milliseconds interval{0};
    if (alive) {
      const double deadman_s = welcome ? static_cast<double>(welcome->deadman_timeout_s) : 1.0;
      interval =
          std::chrono::milliseconds(std::clamp(static_cast<long>(deadman_s * 1000 / 4), 20L, 250L));
    }
    client.set_heartbeat(interval);
    add_log(alive ? "page alive: feeding the deadman" : "no live page: deadman no longer fed");
    mark_dirty();
  }
}

void ConsoleServer::Impl::update_overlay() {
  bool want = false;
  for (const auto& s : sessions)
    want = want || s->overlay;
  overlay_wanted = want;
}

}  // namespace ajar::console
