#include <utility>  // before Asio (asio issue 944)

#include "ajar/daemon/server.hpp"

#include <map>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <spdlog/spdlog.h>

#include "ajar/daemon/config.hpp"
#include "ajar/daemon/session_hub.hpp"
#include "ajar/daemon/tls.hpp"
#include "ajar/recorder/recorder.hpp"

namespace ajar::daemon {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

std::string endpoint_text(const tcp::endpoint& e) {
  const auto address = e.address();
  return (address.is_v6() ? "[" + address.to_string() + "]" : address.to_string()) + ":" +
         std::to_string(e.port());
}

}  // namespace

ServerOptions ServerOptions::from(const NetworkConfig& network) {
  ServerOptions options;
  options.bind_address = network.bind_address;
  options.port = network.port;
  options.max_clients = network.max_clients;
  options.session.send_queue_frames =
      static_cast<std::size_t>(std::max(network.send_queue_frames, 1));
  options.session.read_deadline = seconds(network.read_deadline_s);
  options.session.idle_timeout = seconds(network.idle_timeout_s);
  options.hello_timeout = seconds(network.hello_timeout_s);
  options.tls = network.tls;
  options.insecure_plaintext = network.insecure_plaintext;
  return options;
}

struct Server::Impl {
  Impl(asio::io_context& io_context, Engine& eng, ServerOptions opts)
      : io(io_context),
        engine(eng),
        options(std::move(opts)),
        acceptor(io),
        poll_timer(io),
        recordings(options.recordings == nullptr && eng.recorder() != nullptr
                       ? make_recorder_recordings(*eng.recorder(), io_context)
                       : nullptr),
        hub(eng, SessionHub::Options{
                     options.ledger, options.hello_timeout,
                     options.recordings != nullptr ? options.recordings : recordings.get()}) {
    if (engine.recorder() != nullptr) {
      options.session.frame_tap = [&eng = engine](std::uint64_t id, std::uint8_t direction,
                                                  std::span<const std::uint8_t> frame,
                                                  const SharedFrame& sent) {
        if (sent) {
          eng.recorder()->frame(direction, id, eng.daemon_time_ns(), sent);  // not copied
        } else {
          eng.recorder()->frame(direction, id, eng.daemon_time_ns(), frame);
        }
      };
    }
  }

  void accept() {
    acceptor.async_accept([this](const boost::system::error_code& ec, tcp::socket socket) {
      if (!accepting) return;
      if (ec) {
        if (ec != asio::error::operation_aborted) {
          spdlog::warn("accept failed: {}", ec.message());
          // Out of file descriptors and the like: try again shortly rather than spin.
          retry_timer = std::make_unique<asio::steady_timer>(io, std::chrono::milliseconds(100));
          retry_timer->async_wait([this](const boost::system::error_code& wait_ec) {
            if (!wait_ec && accepting) accept();
          });
        }
        return;
      }
      on_accepted(std::move(socket));
      accept();
    });
  }

  void on_accepted(tcp::socket socket) {
    boost::system::error_code ec;
    socket.set_option(tcp::no_delay(true), ec);
    const auto remote = socket.remote_endpoint(ec);
    const std::string peer = ec ? std::string("unknown peer") : endpoint_text(remote);
    const std::uint64_t id = ++last_session_id;
    if (tls) {
      const auto limit = static_cast<std::size_t>(std::max(options.max_clients, 0));
      if (hub.session_count() + tls->pending() >= limit)
        tls->drop_oldest("dropped unfinished: max_clients reached");
      tls->handshake(
          std::move(socket), peer,
          [this, id, peer](TlsStream stream, Admission a, PeerCertificate c) {
            if (!accepting) return;
            if (!a.admitted) return refuse_certificate(std::move(stream), id, peer, a);
            track(id, start_session<TlsStream>(std::move(stream), id, peer, std::move(a.access)),
                  std::move(c));
          });
      return;
    }
    start_session<tcp::socket>(std::move(socket), id, peer, PeerAccess{});
  }

  template <typename Stream>
  std::shared_ptr<Session<Stream>> start_session(Stream stream, std::uint64_t id,
                                                 const std::string& peer, PeerAccess access) {
    if (!has_room()) return refuse(std::move(stream), id, peer, std::move(access));
    auto session = std::make_shared<Session<Stream>>(std::move(stream), id, peer, &hub,
                                                     options.session, std::move(access));
    session->start();
    return session;
  }

