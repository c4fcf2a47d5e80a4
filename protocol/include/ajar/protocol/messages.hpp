// Ajar wire protocol 1.2: the messages, as plain C++ values. Pure: no sockets, threads or logging.
// The byte-level layout of every message is in docs/protocol.md; codec.hpp turns these into bytes
// and back. Every field has a fixed size on the wire: no message allocates when decoded.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <variant>

#include "ajar/core/error.hpp"
#include "ajar/core/types.hpp"
#include "ajar/core/words.hpp"

namespace ajar::protocol {

inline constexpr std::uint8_t kVersionMajor = 1;
// This library speaks 1.0, 1.1 and 1.2: it encodes and decodes every layout (docs/protocol.md
// section 7).
inline constexpr std::uint8_t kVersionMinor = 2;
inline constexpr std::size_t kMaxPlanePoints = 16;
inline constexpr std::size_t kMinPlanePoints = 3;
// 1.2: the most data one RecordingChunk carries, and the entries one RecordingList carries.
inline constexpr std::size_t kMaxRecordingChunk = 960;
inline constexpr std::size_t kRecordingListEntries = 8;

// Copies `in` into `out` (capacity `capacity`) so that the result is valid on the wire: at most
// `capacity` bytes, cut only at a UTF-8 code point boundary, invalid UTF-8 bytes replaced by '?',
// control characters (U+0000..U+001F, U+007F) replaced by ' '. Returns the length written.
std::size_t copy_wire_string(std::string_view in, char* out, std::size_t capacity) noexcept;
// True when `s` is acceptable as a wire string: valid UTF-8 without control characters.
bool is_wire_string(std::string_view s) noexcept;

// A string with a fixed capacity and an explicit length (wire: u8 length + N bytes, zero padded;
// see docs/protocol.md). assign() sanitizes (see copy_wire_string) so that what is stored always
// encodes into something the peer's decoder accepts.
template <std::size_t N>
struct FixedString {
  static_assert(N <= 255);
  std::array<char, N> bytes{};
  std::uint8_t length = 0;

  FixedString() = default;
  FixedString(std::string_view s) { assign(s); }  // NOLINT: implicit, truncates to N
  FixedString(const char* s) : FixedString(std::string_view(s)) {}  // NOLINT: implicit
  void assign(std::string_view s) {
    bytes.fill('\0');
    length = static_cast<std::uint8_t>(copy_wire_string(s, bytes.data(), N));
  }
  std::string_view view() const { return {bytes.data(), length}; }
  friend bool operator==(const FixedString& a, const FixedString& b) {
    return a.view() == b.view();
  }
};

// 1.2: binary data with a fixed capacity and an explicit length (wire: u16 length + N bytes, zero
// padded; docs/protocol.md "bytes<N>").
template <std::size_t N>
struct FixedBytes {
  static_assert(N <= 0xFFFF);
  std::array<std::uint8_t, N> bytes{};
  std::uint16_t length = 0;

