#include <utility>  // before Asio (asio issue 944)

#include "ajar/daemon/daemon.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <csignal>
#include <cstring>
#include <filesystem>

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <spdlog/spdlog.h>

#include "ajar/daemon/blackbox.hpp"
#include "ajar/daemon/cli.hpp"
#include "ajar/daemon/logging.hpp"
#include "ajar/daemon/realtime.hpp"
#include "ajar/daemon/server.hpp"
#include "ajar/daemon/systemd_notify.hpp"
#include "ajar/drivers/factory.hpp"

namespace ajar::daemon {
namespace {

namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;

constexpr auto kStatusEvery = std::chrono::seconds(5);
// Shutdown (docs/operations.md, "Signals"): every wait is on a timer of the I/O thread, bounded.
constexpr auto kWheelsRestLimit = std::chrono::seconds(5);  // the smooth stop
constexpr auto kStateFlushLimit = std::chrono::seconds(5);  // the last save
constexpr auto kShutdownGrace = std::chrono::seconds(3);    // sessions flushing and closing
constexpr auto kShutdownPollPeriod = std::chrono::milliseconds(2);

std::string state_text(const protocol::Status& s, std::size_t sessions) {
  std::string text = "state " + std::string(protocol::to_string(s.state));
  if (s.latched_fault != ErrorCode::kOk)
    text += ", fault " + std::string(to_string(s.latched_fault));
  text += "; " + std::to_string(sessions) + " session(s)";
  return text;
}

class Runner {
 public:
  Runner(const Config& config, const RunOptions& options)
      : config_(config),
        options_(options),
        signals_(io_, SIGTERM, SIGINT, SIGHUP),
        watchdog_timer_(io_),
        status_timer_(io_),
        shutdown_timer_(io_) {}

  int run() {
    try {
      prepare_process({config_.control.realtime, config_.control.priority,
                       config_.control.lock_memory});  // before the engine starts threads
      engine_ = options_.make_engine ? options_.make_engine(config_) : make_engine(config_);
      // The server installs the engine's event sink: before engine.start().
      server_ = std::make_unique<Server>(io_, *engine_, ServerOptions::from(config_.network));
      // Bound (a busy port fails here, before any driver is activated) but not listening: a connect
      // is refused until the engine serves.
      port_ = server_->bind();
      engine_->start();
      for (const auto& w : engine_->startup_warnings())
        spdlog::warn("{}", w);
      spdlog::info("realtime: {}",
                   describe_realtime({config_.control.realtime, config_.control.priority,
                                      config_.control.lock_memory},
                                     realtime_granted()));
      server_->start();
      if (!options_.port_file.empty()) {
        write_file_atomically(options_.port_file, std::to_string(port_) + "\n");
      }
    } catch (const StartupError& e) {
      return fail(e.what());
    } catch (const drivers::DriverStartupError& e) {
      return fail(e.what());
    } catch (const std::exception& e) {
      return fail(e.what());
    }

    wait_signal();
    start_watchdog();
    schedule_status();
    const std::string where = config_.network.bind_address + ":" + std::to_string(port_);
    spdlog::info("ajard ready: listening on {}, drivers active, control loop at {} Hz", where,
                 config_.control.rate_hz);
    notifier_.ready("serving on " + where);

    io_.run();
    engine_.reset();
    spdlog::info("ajard stopped");
    return kExitOk;
  }

 private:
  int fail(const std::string& what) {
    spdlog::critical("start-up failed: {}", what);
    if (engine_) engine_->shutdown();
    if (server_) server_->stop();
    io_.restart();
    io_.poll();
    server_.reset();
    engine_.reset();
    return kExitStartup;
  }

  void wait_signal() {
    signals_.async_wait([this](const boost::system::error_code& ec, int signal_number) {
      if (ec) return;
      if (stopping_) {
        spdlog::info("signal {} ignored: already shutting down", signal_number);
      } else if (signal_number == SIGHUP) {
        reload();
      } else {
        shutdown(signal_number == SIGTERM ? "SIGTERM" : "SIGINT");
      }
      wait_signal();
    });
  }

