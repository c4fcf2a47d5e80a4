// ajarctl's session (private to ajar_ctl): one connection and one Hello shared by the commands of
// a command line or a script, and the commands that talk to the daemon. Split by job:
// session.cpp (connect, dispatch, printing, ping, watch), session_motion.cpp (align, engage,
// approach: the Ack, then one wait for the motion's end), session_drive.cpp (drive with keys or
// for S seconds).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/client/cli.hpp"
#include "ajar/client/output.hpp"
#include "ajar/client/teleop.hpp"

namespace ajar::client {

using Clock = std::chrono::steady_clock;

// Ctrl-C, SIGTERM and SIGHUP (a closed terminal) end a wait like Ctrl-C (the waits send Stop);
// SIGPIPE is ignored. catch_interrupts() installs the handlers and clears interrupted().
void catch_interrupts();
bool interrupted();

Milliseconds seconds_to_ms(double s);
// kExitOk, kExitRefused (an error reply) or kExitConnection (timeout, disconnected).
int exit_code(const Response& r);

class Session {
 public:
  Session(const GlobalOptions& options, std::ostream& out, std::ostream& err);

  // Connects and says Hello once; later calls reuse the session.
  int open(bool controller);
  // One command on the open session; its exit code.
  int execute(const Command& c);
  void print(const JsonObject& json, const std::string& text);
  void print_error(std::string_view command, std::string_view code, const std::string& message);
  // Commands come from stdin or a file: drive without --for refuses (no keys to read).
  void set_script_mode() { script_mode_ = true; }

 private:
  static ClientOptions client_options(const GlobalOptions& o);
  std::uint8_t session_minor() const;  // the Welcome's minor (this version's before one)

  // session.cpp
  int ping(const Command& c);
  int watch(const Command& c);
  std::optional<protocol::RobotModel> robot_model(std::string_view command);
  std::uint64_t telemetry_count();
  bool wait_at_rest(std::uint64_t after, double seconds);

  // session_motion.cpp
  struct MotionWait {
    int rc = kExitOk;       // the Ack's, or an interruption's or a failed status read's
    bool waited = false;    // false: the Ack failed or --no-wait (rc says which)
    bool finished = false;  // `done` said so before --wait-timeout (else Stop was sent)
    protocol::Status last;  // the last status read
  };
  MotionWait send_and_wait(const Command& c,
                           const std::function<bool(const protocol::Status&)>& done,
                           const std::function<void(const protocol::Status&, double)>& progress);
  int motion(const Command& c);
  int approach(const Command& c);

  // session_drive.cpp
  int drive_keys(const Command& c);
  // drive_keys' loop (on the raw terminal): keys to velocities, Drive re-sent when due, Stop on
  // space, the status line; until q/Esc/Ctrl-C, the end of input, an interruption, a lost
  // connection or a Drive no velocity would change. Its exit code; `note`: what to tell.
  int drive_by_keys(const std::string& name, const teleop::Limits& limits,
                    teleop::ResendScheduler& schedule, std::string& note);
  void draw_drive_status(const teleop::Velocity& v, const std::string& note);
  int drive_for(const Command& c);
  // drive_for's parts: Drive re-sent for --for seconds (an interruption says so in `failure`);
  // then Drive 0 and the wait for rest, or Stop after a failure (`count`: the telemetry frames
  // before); the result printed with the odometry before and after.
  int drive_steadily(const Command& c, teleop::ResendScheduler& schedule, std::string& failure);
  int come_to_rest(const std::string& name, int rc, const std::string& failure,
                   std::uint64_t count);
  void print_drive_result(const Command& c, const protocol::Status& before,
                          const protocol::Status& after);

  const GlobalOptions& options_;
  std::ostream& out_;
  std::ostream& err_;
  bool script_mode_ = false;
  // Declared before client_: the client's callbacks use them until the client is destroyed.
  std::mutex latest_mutex_;
  protocol::Telemetry latest_;               // newest Telemetry (drive's status line, waits)
  std::uint64_t telemetry_count_ = 0;        // Telemetry frames received
  std::vector<protocol::EventKind> events_;  // kinds of the Events received, oldest first
  std::mutex print_mutex_;
  std::atomic<bool> show_events_{false};
  std::atomic<bool> show_telemetry_{false};
  Client client_;
  bool greeted_ = false;
};

}  // namespace ajar::client
