// ConsoleServer: start (TLS files, listening socket), run (threads, signals), stop; the Asio
// thread's tick and the log. The other jobs: server_impl.hpp lists their files.
#include "ajar/console/server.hpp"

#include "server_impl.hpp"

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/use_awaitable.hpp>

#include <ctime>
#include <stdexcept>

#include "ajar/client/json.hpp"
#include "ajar/security/tls_files.hpp"
#include "daemon_json.hpp"

namespace ajar::console {
std::string ConsoleServer::Impl::now_hms() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  std::array<char, 16> buf{};
  std::strftime(buf.data(), buf.size(), "%H:%M:%S", &tm);
  return buf.data();
}

void ConsoleServer::Impl::add_log(const std::string& text) {
  const std::string entry = now_hms() + "  " + text;
  log.push_back(entry);
  while (log.size() > 200)
    log.pop_front();
  pages.broadcast_text(
      client::JsonObject().add("type", "log").add("entries", client::JsonArray().add(entry)).str());
}

asio::awaitable<void> ConsoleServer::Impl::tick_loop() {
  asio::steady_timer timer(ioc);
  error_code ec;
  unsigned ticks = 0;
  while (!stopping) {
    timer.expires_after(std::chrono::milliseconds(100));
    co_await timer.async_wait(asio::redirect_error(asio::use_awaitable, ec));
    update_heartbeat();
    if (state_dirty) {
      state_dirty = false;
      if (telemetry) {
        broadcast_pose = {telemetry->odometry_x_m, telemetry->odometry_y_m,
                          telemetry->base_yaw_odometry_rad};
      }
      pages.broadcast_text(snapshot());
    }
    // The page's link watchdog: a word from the console at least every 250 ms, with the age of
    // ajard's telemetry as the console sees it.
    if (++ticks % 2 == 0) {
      client::JsonObject t;
      t.add("type", "tick").add("daemon", daemon_connected);
      if (telemetry) {
        t.add("telemetry_age_ms",
              std::chrono::duration<double, std::milli>(Clock::now() - telemetry_at).count());
      }
      pages.broadcast_text(t.str());
    }
  }
}

ConsoleServer::ConsoleServer(ConsoleOptions options, std::unique_ptr<FrameSource> source,
                             SimulatedSource* sim)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(source), sim)) {}

ConsoleServer::~ConsoleServer() {
  stop();
  if (impl_->frame_thread.joinable()) impl_->frame_thread.join();
  impl_->link.shutdown();
}

std::uint16_t ConsoleServer::listen() {
  auto& d = *impl_;
  // Before anything listens: a bad key is a start-up error, not a retry loop on the page.
  const auto& tls = d.options.tls;
  if (!tls.enabled() && (!tls.certificate.empty() || !tls.private_key.empty()))
    throw std::runtime_error("--cert/--key need --ca (the CA that signed ajard's certificate)");
  if (tls.enabled()) {
    if (tls.certificate.empty() != tls.private_key.empty())
      throw std::runtime_error("TLS: a client certificate needs both --cert and --key");
    const std::pair<const std::string*, const char*> files[] = {
        {&tls.ca, "--ca"}, {&tls.certificate, "--cert"}, {&tls.private_key, "--key"}};
    for (const auto& [path, option] : files) {
      if (path->empty()) continue;
      const std::string problem = security::tls_file_problem(*path, path == &tls.private_key);
      if (!problem.empty()) throw std::runtime_error(std::string(option) + ": " + problem);
    }
  }
  error_code ec;
  const auto address = asio::ip::make_address(d.options.listen_host, ec);
  if (ec)
    throw std::runtime_error("--listen: '" + d.options.listen_host + "' is not an IP address");
  const tcp::endpoint ep(address, d.options.listen_port);
  d.acceptor.open(ep.protocol(), ec);
  if (!ec) d.acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) d.acceptor.bind(ep, ec);
  if (!ec) d.acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error("cannot listen on " + d.options.listen_host + ":" +
                             std::to_string(d.options.listen_port) + ": " + ec.message());
  }
  d.port = d.acceptor.local_endpoint().port();
  if (d.options.foxglove) {
    foxglove::ServerOptions fo;
    fo.host = d.options.foxglove_host;
    fo.port = d.options.foxglove_port;
    d.foxglove = std::make_unique<FoxgloveLive>(fo);
    d.foxglove_port = d.foxglove->listen();
  }
  return d.port;
}

std::uint16_t ConsoleServer::foxglove_port() const {
  return impl_->foxglove_port;
}

void ConsoleServer::run() {
  auto& d = *impl_;
  auto& client = d.link.client();
  client.on_telemetry([&d](const protocol::Telemetry& t) { d.on_telemetry(t); });
  client.on_event([&d](const protocol::Event& e) { d.on_event(e); });
  client.on_disconnect([&d](const std::string& why) {
    d.on_io([&d, why] {
      d.daemon_connected = false;
      d.connection_message = "disconnected: " + why;
      d.add_log("ajard: disconnected: " + why);
      d.mark_dirty();
    });
  });
  d.add_log("camera: " + d.source->describe());
  d.link.start();
  d.frame_thread = std::thread([&d] { d.frame_loop(); });
  if (d.foxglove) d.foxglove->start();
  asio::signal_set signals(d.ioc, SIGINT, SIGTERM);
  signals.async_wait([this](const error_code& ec, int) {
    if (!ec) stop();
  });
  asio::co_spawn(d.ioc, d.accept_loop(), asio::detached);
  asio::co_spawn(d.ioc, d.tick_loop(), asio::detached);
  d.ioc.run();
  d.stopping = true;
  d.link.client().set_heartbeat(std::chrono::milliseconds(0));
}

void ConsoleServer::stop() {
  auto& d = *impl_;
  d.stopping = true;
  if (d.foxglove) d.foxglove->stop();
  asio::post(d.ioc, [&d] {
    error_code ec;
    d.acceptor.close(ec);
    d.pages.close_all();
    d.ioc.stop();
  });
}

}  // namespace ajar::console