  // TLS sessions and the certificates they authenticated with, re-checked on reload_tls().
  struct Tracked {
    std::weak_ptr<TlsSession> session;
    PeerCertificate certificate;
  };
  void track(std::uint64_t id, const std::shared_ptr<TlsSession>& session, PeerCertificate c) {
    // Forget closed sessions now and then, so that the table stays about max_clients long.
    if (tls_sessions.size() >= 2 * static_cast<std::size_t>(std::max(options.max_clients, 8)))
      std::erase_if(tls_sessions, [](const auto& t) { return t.second.session.expired(); });
    tls_sessions[id] = Tracked{session, std::move(c)};
  }

  // After a reload: a session whose certificate the new policy refuses (revoked, denied, expired,
  // no longer listed) or grants less gets ERROR NOT_CONTROLLER (field "certificate", naming the
  // identity and the reason) and is closed after it; the deadman stops a controller's motion.
  void recheck_tls_sessions() {
    for (auto it = tls_sessions.begin(); it != tls_sessions.end();) {
      const auto session = it->second.session.lock();
      if (!session) {
        it = tls_sessions.erase(it);
        continue;
      }
      const std::string why = tls->recheck(it->second.certificate, session->access());
      if (why.empty()) {
        ++it;
        continue;
      }
      const std::string& identity = session->access().identity;
      spdlog::warn("TLS: closing session {} from {} ({}): after the reload: {}", it->first,
                   session->peer(), identity, why);
      protocol::ErrorReply error;
      error.code = ErrorCode::kNotController;
      error.offending_type = protocol::MessageType::kHello;
      error.field.assign("certificate");
      error.message.assign("certificate " + identity + " no longer admitted: " + why + "; closing");
      if (auto frame = encode_frame(protocol::Envelope{0, 0, error}, hub.minor_of(it->first)))
        session->send(std::move(frame));
      session->close_after_flush("certificate no longer admitted: " + why);
      it = tls_sessions.erase(it);
    }
  }

  // The TLS handshake succeeded but the policy running now refuses the certificate (reloaded after
  // it was verified, tls.hpp): ERROR NOT_CONTROLLER (field "certificate", naming the identity and
  // why), then a graceful close. No handler: nothing the peer sends is handled, not even a Stop.
  void refuse_certificate(TlsStream stream, std::uint64_t id, const std::string& peer,
                          const Admission& a) {
    protocol::ErrorReply error;
    error.code = ErrorCode::kNotController;
    error.offending_type = protocol::MessageType::kHello;
    error.field.assign("certificate");
    error.message.assign("certificate " + a.access.identity + " not admitted: " + a.refusal +
                         "; closing");
    PeerAccess none = a.access;
    none.may_control = false;
    none.may_stop = false;
    auto session = std::make_shared<TlsSession>(std::move(stream), id, peer, nullptr,
                                                options.session, std::move(none));
    session->refuse(encode_frame(protocol::Envelope{0, 0, error}),
                    "certificate not admitted: " + a.refusal, Clock::duration::zero());
  }

  // A newcomer is always read: at max_clients the hub closes an idle session to make room.
  bool has_room() {
    const auto limit = static_cast<std::size_t>(std::max(options.max_clients, 0));
    return hub.session_count() < limit || hub.make_room();
  }

  // Nothing to evict (only the controller): TOO_MANY_CLIENTS, but the newcomer's first frames are
  // still read for refused_read_window, so its Stop/EmergencyStop is executed.
  template <typename Stream>
  std::shared_ptr<Session<Stream>> refuse(Stream stream, std::uint64_t id, const std::string& peer,
                                          PeerAccess access) {
    spdlog::warn(
        "refused {}: {} clients connected (network.max_clients); its Stop and "
        "EmergencyStop are still executed",
        peer, hub.session_count());
    protocol::ErrorReply error;
    error.code = ErrorCode::kTooManyClients;
    error.offending_type = protocol::MessageType::kHello;
    error.message.assign("too many clients (" + std::to_string(options.max_clients) +
                         "); try again later");
    auto session = std::make_shared<Session<Stream>>(
        std::move(stream), id, peer, &hub.refusal_handler(), options.session, std::move(access));
    session->refuse(encode_frame(protocol::Envelope{0, 0, error}), "too many clients",
                    options.refused_read_window);
    return session;
  }

  void schedule_poll() {
    next_poll += options.poll_period;
    const auto now = Clock::now();
    if (next_poll < now) next_poll = now + options.poll_period;  // fell behind: do not burst
    poll_timer.expires_at(next_poll);
    poll_timer.async_wait([this](const boost::system::error_code& ec) {
      if (ec || !polling) return;
      poll();
      schedule_poll();
    });
  }

  void poll() {
    try {
      engine.poll();
    } catch (const std::exception& e) {
      spdlog::error("engine poll failed: {}", e.what());
    }
    for (const auto& warning : engine.take_warnings())
      spdlog::warn("{}", warning);
    hub.tick(Clock::now());
  }

