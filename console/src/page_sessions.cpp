// One WebSocket per open page: what it gets first (state, log, the newest frame), its reader (its
// queue and writer: PageHub); and the deadman's gate: the heartbeat to ajard is on only while a
// connected page said "alive" within kPageAliveTimeout.
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

asio::awaitable<void> ConsoleServer::Impl::run_session(std::shared_ptr<WsSession> s) {
  pages.open(s);
  pages.reply(s, snapshot());
  client::JsonArray entries;
  for (const auto& e : log)
    entries.add(e);
  pages.reply(s, client::JsonObject().add("type", "log").add("entries", entries).str());
  if (!frames.empty() && frames.back()->colour) {
    pages.reply(s, frame_json(*frames.back()));
    pages.send(s, true, frames.back()->colour);
  }
  asio::co_spawn(ioc, PageHub::write_loop(s), asio::detached);
  beast::flat_buffer buffer;
  for (;;) {
    error_code ec;
    buffer.clear();
    co_await s->ws.async_read(buffer, asio::redirect_error(asio::use_awaitable, ec));
    if (ec) break;
    if (!s->ws.got_text()) continue;
    handle_page(s, beast::buffers_to_string(buffer.data()));
  }
  pages.close(s);
  update_heartbeat();  // a closed page stops feeding the deadman at once
}

void ConsoleServer::Impl::update_heartbeat() {
  const bool alive = pages.any_alive(Clock::now());
  if (alive != heartbeat_on) {
    heartbeat_on = alive;
    std::chrono::milliseconds interval{0};
    if (alive) {
      const double deadman_s = welcome ? static_cast<double>(welcome->deadman_timeout_s) : 1.0;
      interval =
          std::chrono::milliseconds(std::clamp(static_cast<long>(deadman_s * 1000 / 4), 20L, 250L));
    }
    link.client().set_heartbeat(interval);
    add_log(alive ? "page alive: feeding the deadman" : "no live page: deadman no longer fed");
    mark_dirty();
  }
}

}  // namespace ajar::console
