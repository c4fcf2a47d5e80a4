// The one list of ajard's config keys (private to config.cpp and config_print.cpp).
//
// fields(io, config) visits every key in file order with its type, its range or words, and its
// unit. Three visitors walk it: the reader (config.cpp: YAML -> Config, every error naming file,
// line and key), the writer (to_yaml) and the key list (config_keys: the flat key/value/allowed
// list that changed_keys compares and the docs/configuration.md test checks). A key added here is
// read, printed, compared and required in the docs at once. Cross-key rules (a wheel's axis within
// the card's axis count, ...) are in check() in config.cpp.
//
// The Io concept (C is Config when reading, const Config otherwise; every `key` but a section's is
// a Key: {name, meaning}):
//   section(key, fn)                 a map of keys; fn() visits them
//   number(key, v, min, max, unit)   a finite double within [min, max]
//   integer(key, v, min, max)        a whole number within [min, max]
//   integer_of(key, v, set, problem) a whole number from a fixed set
//   boolean(key, v)                  true / false
//   text(key, v, allowed, nonempty)  a string; `allowed` describes it for errors and the docs
//   choice(key, v, words[, presence]) one word of a table (Word<U>[]: config word <-> value)
//   range(key, lo, hi, min, max, unit)  [lo, hi] with min <= lo < hi <= max
//   vector3(key, v, min, max, unit)  three numbers
//   transform(key, m)                a rigid 4x4 transform (4 rows of 4 numbers)
//   list(key, items, allowed, fn)    a list of maps; fn(io, item) visits one item's keys
//   identity(id)                     inside a list item: exactly one of cn, san, sha256
#pragma once

#include <numbers>
#include <span>
#include <sstream>
#include <string>
#include <string_view>

#include "ajar/core/words.hpp"
#include "ajar/daemon/config.hpp"