  asio::io_context& io;
  Engine& engine;
  ServerOptions options;
  tcp::acceptor acceptor;
  asio::steady_timer poll_timer;
  std::unique_ptr<asio::steady_timer> retry_timer;
  // The engine's recorder over the protocol (ServerOptions::recordings unless given); declared
  // before the hub, so destroyed after it.
  std::unique_ptr<Recordings> recordings;
  SessionHub hub;
  std::unique_ptr<TlsAcceptor> tls;  // null: plaintext
  std::map<std::uint64_t, Tracked> tls_sessions;
  Clock::time_point next_poll{};
  std::uint64_t last_session_id = 0;
  std::uint16_t bound_port = 0;
  std::string where;
  bool started = false;
  bool accepting = false;
  bool polling = false;  // the poll timer runs: from start() to stop_accepting()
  bool stopped = false;
};

Server::Server(asio::io_context& io, Engine& engine, ServerOptions options)
    : impl_(std::make_unique<Impl>(io, engine, std::move(options))) {
  // Before engine.start(): the engine wants its sink set first.
  engine.set_event_sink([&hub = impl_->hub](const protocol::Event& e) { hub.on_event(e); });
}

Server::~Server() = default;

std::uint16_t Server::bind() {
  auto& d = *impl_;
  const std::string where = d.options.bind_address + ":" + std::to_string(d.options.port);
  boost::system::error_code ec;
  const auto address = asio::ip::make_address(d.options.bind_address, ec);
  if (ec)
    throw StartupError("network.bind_address: '" + d.options.bind_address +
                       "' is not an IP address");
  if (d.options.tls.enabled) {
    if (!d.tls) d.tls = std::make_unique<TlsAcceptor>(d.options.tls);
  } else if (!address.is_loopback()) {
    if (!d.options.insecure_plaintext)
      throw StartupError("network.bind_address: plaintext on " + d.options.bind_address +
                         " is refused: enable network.tls or set network.insecure_plaintext");
    spdlog::warn(
        "INSECURE: plaintext on {} (network.insecure_plaintext): anyone who reaches this port "
        "can command the robot; enable network.tls (docs/security.md)",
        d.options.bind_address);
  }
  const tcp::endpoint endpoint(address, d.options.port);
  auto fail = [&](const char* what) {
    throw StartupError("cannot listen on " + where + ": " + what + ": " + ec.message());
  };
  d.acceptor.open(endpoint.protocol(), ec);
  if (ec) fail("socket");
  d.acceptor.set_option(tcp::acceptor::reuse_address(true), ec);
  if (ec) fail("SO_REUSEADDR");
  d.acceptor.bind(endpoint, ec);
  if (ec) fail("bind");
  d.bound_port = d.acceptor.local_endpoint(ec).port();
  d.where = endpoint_text(tcp::endpoint(address, d.bound_port));
  return d.bound_port;
}

void Server::start() {
  auto& d = *impl_;
  if (d.started) return;
  d.started = true;
  boost::system::error_code ec;
  d.acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw StartupError("cannot listen on " + d.where + ": listen: " + ec.message());
  spdlog::info("listening on {} ({})", d.where, d.tls ? "mutual TLS 1.3" : "plaintext");
  d.accepting = true;
  d.accept();
  d.polling = true;
  d.next_poll = Clock::now();
  d.schedule_poll();
}

void Server::begin_shutdown() {
  auto& d = *impl_;
  d.accepting = false;
  boost::system::error_code ignored;
  d.acceptor.close(ignored);
  if (d.tls) d.tls->close_all();
  if (d.retry_timer) d.retry_timer->cancel();
  d.hub.begin_shutdown();  // the poll timer goes on: engine reports, events, held replies
}

void Server::stop_accepting() {
  auto& d = *impl_;
  begin_shutdown();
  d.polling = false;
  d.poll_timer.cancel();
}

void Server::reload_tls(const TlsConfig& tls) {
  auto& d = *impl_;
  if (!d.tls) return;
  d.tls->reload(tls);
  d.options.tls = tls;
  d.recheck_tls_sessions();
}

void Server::stop() {
  auto& d = *impl_;
  if (d.stopped) return;
  stop_accepting();
  d.stopped = true;
  d.hub.release_all();
  d.hub.close_all("daemon shutting down");
  d.engine.set_event_sink([](const protocol::Event&) {});
}

std::uint16_t Server::port() const noexcept {
  return impl_->bound_port;
}
std::size_t Server::session_count() const noexcept {
  return impl_->hub.session_count();
}
const SessionHub& Server::hub() const noexcept {
  return impl_->hub;
}

}  // namespace ajar::daemon
