// Engine: the daemon's heart below the network. It owns the procedure state machine, the accepted
// door parameters (persisted), the motion card's lifecycle (brought up before the control thread
// starts, down after it stops), the control loop thread (which drives the card) and the arm.
// The network layer (server.hpp) owns sessions, roles, request de-duplication and fan-out, and
// talks to the engine only through this interface, from the single I/O thread.
//
// Threading: every method is called from the I/O thread, except where noted. The engine talks to
// its control thread through one ordered lock-free command path (docs/control-loop.md) and reads
// back reports and published snapshots; no call here blocks on the control loop.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ajar/drivers/factory.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::recorder {
class Recorder;
}

namespace ajar::daemon {

struct Config;

// Every method is pure: an implementation (EngineImpl) or a test double (tests/daemon/
// fake_engine.hpp, which forwards to another engine) that leaves one out does not compile, so a
// new method can never fall through silently to a default.
class Engine {
 public:
  // Receives events for every session (state changes, motion, faults). Called on the I/O thread
  // from inside handle_command() or poll().
  using EventSink = std::function<void(const protocol::Event&)>;

  virtual ~Engine() = default;

  // Where events go (every session). Set it before start(); the engine keeps a copy. Events
  // emitted while no sink is set are dropped.
  virtual void set_event_sink(EventSink sink) = 0;

  // Brings the drivers up (init -> configured -> active), restores persisted parameters (a
  // rejected state file or an unclean end of the previous run latches a fault:
  // docs/procedure.md, "Persistence"), records durably that the daemon runs, and starts the
  // control thread. Throws ajar::daemon::StartupError naming what failed (also when the state
  // cannot be recorded).
  virtual void start() = 0;

  // Shutdown in steps, for a caller that must not block (the daemon's I/O thread,
  // docs/operations.md "Signals"); shutdown() alone does them all, waiting (bounded).
  // begin_shutdown(): stops the wheels (smooth) and the arm, closing an open arm task with
  //   motion_stopped; from now on every command but Stop and EmergencyStop is refused with
  //   SHUTTING_DOWN. Stop and EmergencyStop are still executed on the card (the control thread runs
  //   until shutdown()), an EmergencyStop latches and is persisted. Idempotent.
  virtual void begin_shutdown() = 0;
  // Whether the wheels are at rest (drains the control loop's reports; poll it until true or the
  // caller's deadline).
  virtual bool wheels_at_rest() = 0;
  // After the wheels rest, or the caller's deadline passed (then the card gets an emergency stop
  // and MOTION_TIMEOUT latches): closes what is still open (motion_stopped) and persists the state
  // with the clean-shutdown mark. Call it while the sessions still hear events, then stop reading
  // requests; then wait, bounded, for settled_generation() >= accepted_generation() (a save that
  // does not finish leaves the mark off the disk: the next start treats the end as unclean).
  virtual void seal_state() = 0;
  // The rest: does what the steps above did not (waiting at most 5 s for the wheels and 5 s for
  // the disk), joins the control thread, abandons a state writer that hangs, brings the drivers
  // down. Idempotent. A control thread stuck in a motion-card call (a vendor call that never
  // returns) is waited for at most 1 s; then the card is left as the loop supervisor's out-of-band
  // emergency stop left it (not brought down: the vendor library is wedged) and wedged() is true.
  virtual void shutdown() noexcept = 0;
  // shutdown() could not end the control thread: the process must exit without destroying the
  // engine (its destructor would wait for that thread forever).
  virtual bool wedged() const noexcept = 0;

  // A command from the controlling session (roles are enforced by the caller). Validates with core,
  // updates the procedure, queues motion to the control loop. Returns the reply: Ack or ErrorReply.
  // Never moves anything on a refusal.
  virtual protocol::Message handle_command(const protocol::Message& request) = 0;

  // Stop / EmergencyStop from any session role is routed here too (via handle_command).

  // The controller is alive: any frame from it counts. The deadman in the control loop stops motion
  // and latches kDeadman when no heartbeat arrives for safety.deadman_timeout_s while moving.
  // Thread-safe (an atomic store).
  virtual void controller_heartbeat() noexcept = 0;
  // The controlling session went away (disconnect or take-over). If anything moves, it is stopped
  // at once and kDeadman latches.
  virtual void controller_lost() = 0;