namespace ajar::daemon::config_detail {

// The config file's words: Word rows (core/words.hpp: a value and its word). Every config enum's
// word table exists only here.

// Words that are no longer accepted, and what to write instead. `off` (and the `false` a YAML 1.1
// tool such as PyYAML or Ansible writes back for it) means "no fault" / "no logging": `none`.
struct RetiredWord {
  std::string_view word;
  std::string_view replacement;
};
inline constexpr RetiredWord kRetiredWords[] = {{"off", "none"}, {"false", "none"}};
inline constexpr std::string_view kRetiredWhy =
    "YAML 1.1 tools (PyYAML, Ansible) read off as the boolean false and write it back as false";

inline constexpr Word<drivers::DriverKind> kDriverKinds[] = {{drivers::DriverKind::kSim, "sim"},
                                                             {drivers::DriverKind::kMock, "mock"},
                                                             {drivers::DriverKind::kReal, "real"}};

inline constexpr Word<drivers::MockFault> kMockFaults[] = {
    {drivers::MockFault::kNone, "none"},
    {drivers::MockFault::kStuck, "stuck"},
    {drivers::MockFault::kSlow, "slow"},
    {drivers::MockFault::kErrorCode, "error"},
    {drivers::MockFault::kIntermittent, "intermittent"},
    {drivers::MockFault::kGarbage, "garbage"}};
// The mock arm's: the same words, and the arm's own (docs/drivers.md, "The mock arm").
inline constexpr Word<drivers::MockArmFault> kMockArmFaults[] = {
    {drivers::MockArmFault::kNone, "none"},
    {drivers::MockArmFault::kStuck, "stuck"},
    {drivers::MockArmFault::kSlow, "slow"},
    {drivers::MockArmFault::kErrorCode, "error"},
    {drivers::MockArmFault::kIntermittent, "intermittent"},
    {drivers::MockArmFault::kGarbage, "garbage"},
    {drivers::MockArmFault::kSilentMidTask, "silent_mid_task"},
    {drivers::MockArmFault::kSilentMidStop, "silent_mid_stop"},
    {drivers::MockArmFault::kResetMidTask, "reset_mid_task"},
    {drivers::MockArmFault::kStopIgnored, "stop_ignored"}};

inline constexpr Word<char> kParities[] = {{'N', "none"}, {'E', "even"}, {'O', "odd"}};

inline constexpr Word<LogLevel> kLogLevels[] = {
    {LogLevel::kTrace, "trace"}, {LogLevel::kDebug, "debug"}, {LogLevel::kInfo, "info"},
    {LogLevel::kWarn, "warn"},   {LogLevel::kError, "error"}, {LogLevel::kCritical, "critical"},
    {LogLevel::kNone, "none"}};

inline constexpr Word<LogSink> kLogSinks[] = {
    {LogSink::kAuto, "auto"}, {LogSink::kStderr, "stderr"}, {LogSink::kJournald, "journald"}};

inline constexpr Word<bool> kUnlisted[] = {{true, "observer"}, {false, "refuse"}};
inline constexpr Word<bool> kRoles[] = {{true, "controller"}, {false, "observer"}};

inline constexpr Word<TlsIdentity::Kind> kIdentityKinds[] = {
    {TlsIdentity::Kind::kCommonName, "cn"},
    {TlsIdentity::Kind::kSubjectAltName, "san"},
    {TlsIdentity::Kind::kSha256, "sha256"}};

inline constexpr int kStandardBauds[] = {1200,  2400,   4800,   9600,   19200, 38400,
                                         57600, 115200, 230400, 460800, 921600};
inline constexpr int kPolarities[] = {1, -1};

inline constexpr double kHalfPi = std::numbers::pi / 2;

// A key of the file: its name in its map and its meaning, docs/configuration.md's meaning column
// verbatim (markdown; the reference tables and through them ajard.yaml(5) are tested against it).
// The keys inside a list item have no row of their own: a name only.
struct Key {
  std::string_view name;
  std::string_view meaning;
  constexpr Key(const char* item_key) : name(item_key) {}  // NOLINT: implicit, list items' keys
  constexpr Key(std::string_view item_key) : name(item_key) {}  // NOLINT: implicit
  constexpr Key(std::string_view key, std::string_view what) : name(key), meaning(what) {}
  constexpr operator std::string_view() const noexcept { return name; }  // NOLINT: implicit
};

enum class Text { kMayBeEmpty, kNonEmpty };
enum class Presence { kOptional, kRequired };

template <typename Io, typename C>
void tls_fields(Io& io, C& t) {
  io.boolean({"enabled",
              "every connection must complete a TLS 1.3 handshake with a client certificate; then "
              "`certificate`, `private_key` and `ca` are required"},
             t.enabled);
  io.text({"certificate",
           "the daemon's certificate (chain); its subjectAltName must name the host/IP clients "
           "connect to. Must not be group/world writable"},
          t.certificate, "PEM file", Text::kMayBeEmpty);
  io.text({"private_key", "its key, unencrypted; refused unless mode 0600 (or stricter)"},
          t.private_key, "PEM file, mode 0600", Text::kMayBeEmpty);
  io.text({"ca", "the CA client certificates must chain to"}, t.ca, "PEM file", Text::kMayBeEmpty);
  io.text({"crl",
           "the CA's revocation list (`make-certs revoke NAME`); when given, every client "
           "certificate is checked against it — an expired CRL refuses everyone, so renew it "
           "(`make-certs crl`, valid 365 days)"},
          t.crl, "PEM file", Text::kMayBeEmpty);
  io.number({"handshake_timeout_s", "a handshake not finished by then is dropped (logged)"},
            t.handshake_timeout_s, 0.1, 600, "s");
  io.integer({"max_pending_handshakes",
              "handshakes running at once; a new connection beyond drops the oldest unfinished "
              "one. Handshakes count against `max_clients` too"},
             t.max_pending_handshakes, 1, 4096);
  io.choice({"unlisted", "what a CA-signed certificate that matches no `identities` entry gets"},
            t.unlisted_may_observe, kUnlisted);
  io.list(
      {"identities",
       "`{cn: NAME}`, `{san: NAME}` or `{sha256: HEX}` with `role: controller` or `observer` "
       "(required) and `may_stop` (default true); the first entry that matches the certificate's "
       "subject CN, one of its subjectAltNames (DNS, IP, email, URI) or its SHA-256 fingerprint "
       "(`openssl x509 -noout -fingerprint -sha256`, colons optional) decides. `controller` may "
       "take control; `observer` may not. `may_stop` allows Stop/EmergencyStop"},
      t.identities, "list of {cn, san or sha256; role; may_stop}", [](auto& item, auto& grant) {
        item.identity(grant.identity);
        item.choice("role", grant.may_control, kRoles, Presence::kRequired);
        item.boolean("may_stop", grant.may_stop);
      });
  io.list({"deny",
           "`{cn: …}`, `{san: …}` or `{sha256: …}`: refused at the handshake although CA-signed (a "
           "lost laptop, until the CRL names it)"},
          t.deny, "list of {cn, san or sha256}",
          [](auto& item, auto& identity) { item.identity(identity); });
}

template <typename Io, typename C>
void network_fields(Io& io, C& n) {
  io.text(
      {"bind_address", "address the TCP server listens on (`0.0.0.0` for the robot's Ethernet)"},
      n.bind_address, "IPv4/IPv6 literal", Text::kNonEmpty);
  io.integer({"port", "TCP port (0: any free port; see `--port-file`)"}, n.port, 0, 65535);
  io.integer({"max_clients",
              "at the limit a newcomer makes room: the idlest un-greeted session (else observer) "
              "is closed with `TOO_MANY_CLIENTS`; never the controller. Refused only when nothing "
              "can be closed — and even then its Stop/EmergencyStop is executed"},
             n.max_clients, 1, 4096);
  io.integer(
      {"send_queue_frames", "frames queued per session; a client that lets it fill is dropped"},
      n.send_queue_frames, 8, 65536);
  io.number({"read_deadline_s", "a frame that has started arriving must complete within this"},
            n.read_deadline_s, 0.1, 3600, "s");
  io.number({"idle_timeout_s", "close sessions silent this long (0: never)"}, n.idle_timeout_s, 0,
            86400, "s");
  io.number({"hello_timeout_s",
             "a connection that has not completed Hello this long after it opened gets `Error "
             "HELLO_REQUIRED` and is closed (0: never). Keeps sockets that never greet from "
             "holding `max_clients`"},
            n.hello_timeout_s, 0, 3600, "s");
  io.boolean({"insecure_plaintext",
              "plaintext on an address that is not loopback (`127.0.0.0/8`, `::1`) is refused at "
              "start unless this is true — and then ajard warns at every start. Use `tls` instead"},
             n.insecure_plaintext);
  io.section("tls", [&] { tls_fields(io, n.tls); });
}

template <typename Io, typename C>
void wheel_fields(Io& io, C& w, std::string_view axis_meaning) {
  io.integer({"card_axis", axis_meaning}, w.card_axis, 1, 8);
  io.integer_of({"polarity", "makes positive counts roll the wheel forward"}, w.polarity,
                kPolarities, "must be +1 or -1");
}

template <typename Io, typename C>
void base_fields(Io& io, C& b) {
  io.number({"wheel_radius_m", "R_W"}, b.wheel_radius_m, 0.01, 1.0, "m");
  io.number({"turning_radius_m", "R_B, turning centre to each driving wheel"}, b.turning_radius_m,
            0.05, 2.0, "m");
  io.number({"encoder_counts_per_rev", "motor encoder counts per motor revolution"},
            b.encoder_counts_per_rev, 1, 1e7, "");
  io.number({"gear_ratio", "motor revolutions per wheel revolution"}, b.gear_ratio, 0.01, 1000, "");
  io.section("left_wheel", [&] {
    wheel_fields(io, b.left,
                 "GTS axis of the left driving wheel; the two wheels' axes differ and are within "
                 "1..`drivers.card.axis_count`");
  });
  io.section("right_wheel",
             [&] { wheel_fields(io, b.right, "GTS axis of the right driving wheel"); });
  io.number({"max_wheel_speed_rad_s", "trapezoid cruise speed of a wheel"}, b.max_wheel_speed_rad_s,
            0.01, 100, "rad/s");
  io.number({"max_wheel_accel_rad_s2", "trapezoid acceleration and deceleration"},
            b.max_wheel_accel_rad_s2, 0.01, 1000, "rad/s^2");
}

template <typename Io, typename C>
void limits_fields(Io& io, C& l) {
  io.range({"door_width_m", "accepted door widths"}, l.min_door_width_m, l.max_door_width_m, 0.1,
           5.0, "m");
  io.range({"handle_length_m", "accepted handle lengths"}, l.min_handle_length_m,
           l.max_handle_length_m, 0.01, 1.0, "m");
  io.range({"depth_m", "the sensor's usable depth (camera z); points outside are refused"},
           l.min_depth_m, l.max_depth_m, 0.05, 20.0, "m");
  io.number({"max_yaw_correction_rad", "largest yaw the base may be asked to turn (< π/2)"},
            l.max_yaw_correction_rad, 0.001, kHalfPi - 1e-3, "rad");
  io.section("tolerances", [&] {
    auto& t = l.tolerances;
    io.number({"min_point_separation_m", "closer points are duplicates"}, t.min_point_separation_m,
              1e-4, 0.5, "m");
    io.number({"min_lateral_fraction",
               "Algorithm 1: |y1 − y2| / |P1P2| below this is \"not side by side\""},
              t.min_lateral_fraction, 0.0, 1.0, "");
    io.number({"collinearity", "plane points with a normalised spread below this are collinear"},
              t.collinearity, 1e-6, 0.5, "");
    io.number({"max_plane_rms_m", "plane fits with a larger RMS residual are refused"},
              t.max_plane_rms_m, 1e-5, 0.5, "m");
    io.number({"max_door_tilt_rad", "the door normal may tilt this far out of the horizontal"},
              t.max_door_tilt_rad, 0.0, kHalfPi - 1e-3, "rad");
  });
  io.section("arm_workspace", [&] {
    auto& a = l.arm;
    io.vector3({"shoulder_m", "centre of the arm's reach, base frame"}, a.shoulder_m, -5, 5, "m");
    io.range({"reach_m", "reachable distance from the shoulder"}, a.min_reach_m, a.max_reach_m, 0.0,
             5.0, "m");
    io.range({"z_m", "reachable height band, base frame"}, a.min_z_m, a.max_z_m, -5.0, 5.0, "m");
  });
}

template <typename Io, typename C>
void drive_fields(Io& io, C& d) {
  io.number({"max_linear_speed_m_s", "Jog: the loop clamps the body speed along +x to this"},
            d.max_linear_speed_m_s, 0.001, 5, "m/s");
  io.number({"max_angular_speed_rad_s", "Jog: body yaw rate limit"}, d.max_angular_speed_rad_s,
            0.001, 10, "rad/s");
  io.number({"max_linear_accel_m_s2",
             "Jog: speeding up and slowing down (also the stop after the command timeout)"},
            d.max_linear_accel_m_s2, 0.001, 20, "m/s^2");
  io.number({"max_angular_accel_rad_s2", "Jog: yaw acceleration limit"}, d.max_angular_accel_rad_s2,
            0.001, 50, "rad/s^2");
  io.number({"command_timeout_s",
             "A Drive command is valid this long; when no new one arrives the base decelerates to "
             "rest (the connection may stay up)"},
            d.command_timeout_s, 0.05, 5, "s");
  io.number({"approach_max_travel_m", "Longest accepted Approach move (`APPROACH_TOO_FAR`)"},
            d.approach_max_travel_m, 0.01, 20, "m");
  io.number({"approach_square_tolerance_rad",
             "Approach refused (`NOT_SQUARE_TO_DOOR`) when the yaw to the door is larger"},
            d.approach_square_tolerance_rad, 0.001, 1.0, "rad");
  io.number({"approach_min_standoff_m",
             "Smallest accepted standoff (`STANDOFF_OUT_OF_RANGE`); with a fresh door distance a "
             "forward jog stops there too (`AT_MINIMUM_STANDOFF`)"},
            d.approach_min_standoff_m, 0.05, 10, "m");
  io.number({"stale_forward_speed_m_s",
             "Forward jog speed limit while the door distance is stale (a stale plane): the base "
             "cannot be trusted to stop at the standoff, so it creeps"},
            d.stale_forward_speed_m_s, 0.001, 5, "m/s");
  io.number({"stale_travel_m",
             "The base origin moved this far (straight line) since the plane / contact point was "
             "taken: it is stale (`MEASUREMENT_STALE`)"},
            d.stale_travel_m, 0.001, 1.0, "m");
  io.number(
      {"stale_yaw_rad", "The base turned this much (not counting AlignBase's own turn): stale"},
      d.stale_yaw_rad, 0.001, 1.0, "rad");
}

template <typename Io, typename C>
void drivers_fields(Io& io, C& d) {
  io.choice({"kind",
             "`sim` (card simulator + arm simulator on a pseudo-terminal), `mock` (in-process "
             "doubles), `real` (GTS4 card + RS-232 arm)"},
            d.kind, kDriverKinds);
  io.section("card", [&] {
    io.text({"library",
             "`real`: path of the vendor's GTS library (required); `sim`: empty = the card "
             "simulator installed with ajard (`/usr/lib/<triplet>/ajar/`, found relative to "
             "ajard), or in a build tree the one built there"},
            d.card.library_path, "file path", Text::kMayBeEmpty);
    io.text({"config_file", "file passed to `GT_LoadConfig` (empty: skipped)"},
            d.card.card_config_path, "file path", Text::kMayBeEmpty);
    io.integer({"channel", "`GT_Open` channel"}, d.card.channel, 0, 15);
    io.integer({"poll_timeout_ms",
                "deadline for start-up waits on the card, and for the servo to come back on during "
                "a recovery (Reset) in the control loop"},
               d.card.poll_timeout_ms, 1, 60000);
    io.integer({"axis_count",
                "axes on the card (GTS-400: 4, GTS-800: 8); the wheels' `card_axis` must be within "
                "1..axis_count"},
               d.card.axis_count, 1, 8);
  });
  io.section("arm", [&] {
    io.text({"device", "serial device of the arm controller (`real`)"}, d.arm.device, "device path",
            Text::kNonEmpty);
    io.integer_of({"baud", "a standard rate"}, d.arm.baud, kStandardBauds,
                  "is not a standard baud rate");
    io.integer({"data_bits", "framing"}, d.arm.data_bits, 5, 8);
    io.choice({"parity", "framing"}, d.arm.parity, kParities);
    io.integer({"stop_bits", "framing"}, d.arm.stop_bits, 1, 2);
    io.integer({"ack_timeout_ms", "acknowledgement timeout per attempt"}, d.arm.ack_timeout_ms, 1,
               60000);
    io.integer({"retries", "retries (same sequence number) after the first attempt"}, d.arm.retries,
               0, 100);
    io.integer({"reconnect_min_ms", "reconnect backoff, doubling from min to max"},
               d.arm.reconnect_min_ms, 1, 600000);
    io.integer({"reconnect_max_ms", "the backoff's ceiling; not below `reconnect_min_ms`"},
               d.arm.reconnect_max_ms, 1, 600000);
  });
  io.section("mock", [&] {
    io.choice({"card_fault",
               "the mock card's fault (docs/drivers.md): `none`; `stuck`, `slow`, `error`, "
               "`intermittent`, `garbage`"},
              d.mock.card_fault, kMockFaults);
    io.choice({"arm_fault",
               "the mock arm's fault (docs/drivers.md, \"The mock arm\"): the card's words, and "
               "the arm's own: the controller stops answering half way through a task "
               "(`silent_mid_task`) or at the first stop of a task (`silent_mid_stop`), resets "
               "half way through a task (`reset_mid_task`: idle, the task forgotten), or answers a "
               "stop but stays busy (`stop_ignored`)"},
              d.mock.arm_fault, kMockArmFaults);
    io.integer({"slow_ms", "delay of the `slow` fault"}, d.mock.slow_ms, 0, 60000);
  });
  io.section("sim", [&] {
    io.number({"speedup", "simulated time runs this much faster than real time"}, d.sim_speedup,
              0.1, 1000, "");
  });
}

template <typename Io, typename C>
void control_fields(Io& io, C& c) {
  io.number({"rate_hz", "control loop rate"}, c.rate_hz, 10, 5000, "Hz");
  io.boolean({"realtime",
              "run the loop with SCHED_FIFO at `priority`; refused → a warning, normal scheduling"},
             c.realtime);
  io.integer({"priority", "SCHED_FIFO priority"}, c.priority, 1, 99);
  io.boolean({"lock_memory",
              "`mlockall(MCL_CURRENT | MCL_FUTURE | MCL_ONFAULT)` (what is resident and whatever "
              "is touched later stays resident) and the code the loop may run (executable, C/C++ "
              "runtime, card library) locked in full; refused → a warning"},
             c.lock_memory);
  io.number(
      {"motion_timeout_margin_s", "a motion must finish within 1.5 × its planned duration + this"},
      c.motion_timeout_margin_s, 0.0, 600, "s");
  io.number({"aligned_tolerance_rad",
             "a plane re-measured after alignment within this yaw keeps the base aligned"},
            c.aligned_tolerance_rad, 0.0, 0.5, "rad");
  io.number({"stall_timeout_s",
             "the loop supervisor: no control-loop cycle for this long (at least 2 periods), not "
             "counting a non-realtime control thread's waits for a CPU (up to 0.75 s of "
             "silence) → the "
             "base is emergency-stopped out of band and `LOOP_STALLED` latches "
             "(docs/control-loop.md, \"Stalled loop\"); at most 0.5 s so that the supervisor acts "
             "before systemd's watchdog (`WatchdogSec=2`)"},
            c.stall_timeout_s, 0.005, 0.5, "s");
}

// Every key of the file, in the order of config/ajard.yaml and docs/configuration.md.
template <typename Io, typename C>
void fields(Io& io, C& c) {
  io.section("network", [&] { network_fields(io, c.network); });
  io.section("frames", [&] {
    io.transform(
        {"camera_to_base_m",
         "`^B_C T` (the paper's eq. 2 in metres by default), 4 rows of 4 numbers: rotation "
         "(orthonormal, det +1 within 1e-6), translation in metres, bottom row exactly `0 0 0 1`"},
        c.camera_to_base_m);
  });
  io.section("base", [&] { base_fields(io, c.base); });
  io.section("limits", [&] { limits_fields(io, c.limits); });
  io.section("drive", [&] { drive_fields(io, c.drive); });
  io.section("drivers", [&] { drivers_fields(io, c.drivers); });
  io.section("control", [&] { control_fields(io, c.control); });
  io.section("safety", [&] {
    io.number({"deadman_timeout_s",
               "the controller silent this long while anything moves → motion stopped, `DEADMAN` "
               "fault latched"},
              c.safety.deadman_timeout_s, 0.02, 60, "s");
    io.number({"arm_task_timeout_s",
               "an arm task (Engage) not reported done within this → the arm is told to stop, "
               "`ARM_TIMEOUT` latches"},
              c.safety.arm_task_timeout_s, 0.1, 3600, "s");
    io.number(
        {"arm_stop_timeout_s",
         "an arm stop (Stop, Reset, a fault, a missed task deadline) sent while the arm may be at "
         "the door and not confirmed by an idle report within this → `ARM_NOT_CLEAR` latches "
         "(docs/procedure.md, \"The arm interlock\"). Give the serial driver its retries: above "
         "(`arm.retries` + 1) × `arm.ack_timeout_ms` plus the arm's time to withdraw"},
        c.safety.arm_stop_timeout_s, 0.1, 600, "s");
  });
  io.section("logging", [&] {
    io.choice({"level", "`none` turns logging off. SIGHUP applies a changed level at once"},
              c.logging.level, kLogLevels);
    io.choice({"sink", "`auto` (journald under systemd, stderr otherwise), `stderr`, `journald`"},
              c.logging.sink, kLogSinks);
  });
  io.section("state", [&] {
    io.text({"directory",
             "where accepted parameters and the procedure state are persisted (created if missing; "
             "relative paths are relative to the working directory). `--state-dir` overrides it"},
            c.state.directory, "directory path", Text::kNonEmpty);
  });
  io.section("recorder", [&] {
    io.boolean({"enabled",
                "record (a directory that cannot be written is logged and recording stays off; the "
                "daemon runs on)"},
               c.recorder.enabled);
    io.text({"directory",
             "where recordings are written (created 0750 if missing; files 0640, the daemon's user "
             "only; relative paths are relative to the working directory); saved recordings go to "
             "its `saved/`"},
            c.recorder.directory, "directory path", Text::kNonEmpty);
    io.integer({"max_bytes",
                "the disk budget: after each rotation the oldest recordings are removed until the "
                "rest fit (saved ones are never removed)"},
               c.recorder.max_bytes, 1LL << 20, 1LL << 50);
    io.integer(
        {"max_file_bytes",
         "a recording is closed and the next one started at this size (at most `max_bytes`)"},
        c.recorder.max_file_bytes, 64LL << 10, 1LL << 40);
    io.number({"max_file_s", "... or at this age"}, c.recorder.max_file_s, 1, 86400, "s");
    io.integer(
        {"loop_decimation",
         "record every n-th control-loop cycle (`1`: every cycle; 5 at 500 Hz: 100 samples/s)"},
        c.recorder.loop_decimation, 1, 10000);
  });
}

// "a, b, c" of text(item) for every item.
std::string join(const auto& items, auto&& text) {
  std::string out;
  for (const auto& item : items)
    out += (out.empty() ? "" : ", ") + std::string(text(item));
  return out;
}

inline std::string format_number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// What errors and docs/configuration.md say a number may be: "0.1..3600 s".
inline std::string limits_text(double min, double max, std::string_view unit) {
  std::ostringstream s;
  s << min << ".." << max;
  if (!unit.empty()) s << ' ' << unit;
  return s.str();
}

}  // namespace ajar::daemon::config_detail