  // The shutdown never blocks the I/O thread until every session is gone: Stop and EmergencyStop
  // are served (executed on the card, acknowledged, an EmergencyStop latched and persisted) while
  // the wheels come to rest; then the state is sealed (clean-shutdown mark), the sessions are
  // closed after their queued frames, and the last save and the closing sessions are awaited on
  // timers, each bounded; only then does the engine join its threads and bring the drivers down.
  void shutdown(const char* why) {
    spdlog::info(
        "{}: shutting down: stopping the motion (Stop and EmergencyStop are still executed, "
        "everything else gets SHUTTING_DOWN), then persisting the state",
        why);
    notifier_.stopping(std::string("stopping (") + why + ")");
    stopping_ = true;
    status_timer_.cancel();
    server_->begin_shutdown();
    engine_->begin_shutdown();
    log_engine_warnings();
    deadline_ = Clock::now() + kWheelsRestLimit;
    wait_for_wheels();
  }

  void wait_for_wheels() {
    if (!engine_->wheels_at_rest() && Clock::now() < deadline_) {
      after(kShutdownPollPeriod, [this] { wait_for_wheels(); });
      return;
    }
    engine_->seal_state();  // its events still reach the sessions
    log_engine_warnings();
    server_->stop();  // held replies sent, sessions closed after their queued frames
    deadline_ = Clock::now() + kStateFlushLimit;
    grace_deadline_ = Clock::now() + kShutdownGrace;
    wait_for_disk_and_sessions();
  }

  void wait_for_disk_and_sessions() {
    const bool saved = engine_->settled_generation() >= engine_->accepted_generation();
    const bool gone = server_->session_count() == 0;
    const auto now = Clock::now();
    if ((saved || now >= deadline_) && (gone || now >= grace_deadline_)) {
      finish(saved);
      return;
    }
    after(kShutdownPollPeriod, [this] { wait_for_disk_and_sessions(); });
  }

  void finish(bool saved) {
    if (!saved) {
      spdlog::error(
          "state not persisted: the last save did not finish within {} s (a hung or failing "
          "disk?); the next start treats this end as unclean (UNCLEAN_SHUTDOWN)",
          kStateFlushLimit.count());
    }
    engine_->shutdown();  // joins the control thread, brings the drivers down
    log_engine_warnings();
    if (engine_->wedged()) {
      // Its destructor would wait for the stuck control thread forever: exit without it.
      spdlog::critical(
          "exiting with the control thread stuck in a motion-card call (exit status {})",
          kExitWedged);
      shutdown_logging();  // drains the queue; the logger dies on this thread
      std::_Exit(kExitWedged);
    }
    boost::system::error_code ignored;
    signals_.cancel(ignored);
    watchdog_timer_.cancel();
    shutdown_timer_.cancel();
    io_.stop();
  }

  template <typename F>
  void after(std::chrono::milliseconds delay, F then) {
    shutdown_timer_.expires_after(delay);
    shutdown_timer_.async_wait([then](const boost::system::error_code& ec) {
      if (!ec) then();
    });
  }

  void log_engine_warnings() {
    for (const auto& w : engine_->take_warnings())
      spdlog::warn("{}", w);
  }

  // SIGHUP: re-read the config; apply the reloadable keys (kReloadableKeys, and network.tls except
  // `enabled`: its files are re-read on every SIGHUP), and name every other
  // changed key as needing a restart (nothing else is changed under live sessions and the loop).
  static constexpr std::string_view kReloadableKeys[] = {"logging.level"};

