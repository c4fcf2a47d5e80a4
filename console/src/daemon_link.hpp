// Internal to the console's server: DaemonLink, the console's one session with ajard and the two
// worker threads that make its blocking calls: one connects (Hello as controller, or as observer
// when another controller holds the robot; a reconnect at most once a second while disconnected),
// subscribes, reads the robot model and Status, and carries the page's requests in order; the other
// carries Stop and EmergencyStop only, so that a stop never waits behind another request. Jog
// commands are coalesced: at most one Drive waits, the newest. What the link learns goes to its
// Listener on the link's threads (the console posts it to its Asio thread); events and telemetry
// come from the client's reader (client()).
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "ajar/client/client.hpp"
#include "ajar/console/server.hpp"
#include "worker.hpp"

namespace ajar::console {

class DaemonLink {
 public:
  class Listener {
   public:
    virtual void connect_failed(const std::string& why) = 0;  // no connection (retried)
    virtual void hello_refused(const std::string& why) = 0;   // connected, Hello refused
    virtual void connected(const protocol::Welcome& welcome) = 0;
    virtual void robot_model(const client::Response& reply) = 0;  // GetRobotModel (protocol 1.1)
    virtual void status_received(const protocol::Status& status) = 0;  // after requests, events
    // The request worker's turn for the console's own polling (the black box): right after a
    // connect (`connected_now`), and when no job came for a while.
    virtual void worker_idle(bool connected_now) = 0;

   protected:
    ~Listener() = default;
  };
  using Job = std::function<void()>;

  DaemonLink(const ConsoleOptions& options, Listener& listener);
  ~DaemonLink();  // shutdown()
  DaemonLink(const DaemonLink&) = delete;
  DaemonLink& operator=(const DaemonLink&) = delete;

  client::Client& client() { return client_; }

  void start();     // the workers, and the first connect
  void shutdown();  // lets running jobs end, joins the workers, heartbeat off, disconnects

  void post(Job job);       // on the request worker, in order (after start())
  void post_stop(Job job);  // on the stop worker
  // On the request worker: the session closes and reconnects as controller taking over / as an
  // observer; demoted(): the daemon made this session an observer, a reconnect stays one.
  void take_over();
  void observe();
  void demoted();
  // A jog: the newest Drive replaces one still waiting. `refused` runs on the worker for a reply
  // other than an Ack.
  void drive(const protocol::Drive& d, std::function<void(const client::Response&)> refused);

  void refresh_status();  // on a worker: GetStatus, to the listener

 private:
  void connect_now();  // request worker
  void idle();         // request worker: reconnects at most once a second while disconnected

  const ConsoleOptions& options_;
  Listener& listener_;
  client::Client client_;
  protocol::Role role_;  // request worker only
  bool take_over_next_;  // request worker only
  std::chrono::steady_clock::time_point next_connect_attempt_{};
  std::unique_ptr<Worker> worker_;       // connect, measurements, commands
  std::unique_ptr<Worker> stop_worker_;  // Stop and EmergencyStop only
  std::mutex drive_mutex_;
  protocol::Drive pending_drive_;
  bool drive_queued_ = false;
};

}  // namespace ajar::console