  // The frames of one read from a socket (several frames can arrive in one TCP segment). Wheel
  // motion accepted between begin_read_batch() and end_read_batch() is handed to the control loop
  // only at end_read_batch(), so a Stop, EmergencyStop, Reset or controller loss later in the same
  // read cancels it before any wheel turns (the motion is closed by motion_stopped "cancelled
  // before it started"). Outside a batch, motion is handed to the loop at once. Not nested.
  virtual void begin_read_batch() = 0;
  virtual void end_read_batch() = 0;

  // Called periodically (at least every few ms) on the I/O thread: drains control-loop reports,
  // emits events, persists changes.
  virtual void poll() = 0;
  // Delivers what the control loop reported since the last poll() (its events go out now), so
  // that the events of a command handled next are the only ones it causes. The session hub calls
  // it before a command: it sends those events after the command's reply (docs/protocol.md 6.6).
  virtual void catch_up() = 0;

  // Durability of accepted changes (persistence runs on the state store's writer thread, never on
  // the I/O thread). Every change accepted so far is in the save numbered accepted_generation()
  // (0: none yet); settled_generation() is the highest save that has finished — on disk, or failed
  // (then take_warnings() says so). The network layer holds a state-changing command's Ack until
  // settled_generation() reaches the generation that command produced. Thread-safe (atomics).
  virtual std::uint64_t accepted_generation() const noexcept = 0;
  virtual std::uint64_t settled_generation() const noexcept = 0;

  virtual protocol::Status status() const = 0;
  virtual protocol::Telemetry telemetry() const = 0;
  virtual protocol::Welcome welcome_template() const = 0;  // limits and versions for Welcome
  // The reply to GetRobotModel (protocol 1.1): calibration and limits from the config.
  virtual protocol::RobotModel robot_model() const = 0;

  // Health for systemd's watchdog: true while the control loop keeps its period (it has completed a
  // cycle within the last few periods). Thread-safe.
  virtual bool control_loop_healthy() const noexcept = 0;

  // The daemon's clock: nanoseconds since the engine was made (CLOCK_MONOTONIC unless a test
  // injected a clock). Every daemon_time_ns on the wire (Telemetry, Event, Pong) uses it.
  // Thread-safe.
  virtual std::uint64_t daemon_time_ns() const noexcept = 0;

  // The black box (recorder.hpp, docs/blackbox.md), or nullptr (none: an engine double). Made with
  // the engine, started by start() (before the control thread), stopped by shutdown() (after it).
  // The session layer records frames, sessions and events into it; the protocol's black-box
  // requests list, read and save its recordings.
  virtual recorder::Recorder* recorder() noexcept = 0;

  // Test seam (EngineOptions::manual_loop only): runs one control-loop cycle at the engine's
  // clock on the calling thread. Without manual_loop it does nothing.
  virtual void run_loop_cycle() noexcept = 0;

  // Warnings from start() for the network layer to log (the engine never logs): realtime
  // scheduling or mlockall refused, a corrupt/unreadable state file (started clean), a restored
  // state that no longer validates with the current config. Valid after start().
  virtual std::vector<std::string> startup_warnings() const = 0;
  // Warnings that arose since the last call (e.g. the state file could not be written). Call after
  // poll() and log them.
  virtual std::vector<std::string> take_warnings() = 0;
};

// How an engine is made; the defaults are the daemon's. Tests inject a clock and drive the control
// loop by hand so that every interleaving of commands and cycles is reproducible.
struct EngineOptions {
  std::function<std::int64_t()> now_ns;  // monotonic ns; empty = CLOCK_MONOTONIC
  bool manual_loop = false;              // start() starts no control thread: call run_loop_cycle()
};

// Builds the engine for a loaded config (drivers selected by config.drivers.kind). Throws
// StartupError when the drivers cannot be created (e.g. a vendor library is missing).
std::unique_ptr<Engine> make_engine(const Config& config);
// The same over drivers made elsewhere (tests: fakes or mocks). `drivers.card` and `drivers.arm`
// must be set.
std::unique_ptr<Engine> make_engine(const Config& config, drivers::DriverSet drivers,
                                    EngineOptions options = {});

}  // namespace ajar::daemon