  void reload() {
    if (!options_.reload_config) {
      spdlog::warn("SIGHUP: no config file to reload");
      return;
    }
    try {
      const Config fresh = options_.reload_config();
      const Config config_before = config_;
      std::string applied;
      std::string need_restart;
      for (const auto& key : changed_keys(config_, fresh)) {
        const bool reloadable =
            std::find(std::begin(kReloadableKeys), std::end(kReloadableKeys), key) !=
                std::end(kReloadableKeys) ||
            (key.starts_with("network.tls.") && key != "network.tls.enabled");  // tls.hpp
        std::string& list = reloadable ? applied : need_restart;
        list += (list.empty() ? "" : ", ") + key;
        if (key == "logging.level")
          list += " (now " + std::string(to_string(fresh.logging.level)) + ")";
      }
      if (fresh.logging.level != config_.logging.level) {
        set_log_level(fresh.logging.level);
        config_.logging.level = fresh.logging.level;
      }
      if (fresh.network.tls.enabled && config_.network.tls.enabled) {
        // Always: the CRL and certificate files may have changed under an unchanged config.
        try {
          server_->reload_tls(fresh.network.tls);
          config_.network.tls = fresh.network.tls;
        } catch (const std::exception& e) {
          spdlog::error("SIGHUP: network.tls not reloaded, keeping the running policy: {}",
                        e.what());
        }
      }
      // The black box: the config in force now (what was applied) and every key that changed.
      record_config(engine_->recorder(), engine_->daemon_time_ns(), "reload", config_,
                    changed_keys(config_before, fresh));
      if (applied.empty() && need_restart.empty()) {
        spdlog::info("SIGHUP: config re-read, nothing changed");
      } else if (need_restart.empty()) {
        spdlog::warn("SIGHUP: applied {}", applied);
      } else {
        spdlog::warn("SIGHUP: applied {}; not applied, restart ajard to apply: {}",
                     applied.empty() ? std::string("nothing") : applied, need_restart);
      }
    } catch (const std::exception& e) {
      spdlog::error("SIGHUP: config not reloaded, keeping the running one: {}", e.what());
    }
  }

  void start_watchdog() {
    const auto interval = notifier_.watchdog_interval();
    if (!interval) return;
    spdlog::info("systemd watchdog: petting every {} ms while the control loop is healthy",
                 interval->count() / 1000);
    watchdog_interval_ = *interval;
    pet_watchdog();
  }

  void pet_watchdog() {
    if (stopping_) return;  // after STOPPING=1 systemd's stop timeout applies, not the watchdog
    const bool healthy = engine_->control_loop_healthy();
    if (healthy) {
      notifier_.watchdog();
      if (stalled_) spdlog::warn("control loop healthy again: petting the systemd watchdog");
    } else if (!stalled_) {
      spdlog::critical(
          "control loop stalled: not petting the systemd watchdog (systemd will "
          "restart ajard unless it recovers)");
      notifier_.status("control loop stalled");
    }
    stalled_ = !healthy;
    watchdog_timer_.expires_after(watchdog_interval_);
    watchdog_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) pet_watchdog();
    });
  }

  void schedule_status() {
    if (!notifier_.enabled()) return;
    status_timer_.expires_after(kStatusEvery);
    status_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec || stopping_) return;
      if (!stalled_) notifier_.status(state_text(engine_->status(), server_->session_count()));
      schedule_status();
    });
  }

  Config config_;
  const RunOptions& options_;
  asio::io_context io_{1};
  asio::signal_set signals_;
  asio::steady_timer watchdog_timer_;
  asio::steady_timer status_timer_;
  asio::steady_timer shutdown_timer_;
  SystemdNotifier notifier_;
  std::unique_ptr<Engine> engine_;
  std::unique_ptr<Server> server_;
  std::uint16_t port_ = 0;
  std::chrono::microseconds watchdog_interval_{0};
  bool stalled_ = false;
  bool stopping_ = false;               // SIGTERM/SIGINT: the shutdown runs
  Clock::time_point deadline_{};        // of the shutdown step that runs
  Clock::time_point grace_deadline_{};  // for the sessions to close
};

}  // namespace

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp." + std::to_string(::getpid());
  auto fail = [&](const char* what) {
    const int err = errno;
    ::unlink(temporary.c_str());
    throw StartupError("cannot write " + path + ": " + what + ": " + std::strerror(err));
  };
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("open");
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      ::close(fd);
      fail("write");
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    ::close(fd);
    fail("fsync");
  }
  if (::close(fd) != 0) fail("close");
  if (::rename(temporary.c_str(), path.c_str()) != 0) fail("rename");
}

int run_daemon(const Config& config, const RunOptions& options) {
  Runner runner(config, options);
  return runner.run();
}

}  // namespace ajar::daemon
