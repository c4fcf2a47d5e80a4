// In-process daemon for tests: a Server on 127.0.0.1 port 0 with its own I/O thread, over any
// Engine (FakeEngine, fake_engine.hpp, for session tests, the real engine on mock/sim drivers for
// e2e tests).
#pragma once

#include <utility>  // before Asio (asio issue 944)

#include <atomic>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>

#include "ajar/daemon/engine.hpp"
#include "ajar/daemon/server.hpp"
#include "ajar/daemon/session_hub.hpp"
#include "eventually.hpp"
#include "fake_engine.hpp"

namespace ajar::test {

// Runs a Server on its own I/O thread, as ajard does: the server is built (installing the event
// sink), binds, engine.start(), listens and serves; stop() stops accepting, shuts the engine down
// and closes the sessions on the I/O thread, then joins it.
class ServerThread {
 public:
  ServerThread(daemon::Engine& engine, daemon::ServerOptions options) : engine_(engine) {
    options.bind_address = "127.0.0.1";
    options.port = 0;
    server_ = std::make_unique<daemon::Server>(io_, engine, std::move(options));
    port_ = server_->bind();
    engine_.start();
    server_->start();
    thread_ = std::thread([this] { io_.run(); });
  }
  ~ServerThread() { stop(); }

  void stop() {
    if (!thread_.joinable()) return;
    boost::asio::post(io_, [this] {  // the daemon's order (daemon.cpp)
      server_->stop_accepting();
      engine_.shutdown();
      server_->stop();
    });
    // Sessions linger at most SessionOptions::linger after the graceful close.
    thread_.join();
  }

  std::uint16_t port() const { return port_; }
  boost::asio::io_context& io() { return io_; }

  // Runs `f` on the I/O thread and returns its result (to inspect server state without races).
  template <typename F>
  auto call(F f) -> decltype(f()) {
    std::packaged_task<decltype(f())()> task(std::move(f));
    auto result = task.get_future();
    boost::asio::post(io_, [&task] { task(); });
    return result.get();
  }

  std::size_t session_count() {
    return call([this] { return server_->session_count(); });
  }

  // The server itself: use it only inside call() (the I/O thread), e.g.
  // call([&] { thread.server().reload_tls(tls); return 0; }).
  daemon::Server& server() { return *server_; }

 private:
  daemon::Engine& engine_;
  boost::asio::io_context io_{1};
  std::unique_ptr<daemon::Server> server_;
  std::uint16_t port_ = 0;
  std::thread thread_;
};

}  // namespace ajar::test