  // Copies the first min(size, N) bytes of `data`; returns how many.
  std::size_t assign(const std::uint8_t* data, std::size_t size) noexcept {
    bytes.fill(0);
    length = static_cast<std::uint16_t>(std::min(size, N));
    std::copy(data, data + length, bytes.begin());
    return length;
  }
  const std::uint8_t* data() const noexcept { return bytes.data(); }
  std::size_t size() const noexcept { return length; }
  friend bool operator==(const FixedBytes& a, const FixedBytes& b) {
    return a.length == b.length &&
           std::equal(a.bytes.begin(), a.bytes.begin() + a.length, b.bytes.begin());
  }
};

// The words of a wire enum (ajar::Word rows, core/words.hpp), in value order (the values are
// 0..words.size()-1); `last` is its last enumerator, so that an enumerator added without its word
// fails to compile (to_string below).
template <typename E>
struct EnumWords;

enum class MessageType : std::uint16_t {
  // host -> daemon
  kHello = 0x0101,
  kPing = 0x0102,
  kMeasureDoorWidth = 0x0110,
  kMeasureHandle = 0x0111,
  kMeasureDoorPlane = 0x0112,
  kSetContactPoint = 0x0113,
  kAlignBase = 0x0120,
  kEngage = 0x0121,
  kStop = 0x0130,
  kEmergencyStop = 0x0131,
  kReset = 0x0132,
  kGetStatus = 0x0140,
  kSubscribe = 0x0141,
  // host -> daemon, protocol 1.1
  kDrive = 0x0122,
  kApproach = 0x0123,
  kGetRobotModel = 0x0142,
  kResetLoopStatistics = 0x0143,
  // host -> daemon, protocol 1.2 (the black box: docs/blackbox.md)
  kListRecordings = 0x0150,
  kFetchRecording = 0x0151,
  kSaveRecording = 0x0152,
  // daemon -> host
  kWelcome = 0x0201,
  kPong = 0x0202,
  kAck = 0x0203,
  kError = 0x0204,
  kEvent = 0x0205,
  kStatus = 0x0206,
  kTelemetry = 0x0207,
  // daemon -> host, protocol 1.1
  kRobotModel = 0x0208,
  // daemon -> host, protocol 1.2
  kRecordingList = 0x0209,
  kRecordingChunk = 0x020A,
};

enum class Role : std::uint8_t { kController = 0, kObserver = 1 };
template <>
struct EnumWords<Role> {
  static constexpr std::array<Word<Role>, 2> words{
      {{Role::kController, "controller"}, {Role::kObserver, "observer"}}};
  static constexpr auto last = Role::kObserver;
};

// The procedure (paper Fig. 4) as the daemon enforces it.
enum class ProcedureState : std::uint8_t {
  kAwaitingWidth = 0,   // nothing measured yet
  kAwaitingHandle = 1,  // width stored
  kAwaitingPlane = 2,   // width and handle stored
  kReadyToAlign = 3,    // plane stored, base not aligned
  kAligning = 4,        // wheels turning
  kAligned = 5,         // base squared up; awaiting the contact point
  kReadyToEngage = 6,   // contact point stored
  kEngaging = 7,        // task handed to the arm, arm working
  kEngaged = 8,         // arm accepted/finished the hand-off
  kFault = 9,           // a fault is latched: only Stop, EmergencyStop, Reset, GetStatus, ...
};
template <>
struct EnumWords<ProcedureState> {
  static constexpr std::array<Word<ProcedureState>, 10> words{
      {{ProcedureState::kAwaitingWidth, "awaiting_width"},
       {ProcedureState::kAwaitingHandle, "awaiting_handle"},
       {ProcedureState::kAwaitingPlane, "awaiting_plane"},
       {ProcedureState::kReadyToAlign, "ready_to_align"},
       {ProcedureState::kAligning, "aligning"},
       {ProcedureState::kAligned, "aligned"},
       {ProcedureState::kReadyToEngage, "ready_to_engage"},
       {ProcedureState::kEngaging, "engaging"},
       {ProcedureState::kEngaged, "engaged"},
       {ProcedureState::kFault, "fault"}}};
  static constexpr auto last = ProcedureState::kFault;
};

enum class EventKind : std::uint8_t {
  kStateChanged = 0,
  kMotionStarted = 1,
  kMotionFinished = 2,
  kMotionStopped = 3,
  kFaultLatched = 4,
  kFaultCleared = 5,
  kControlChanged = 6,  // the controller session changed (take-over, disconnect)
};
template <>
struct EnumWords<EventKind> {
  static constexpr std::array<Word<EventKind>, 7> words{
      {{EventKind::kStateChanged, "state_changed"},
       {EventKind::kMotionStarted, "motion_started"},
       {EventKind::kMotionFinished, "motion_finished"},
       {EventKind::kMotionStopped, "motion_stopped"},
       {EventKind::kFaultLatched, "fault_latched"},
       {EventKind::kFaultCleared, "fault_cleared"},
       {EventKind::kControlChanged, "control_changed"}}};
  static constexpr auto last = EventKind::kControlChanged;
};

enum class ArmState : std::uint8_t {
  kDisconnected = 0,
  kIdle = 1,
  kBusy = 2,  // executing a door task
  kDone = 3,
  kFault = 4,
};
template <>
struct EnumWords<ArmState> {
  static constexpr std::array<Word<ArmState>, 5> words{{{ArmState::kDisconnected, "disconnected"},
                                                        {ArmState::kIdle, "idle"},
                                                        {ArmState::kBusy, "busy"},
                                                        {ArmState::kDone, "done"},
                                                        {ArmState::kFault, "fault"}}};
  static constexpr auto last = ArmState::kFault;
};

// Lifecycle of a driver as reported on the wire (mirrors drivers::LifecycleState).
enum class DriverState : std::uint8_t {
  kUnconfigured = 0,
  kInactive = 1,
  kActive = 2,
  kFault = 3,
};
template <>
struct EnumWords<DriverState> {
  static constexpr std::array<Word<DriverState>, 4> words{
      {{DriverState::kUnconfigured, "unconfigured"},
       {DriverState::kInactive, "inactive"},
       {DriverState::kActive, "active"},
       {DriverState::kFault, "fault"}}};
  static constexpr auto last = DriverState::kFault;
};

// Which drivers the daemon runs (Welcome, 1.1; mirrors drivers::DriverKind).
enum class DriverKind : std::uint8_t { kSim = 0, kMock = 1, kReal = 2 };
template <>
struct EnumWords<DriverKind> {
  static constexpr std::array<Word<DriverKind>, 3> words{
      {{DriverKind::kSim, "sim"}, {DriverKind::kMock, "mock"}, {DriverKind::kReal, "real"}}};
  static constexpr auto last = DriverKind::kReal;
};

// What moves the base now (Status, Telemetry, Event; 1.2): the procedure state says the step, this
// says the motion — a jog or an Approach leave the state at the step they were accepted in.
enum class BaseMotion : std::uint8_t {
  kNone = 0,         // no motion owns the wheels
  kAligning = 1,     // AlignBase turns the base
  kApproaching = 2,  // an Approach drives it
  kJogging = 3,      // a jog (Drive) is open: from its motion_started to its motion_finished
  kStopping = 4,     // a stop, fault or lost controller ended a motion; the wheels are not at rest
};
template <>
struct EnumWords<BaseMotion> {
  static constexpr std::array<Word<BaseMotion>, 5> words{{{BaseMotion::kNone, "none"},
                                                          {BaseMotion::kAligning, "aligning"},
                                                          {BaseMotion::kApproaching, "approaching"},
                                                          {BaseMotion::kJogging, "jogging"},
                                                          {BaseMotion::kStopping, "stopping"}}};
  static constexpr auto last = BaseMotion::kStopping;
};

// What the black box does now (Status.recorder, 1.2; docs/blackbox.md).
enum class RecorderMode : std::uint8_t {
  kOff = 0,          // recorder.enabled is false
  kRecording = 1,    // a file is open and written
  kDiskFull = 2,     // the disk refused a write for lack of space: paused, retried every 5 s
  kDiskError = 3,    // the disk refused a write or a new file otherwise: paused, retried every 5 s
  kNoDirectory = 4,  // its directory could not be made or written at start: off until a restart
};
template <>
struct EnumWords<RecorderMode> {
  static constexpr std::array<Word<RecorderMode>, 5> words{
      {{RecorderMode::kOff, "off"},
       {RecorderMode::kRecording, "recording"},
       {RecorderMode::kDiskFull, "disk_full"},
       {RecorderMode::kDiskError, "disk_error"},
       {RecorderMode::kNoDirectory, "no_directory"}}};
  static constexpr auto last = RecorderMode::kNoDirectory;
};

// The control thread's scheduling policy (Status.realtime, 1.1).
enum class SchedulingPolicy : std::uint8_t { kOther = 0, kFifo = 1, kRoundRobin = 2 };
template <>
struct EnumWords<SchedulingPolicy> {
  static constexpr std::array<Word<SchedulingPolicy>, 3> words{
      {{SchedulingPolicy::kOther, "other"},
       {SchedulingPolicy::kFifo, "fifo"},
       {SchedulingPolicy::kRoundRobin, "rr"}}};
  static constexpr auto last = SchedulingPolicy::kRoundRobin;
};

using core::FramedPoint;

// ---- host -> daemon -----------------------------------------------------------------------------

struct Hello {
  std::uint8_t version_major = kVersionMajor;
  std::uint8_t version_minor = kVersionMinor;
  Role requested_role = Role::kObserver;
  bool take_over = false;  // controller only: take control from the current controller
  std::uint64_t client_instance_id = 0;  // survives reconnects; keys duplicate detection
  FixedString<32> client_name;
};
struct Ping {
  std::uint64_t client_time_ns = 0;
};
struct MeasureDoorWidth {
  FramedPoint p1_hinge;
  FramedPoint p2_moving_edge;
};
struct MeasureHandle {
  FramedPoint p1_axis;
  FramedPoint p2_free_end;
};
struct MeasureDoorPlane {
  std::uint8_t count = 0;  // 3..16 on the wire
  std::array<FramedPoint, kMaxPlanePoints> points{};
};
struct SetContactPoint {
  FramedPoint contact;
};
struct AlignBase {};
struct Engage {};
struct Stop {};
struct EmergencyStop {};
// Clears a latched fault (drivers are recovered). With clear_parameters it also aborts the
// procedure: every stored measurement is discarded and the state returns to kAwaitingWidth.
struct Reset {
  bool clear_parameters = false;
};
struct GetStatus {};
struct Subscribe {
  float telemetry_rate_hz = 0;
};  // 0 = off; capped at the loop rate

// 1.1: jog the base. Body velocity (+x forward, CCW positive), valid for the robot model's
// drive_command_timeout_s; a client holding the key re-sends it. Zero velocity is a smooth stop.
struct Drive {
  double linear_m_s = 0;
  double angular_rad_s = 0;
};
// 1.1: drive straight until the base origin is `standoff_m` from the door plane.
struct Approach {
  double standoff_m = 0;
};
struct GetRobotModel {};        // 1.1: reply is RobotModel
struct ResetLoopStatistics {};  // 1.1: restart the loop statistics (LoopStatistics, LoopTiming)

// 1.2: the recordings on the daemon, newest first, from index `first` (reply: RecordingList).
struct ListRecordings {
  std::uint32_t first = 0;
};
// 1.2: up to `max_length` bytes (1..kMaxRecordingChunk) of recording `name` from byte `offset`
// (reply: RecordingChunk). offset == the file's size is the end: a chunk with no data.
struct FetchRecording {
  FixedString<48> name;
  std::uint64_t offset = 0;
  std::uint16_t max_length = kMaxRecordingChunk;
};
// 1.2: keep the recordings that overlap the last `last_s` seconds where rotation never removes
// them (reply: RecordingList of the recordings saved).
struct SaveRecording {
  float last_s = 0;
};

// ---- daemon -> host -----------------------------------------------------------------------------

struct Welcome {
  std::uint8_t version_major = kVersionMajor;
  std::uint8_t version_minor = kVersionMinor;
  Role granted_role = Role::kObserver;
  std::uint64_t session_id = 0;
  FixedString<32> daemon_version;
  float loop_rate_hz = 0;
  float deadman_timeout_s = 0;
  float min_door_width_m = 0, max_door_width_m = 0;
  float min_handle_length_m = 0, max_handle_length_m = 0;
  float max_yaw_correction_rad = 0;
  // 1.1
  DriverKind driver_kind = DriverKind::kSim;
};
struct Pong {
  std::uint64_t client_time_ns = 0;
  std::uint64_t daemon_time_ns = 0;
};

// What an Ack carries depends on what it acknowledges.
struct SpanAck {  // MeasureDoorWidth, MeasureHandle
  double length_m = 0;
  core::RotationDirection direction = core::RotationDirection::kClockwise;
  core::Vec3 p1_base_m = core::Vec3::Zero();
  core::Vec3 p2_base_m = core::Vec3::Zero();
};
struct PlaneAck {                          // MeasureDoorPlane
  core::Vec3 normal = core::Vec3::Zero();  // unit, toward the robot, base frame (zero: absent)
  double yaw_deviation_rad = 0;            // CCW positive
  double left_wheel_rad = 0, right_wheel_rad = 0;
  std::int64_t left_counts = 0, right_counts = 0;
  double residual_yaw_rad = 0;  // left undone by rounding to counts
  double rms_residual_m = 0;
  std::uint8_t point_count = 0;
};
struct ContactAck {  // SetContactPoint
  core::Vec3 contact_base_m = core::Vec3::Zero();
  double reach_margin_m = 0;
};
// 1.1, Approach: the straight move the daemon accepted (motion accepted; completion is an Event).
struct ApproachAck {
  double travel_m = 0;           // signed, + forward: start distance - standoff
  double start_distance_m = 0;   // base origin to the door plane when the move was planned
  std::int64_t left_counts = 0;  // wheel command in card counts (polarity applied), as PlaneAck
  std::int64_t right_counts = 0;
};
struct EmptyAck {};  // everything else (AlignBase: motion accepted; Stop; Reset; Subscribe; Drive)
using AckBody = std::variant<EmptyAck, SpanAck, PlaneAck, ContactAck, ApproachAck>;

struct Ack {
  MessageType acknowledged = MessageType::kPing;          // body layout follows from this
  ProcedureState state = ProcedureState::kAwaitingWidth;  // state after the command
  AckBody body;
};

struct ErrorReply {
  ErrorCode code = ErrorCode::kInternal;
  MessageType offending_type = MessageType::kPing;  // type of the refused request (raw if unknown)
  FixedString<32> field;
  FixedString<200> message;
};

struct Event {
  EventKind kind = EventKind::kStateChanged;
  ProcedureState state = ProcedureState::kAwaitingWidth;
  ErrorCode fault = ErrorCode::kOk;  // for kFaultLatched; kOk otherwise
  std::uint64_t daemon_time_ns = 0;
  FixedString<120> detail;
  BaseMotion base_motion = BaseMotion::kNone;  // 1.2: what moves the base after the event
};

struct LoopStatistics {
  float rate_hz = 0;
  std::uint64_t cycles = 0;
  std::uint64_t overruns = 0;
  std::uint32_t period_p50_ns = 0, period_p99_ns = 0, period_max_ns = 0;
  std::uint32_t jitter_p99_ns = 0;  // |period - nominal|, p99
};

// 1.1: percentiles of one loop quantity, in ns, saturating at 2^32 - 1.
struct Quantiles {
  std::uint32_t p50_ns = 0, p99_ns = 0, p999_ns = 0, max_ns = 0;
};
// 1.1: the loop's timing over one span of cycles.
struct TimingWindow {
  std::uint64_t samples = 0;  // cycles measured
  Quantiles latency;          // wake-up latency: actual wake-up - deadline
  Quantiles execution;        // cycle execution time: wake-up to the end of the cycle's work
  Quantiles period;           // wake-up to wake-up
};
// 1.1: loop timing since start (or since ResetLoopStatistics) and over the recent window.
struct LoopTiming {
  float window_s = 0;  // length of the recent window
  TimingWindow all;
  TimingWindow recent;
};

// 1.1: where the door is, seen from the base now (updated as the base moves).
struct DoorRelation {
  bool has_distance = false;
  double distance_m = 0;  // base origin to the door plane (perpendicular); see docs/protocol.md
  bool has_yaw = false;   // from the plane, or before one the width points' line
  double yaw_rad = 0;     // yaw still to correct to face the door squarely, CCW positive
};
// 1.1: stored base-frame measurements after the base moved.
struct Staleness {
  bool plane = false;    // the door plane no longer describes the door: measure it again
  bool contact = false;  // the contact point no longer describes the handle: set it again
  double travel_since_plane_m = 0;  // base origin displacement since the plane was measured
};
// 1.1: what the control thread got at start (Status only).
struct RealtimeState {
  SchedulingPolicy policy = SchedulingPolicy::kOther;
  std::uint8_t priority = 0;   // SCHED_FIFO/RR priority; 0 for kOther
  bool memory_locked = false;  // mlockall succeeded
};

// 1.2: the black box (Status only): the recorder's counters since the daemon started. Loop samples
// and I/O records either reach a file (records_written), are dropped at a full ring/queue
// (loop_dropped, io_dropped: the recorder thread fell behind) or are lost to the disk
// (records_lost: a refused write, or taken while no file was open).
struct RecorderState {
  bool enabled = false;  // recorder.enabled
  RecorderMode mode = RecorderMode::kOff;
  FixedString<48> file;               // the file being written ("" when none)
  std::uint64_t file_bytes = 0;       // its bytes on disk
  std::uint64_t directory_bytes = 0;  // every recording but the saved ones (the budget's count)
  std::uint64_t max_bytes = 0;        // the budget, recorder.max_bytes
  std::uint64_t saved_bytes = 0;      // the saved recordings (outside the budget)
  std::uint64_t disk_free_bytes = 0;  // free on its file system, for the daemon's user
  std::uint64_t records_written = 0;  // messages in the files
  std::uint64_t loop_samples = 0;     // loop samples taken (every loop_decimation-th cycle)
  std::uint64_t loop_dropped = 0;     // ... dropped: the lock-free ring was full
  std::uint64_t io_records = 0;       // frames, events, sessions, config, telemetry queued
  std::uint64_t io_dropped = 0;       // ... dropped: the queue was full
  std::uint64_t records_lost = 0;     // lost to a refused write or while no file was open
  std::uint32_t disk_refusals = 0;    // times the disk refused (each logged once)
  std::uint64_t last_write_ns = 0;    // daemon clock of the last write to a file; 0: none yet
};

struct Status {
  ProcedureState state = ProcedureState::kAwaitingWidth;
  ErrorCode latched_fault = ErrorCode::kOk;
  bool restored_from_disk = false;  // parameters came back from the state file at start
  bool controller_connected = false;
  std::uint16_t session_count = 0;
  // Stored parameters; each `has_` says whether the value below is meaningful.
  bool has_width = false;
  SpanAck width;
  bool has_handle = false;
  SpanAck handle;
  bool has_plane = false;
  PlaneAck plane;
  bool has_contact = false;
  ContactAck contact;
  double base_yaw_odometry_rad = 0;  // CCW positive, since daemon start
  DriverState card = DriverState::kUnconfigured;
  DriverState arm = DriverState::kUnconfigured;
  ArmState arm_state = ArmState::kDisconnected;
  LoopStatistics loop;
  // 1.1 (a 1.0 layout ends above; decoded from a 1.0 frame these stay at their defaults)
  double odometry_x_m = 0;  // with base_yaw_odometry_rad: the base pose in the odometry frame
  double odometry_y_m = 0;
  DoorRelation door;
  Staleness staleness;
  double commanded_linear_m_s = 0;  // body velocity the loop commands now (after limits)
  double commanded_angular_rad_s = 0;
  LoopTiming timing;
  RealtimeState realtime;
  BaseMotion base_motion = BaseMotion::kNone;  // 1.2
  RecorderState recorder;                      // 1.2
};

struct Telemetry {
  std::uint64_t daemon_time_ns = 0;  // monotonic, since daemon start
  ProcedureState state = ProcedureState::kAwaitingWidth;
  bool moving = false;
  double left_wheel_rad = 0, right_wheel_rad = 0;  // from encoders, wheel-forward positive
  std::int64_t left_counts = 0, right_counts = 0;  // encoder counts as read from the card
  double base_yaw_odometry_rad = 0;                // CCW positive, since daemon start
  ArmState arm_state = ArmState::kDisconnected;
  LoopStatistics loop;
  // 1.1, as in Status
  double odometry_x_m = 0;
  double odometry_y_m = 0;
  DoorRelation door;
  Staleness staleness;
  double commanded_linear_m_s = 0;
  double commanded_angular_rad_s = 0;
  LoopTiming timing;
  BaseMotion base_motion = BaseMotion::kNone;  // 1.2
};

// 1.1: one driving wheel.
struct WheelModel {
  std::uint8_t card_axis = 0;  // GTS axis number, from 1
  std::int8_t polarity = 1;    // +1 or -1: the sign that makes positive counts roll forward
};

// 1.1: the robot's calibration and every limit the daemon validates against (reply to
// GetRobotModel): enough to reproduce every derived value of an Ack and to draw base-frame
// coordinates. A value the daemon does not use yet is 0 (docs/protocol.md says which).
struct RobotModel {
  std::array<double, 12> camera_to_base{};  // ^B_C T, rows of [R | t] (3x4), t in metres
  double wheel_radius_m = 0;                // R_W
  double turning_radius_m = 0;              // R_B
  double encoder_counts_per_rev = 0;        // motor encoder counts per motor revolution
  double gear_ratio = 0;                    // motor revolutions per wheel revolution
  WheelModel left, right;
  double max_wheel_speed_rad_s = 0, max_wheel_accel_rad_s2 = 0;
  // Drive (jog)
  double max_linear_speed_m_s = 0, max_angular_speed_rad_s = 0;
  double max_linear_accel_m_s2 = 0, max_angular_accel_rad_s2 = 0;
  double drive_command_timeout_s = 0;
  // Approach
  double approach_max_travel_m = 0;          // longest accepted approach move
  double approach_square_tolerance_rad = 0;  // |yaw to the door| above this: NOT_SQUARE_TO_DOOR
  double approach_min_standoff_m = 0;        // smallest accepted standoff
  // Staleness: base motion after which the stored plane (and contact point) is stale
  double stale_travel_m = 0, stale_yaw_rad = 0;
  // Arm workspace (base frame): spherical shell around the shoulder, clipped by a height band
  core::Vec3 arm_shoulder_m = core::Vec3::Zero();
  double arm_min_reach_m = 0, arm_max_reach_m = 0, arm_min_z_m = 0, arm_max_z_m = 0;
  // Validation limits
  double min_depth_m = 0, max_depth_m = 0;  // camera z
  double min_door_width_m = 0, max_door_width_m = 0;
  double min_handle_length_m = 0, max_handle_length_m = 0;
  double max_yaw_correction_rad = 0;
  double aligned_tolerance_rad = 0;
  double min_point_separation_m = 0, min_lateral_fraction = 0, collinearity = 0;
  double max_plane_rms_m = 0, max_door_tilt_rad = 0;
};

// 1.2: one recording file (the entries of RecordingList).
struct RecordingInfo {
  FixedString<48> name;             // as the daemon names it ("saved/..." for a saved one)
  std::uint64_t size_bytes = 0;     // its size when listed
  std::uint64_t start_unix_ns = 0;  // when its recording started, wall clock (ns since 1970 UTC)
  std::uint64_t end_unix_ns = 0;    // when it was last written, wall clock
  bool writing = false;             // the recorder is still appending to it
  bool saved = false;               // kept by SaveRecording: rotation never removes it
};
// 1.2: reply to ListRecordings (and to SaveRecording: the recordings it saved): entries [first,
// first + count) of the `total` recordings, newest first; entries past `count` are empty.
struct RecordingList {
  std::uint32_t total = 0;
  std::uint32_t first = 0;
  std::uint8_t count = 0;  // 0..kRecordingListEntries
  std::array<RecordingInfo, kRecordingListEntries> entries{};
};
// 1.2: reply to FetchRecording: the bytes of the file from `offset` (as many as asked, fewer at the
// end of the file); `size_bytes` is the file's size when they were read.
struct RecordingChunk {
  std::uint64_t offset = 0;
  std::uint64_t size_bytes = 0;
  FixedBytes<kMaxRecordingChunk> data;
};

using Message =
    std::variant<Hello, Ping, MeasureDoorWidth, MeasureHandle, MeasureDoorPlane, SetContactPoint,
                 AlignBase, Engage, Stop, EmergencyStop, Reset, GetStatus, Subscribe, Welcome, Pong,
                 Ack, ErrorReply, Event, Status, Telemetry, Drive, Approach, GetRobotModel,
                 ResetLoopStatistics, RobotModel, ListRecordings, FetchRecording, SaveRecording,
                 RecordingList, RecordingChunk>;

// The message type of a value, and whether it travels host -> daemon.
MessageType type_of(const Message& m) noexcept;
bool is_request(MessageType t) noexcept;
// The minor version that defined `t` (0 for the 1.0 types, 1 for the 1.1 ones, 2 for the 1.2
// ones); 255 when unknown.
std::uint8_t minor_of(MessageType t) noexcept;
std::string_view to_string(MessageType t) noexcept;  // "MeasureDoorWidth", ...; "Unknown"
// The word of a wire enum value ("awaiting_width", "controller", "sim", "rr", ...); "unknown" for a
// value the enum does not have.
template <typename E>
requires requires {
  EnumWords<E>::words;
}
constexpr std::string_view to_string(E value) noexcept {
  static_assert(EnumWords<E>::words.size() == static_cast<std::size_t>(EnumWords<E>::last) + 1 &&
                    values_are_indices(EnumWords<E>::words),
                "every enumerator has its word, in value order");
  return ajar::word_of(EnumWords<E>::words, value);
}

}  // namespace ajar::protocol
