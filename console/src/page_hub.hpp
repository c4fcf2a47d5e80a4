// Internal to the console's server: PageHub, the open pages' WebSockets (one per page), on the
// Asio thread: each page's send queue (text always; binary frames skipped while two wait, so a slow
// page skips frames, never text) and its writer; which pages are alive (the deadman's gate) and
// which want the depth overlay. The frame thread reads only the two atomics (any_page,
// overlay_wanted). What a page says is not the hub's: ConsoleServer::Impl reads and answers it.
#pragma once

// <utility> before any Asio header (asio issue 944).
#include <utility>

#include <boost/asio/awaitable.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/websocket.hpp>

#include <atomic>
#include <chrono>
#include <deque>
#include <memory>
#include <set>
#include <string>

namespace ajar::console {

// One open page's WebSocket.
struct WsSession {
  explicit WsSession(boost::asio::ip::tcp::socket socket)
      : ws(std::move(socket)), wake(ws.get_executor()) {}
  boost::beast::websocket::stream<boost::asio::ip::tcp::socket> ws;
  boost::asio::steady_timer wake;  // cancelled when the queue gets a message
  struct Outgoing {
    bool binary = false;
    std::shared_ptr<const std::string> data;
  };
  std::deque<Outgoing> queue;
  int frames_queued = 0;  // binary messages in the queue (at most 2: a slow page skips frames)
  bool closed = false;
  bool overlay = false;  // the page shows the depth overlay
  std::chrono::steady_clock::time_point last_alive{};
};

class PageHub {
 public:
  using Page = std::shared_ptr<WsSession>;

  void open(const Page& page);   // a page connected
  void close(const Page& page);  // its reader ended: closed, its writer woken, forgotten
  void close_all();              // the server stops: every page's socket is closed

  // Queues a message for one page (nothing once it is closed; a third binary frame is dropped).
  void send(const Page& page, bool binary, std::shared_ptr<const std::string> data);
  void reply(const Page& page, const std::string& text);
  void notice(const Page& page, const std::string& text);  // {"type":"notice","text":...}
  void broadcast_text(const std::string& text);
  // A new camera frame: its metadata (`meta`, made only when a page is open) and its image to
  // every page, its depth overlay to the pages that show it.
  template <typename MakeMeta>
  void broadcast_frame(MakeMeta&& meta, const std::shared_ptr<const std::string>& colour,
                       const std::shared_ptr<const std::string>& depth);

  // Writes a page's queue until it is closed (co_spawned once per page).
  static boost::asio::awaitable<void> write_loop(Page page);

  // Whether an open page said "alive" within kPageAliveTimeout of `now`.
  bool any_alive(std::chrono::steady_clock::time_point now) const;
  void set_overlay(const Page& page, bool on);

  // Read by the frame thread.
  bool any_page() const noexcept { return any_page_.load(); }
  bool overlay_wanted() const noexcept { return overlay_wanted_.load(); }

 private:
  void update_overlay();

  std::set<Page> pages_;
  std::atomic<bool> any_page_{false};
  std::atomic<bool> overlay_wanted_{false};
};

template <typename MakeMeta>
void PageHub::broadcast_frame(MakeMeta&& meta, const std::shared_ptr<const std::string>& colour,
                              const std::shared_ptr<const std::string>& depth) {
  if (pages_.empty()) return;
  const auto text = std::make_shared<const std::string>(meta());
  for (const auto& p : pages_) {
    if (colour) {
      send(p, false, text);
      send(p, true, colour);
    }
    if (p->overlay && depth) send(p, true, depth);
  }
}

}  // namespace ajar::console
