// The open pages' WebSockets (page_hub.hpp).
#include "page_hub.hpp"

#include <boost/asio/redirect_error.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <boost/beast/core.hpp>

#include "ajar/client/json.hpp"
#include "ajar/console/server.hpp"

namespace ajar::console {

void PageHub::open(const Page& page) {
  pages_.insert(page);
  any_page_ = true;
}

void PageHub::close(const Page& page) {
  page->closed = true;
  page->wake.cancel();
  pages_.erase(page);
  any_page_ = !pages_.empty();
  update_overlay();
}

void PageHub::close_all() {
  boost::system::error_code ec;
  for (const auto& p : pages_) {
    p->closed = true;
    p->wake.cancel();
    p->ws.next_layer().close(ec);
  }
}

void PageHub::send(const Page& page, bool binary, std::shared_ptr<const std::string> data) {
  if (page->closed || !data) return;
  if (binary) {
    if (page->frames_queued >= 2) return;  // a slow page skips frames, never text
    ++page->frames_queued;
  }
  page->queue.push_back({binary, std::move(data)});
  page->wake.cancel();
}

void PageHub::reply(const Page& page, const std::string& text) {
  send(page, false, std::make_shared<const std::string>(text));
}

void PageHub::notice(const Page& page, const std::string& text) {
  reply(page, client::JsonObject().add("type", "notice").add("text", text).str());
}

void PageHub::broadcast_text(const std::string& text) {
  const auto data = std::make_shared<const std::string>(text);
  for (const auto& p : pages_)
    send(p, false, data);
}

boost::asio::awaitable<void> PageHub::write_loop(Page page) {
  namespace asio = boost::asio;
  boost::system::error_code ec;
  while (!page->closed) {
    if (page->queue.empty()) {
      page->wake.expires_at(std::chrono::steady_clock::time_point::max());
      co_await page->wake.async_wait(asio::redirect_error(asio::use_awaitable, ec));
      continue;
    }
    auto m = std::move(page->queue.front());
    page->queue.pop_front();
    if (m.binary) --page->frames_queued;
    page->ws.binary(m.binary);
    co_await page->ws.async_write(asio::buffer(*m.data),
                                  asio::redirect_error(asio::use_awaitable, ec));
    if (ec) {
      page->closed = true;
      break;
    }
  }
}

bool PageHub::any_alive(std::chrono::steady_clock::time_point now) const {
  for (const auto& p : pages_) {
    if (now - p->last_alive < kPageAliveTimeout) return true;
  }
  return false;
}

void PageHub::set_overlay(const Page& page, bool on) {
  page->overlay = on;
  update_overlay();
}

void PageHub::update_overlay() {
  bool want = false;
  for (const auto& p : pages_)
    want = want || p->overlay;
  overlay_wanted_ = want;
}

}  // namespace ajar::console
