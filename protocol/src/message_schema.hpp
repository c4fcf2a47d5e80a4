// The message table: one Schema per message (row: type, name, direction, the minor version that
// defined it; fields with their names and the minor that appended them) and per shared structure,
// and the words of every enum. Encoding, decoding, the names in decode errors, type <-> name,
// is_request(), minor_of(), the layout listing (and through it the golden vector generator and the
// test of docs/protocol.md's layout tables) all read these tables; nothing else lists a field.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <utility>
#include <variant>

#include "schema.hpp"

namespace ajar::protocol::detail {

using enum Direction;

// ---- enums ----------------------------------------------------------------------------------
// The protocol's enums have their words next to them (EnumWords, messages.hpp); core's enums are
// printed by core::to_string, here only their last enumerator matters (the value count).

template <>
struct EnumLast<core::Frame> {
  static constexpr auto last = core::Frame::kBase;
};
template <>
struct EnumLast<core::RotationDirection> {
  static constexpr auto last = core::RotationDirection::kCounterClockwise;
};

// ---- shared structures (docs/protocol.md section 5.0) ---------------------------------------
// Vec3 (x, y, z) and Point (frame, x, y, z) are written by walk.hpp directly.

template <>
struct Schema<SpanAck> {  // SpanBody
  using fields =
      Fields<Field<"length_m", &SpanAck::length_m>, Field<"direction", &SpanAck::direction>,
             Field<"p1_base_m", &SpanAck::p1_base_m>, Field<"p2_base_m", &SpanAck::p2_base_m>>;
};
template <>
struct Schema<PlaneAck> {  // PlaneBody
  using fields = Fields<
      Field<"normal", &PlaneAck::normal>, Field<"yaw_deviation_rad", &PlaneAck::yaw_deviation_rad>,
      Field<"left_wheel_rad", &PlaneAck::left_wheel_rad>,
      Field<"right_wheel_rad", &PlaneAck::right_wheel_rad>,
      Field<"left_counts", &PlaneAck::left_counts>, Field<"right_counts", &PlaneAck::right_counts>,
      Field<"residual_yaw_rad", &PlaneAck::residual_yaw_rad>,
      Field<"rms_residual_m", &PlaneAck::rms_residual_m>,
      Field<"point_count", &PlaneAck::point_count>>;
};
template <>
struct Schema<ContactAck> {  // ContactBody
  using fields = Fields<Field<"contact_base_m", &ContactAck::contact_base_m>,
                        Field<"reach_margin_m", &ContactAck::reach_margin_m>>;
};
template <>
struct Schema<ApproachAck> {  // ApproachBody (1.1)
  using fields = Fields<Field<"travel_m", &ApproachAck::travel_m>,
                        Field<"start_distance_m", &ApproachAck::start_distance_m>,
                        Field<"left_counts", &ApproachAck::left_counts>,
                        Field<"right_counts", &ApproachAck::right_counts>>;
};
template <>
struct Schema<RecordingInfo> {  // RecordingBody (1.2)
  using fields =
      Fields<Field<"name", &RecordingInfo::name>, Field<"size_bytes", &RecordingInfo::size_bytes>,
             Field<"start_unix_ns", &RecordingInfo::start_unix_ns>,
             Field<"end_unix_ns", &RecordingInfo::end_unix_ns>,
             Field<"writing", &RecordingInfo::writing>, Field<"saved", &RecordingInfo::saved>>;
};
template <>
struct Schema<EmptyAck> {
  using fields = Fields<>;
};
template <>
struct Schema<LoopStatistics> {
  using fields =
      Fields<Field<"rate_hz", &LoopStatistics::rate_hz>, Field<"cycles", &LoopStatistics::cycles>,
             Field<"overruns", &LoopStatistics::overruns>,
             Field<"period_p50_ns", &LoopStatistics::period_p50_ns>,
             Field<"period_p99_ns", &LoopStatistics::period_p99_ns>,
             Field<"period_max_ns", &LoopStatistics::period_max_ns>,
             Field<"jitter_p99_ns", &LoopStatistics::jitter_p99_ns>>;
};
template <>
struct Schema<Quantiles> {
  using fields = Fields<Field<"p50_ns", &Quantiles::p50_ns>, Field<"p99_ns", &Quantiles::p99_ns>,
                        Field<"p999_ns", &Quantiles::p999_ns>, Field<"max_ns", &Quantiles::max_ns>>;
};
template <>
struct Schema<TimingWindow> {
  using fields =
      Fields<Field<"samples", &TimingWindow::samples>, Field<"latency", &TimingWindow::latency>,
             Field<"execution", &TimingWindow::execution>, Field<"period", &TimingWindow::period>>;
};
template <>
struct Schema<LoopTiming> {
  using fields = Fields<Field<"window_s", &LoopTiming::window_s>, Field<"all", &LoopTiming::all>,
                        Field<"recent", &LoopTiming::recent>>;
};
template <>
struct Schema<DoorRelation> {
  using fields =
      Fields<Field<"has_distance", &DoorRelation::has_distance>,
             Field<"distance_m", &DoorRelation::distance_m>,
             Field<"has_yaw", &DoorRelation::has_yaw>, Field<"yaw_rad", &DoorRelation::yaw_rad>>;
};
template <>
struct Schema<Staleness> {
  using fields = Fields<Field<"plane", &Staleness::plane>, Field<"contact", &Staleness::contact>,
                        Field<"travel_since_plane_m", &Staleness::travel_since_plane_m>>;
};
template <>
struct Schema<RealtimeState> {
  using fields =
      Fields<Field<"policy", &RealtimeState::policy>, Field<"priority", &RealtimeState::priority>,
             Field<"memory_locked", &RealtimeState::memory_locked>>;
};
template <>
struct Schema<RecorderState> {
  using R = RecorderState;
  using fields =
      Fields<Field<"enabled", &R::enabled>, Field<"mode", &R::mode>, Field<"file", &R::file>,
             Field<"file_bytes", &R::file_bytes>, Field<"directory_bytes", &R::directory_bytes>,
             Field<"max_bytes", &R::max_bytes>, Field<"saved_bytes", &R::saved_bytes>,
             Field<"disk_free_bytes", &R::disk_free_bytes>,
             Field<"records_written", &R::records_written>, Field<"loop_samples", &R::loop_samples>,
             Field<"loop_dropped", &R::loop_dropped>, Field<"io_records", &R::io_records>,
             Field<"io_dropped", &R::io_dropped>, Field<"records_lost", &R::records_lost>,
             Field<"disk_refusals", &R::disk_refusals>, Field<"last_write_ns", &R::last_write_ns>>;
};
template <>
struct Schema<WheelModel> {
  using fields = Fields<Field<"card_axis", &WheelModel::card_axis>,
                        Field<"polarity", &WheelModel::polarity, 0, Polarity>>;
};

// The MotionBlock 1.1 appended to Status and Telemetry (the same fields in both).
template <typename T>
using MotionBlock =
    Fields<Field<"odometry_x_m", &T::odometry_x_m, 1>, Field<"odometry_y_m", &T::odometry_y_m, 1>,
           Field<"door", &T::door, 1>, Field<"staleness", &T::staleness, 1>,
           Field<"commanded_linear_m_s", &T::commanded_linear_m_s, 1>,
           Field<"commanded_angular_rad_s", &T::commanded_angular_rad_s, 1>,
           Field<"timing", &T::timing, 1>>;

// ---- host -> daemon -------------------------------------------------------------------------
// The policies (message_table.hpp) the commands share: every controller command is deduplicated
// and its Ack durable; measurements and the motions from rest wait for the wheels to be at rest.

inline constexpr MessagePolicy kCommand{
    .sender = Sender::kController, .deduplicated = true, .durable_ack = true};
inline constexpr MessagePolicy kMeasurement{.sender = Sender::kController,
                                            .deduplicated = true,
                                            .durable_ack = true,
                                            .needs_wheels_at_rest = true};
inline constexpr MessagePolicy kMotionFromRest{.sender = Sender::kController,
                                               .deduplicated = true,
                                               .durable_ack = true,
                                               .starts_motion = true,
                                               .needs_wheels_at_rest = true};
inline constexpr MessagePolicy kDriving{.sender = Sender::kController,
                                        .deduplicated = true,
                                        .durable_ack = true,
                                        .starts_motion = true};

// The refusals (message_table.hpp), built from the groups the requests share; a row's order is no
// priority (docs/protocol.md 5.x and 6 give the orders). A field is a wire field of the request or
// something the daemon holds (refusal_field, core::fields); the empty field is an Error about no
// one field.

template <std::size_t... N>
constexpr auto join(const std::array<Refusal, N>&... parts) {
  std::array<Refusal, (N + ... + 0)> out{};
  std::size_t i = 0;
  ((std::ranges::copy(parts, out.begin() + static_cast<std::ptrdiff_t>(i)), i += N), ...);
  return out;
}
template <typename... R>
constexpr auto list(R... r) {
  return std::array<Refusal, sizeof...(R)>{r...};
}

namespace rf = refusal_field;
namespace cf = core::fields;
using E = ErrorCode;

// Session rules (6.1, 7.1): every request but a stop, before anything else looks at it.
inline constexpr auto kSession =
    list(Refusal{E::kShuttingDown, rf::kNone}, Refusal{E::kTooManyClients, rf::kNone},
         Refusal{E::kHelloRequired, rf::kNone});
inline constexpr auto kNewer = list(Refusal{E::kUnknownMessageType, rf::kHeaderType});  // 1.1+
inline constexpr auto kControllerSession =
    join(kSession, list(Refusal{E::kNotController, rf::kNone}));
// The procedure's first checks of a measurement or a motion from rest (wheels at rest, 4.2).
inline constexpr auto kMoving =
    list(Refusal{E::kMotionInProgress, rf::kNone}, Refusal{E::kFaultLatched, rf::kNone});
inline constexpr auto kNeedWidth = list(Refusal{E::kMissingDoorWidth, rf::kNone});
inline constexpr auto kNeedHandle = list(Refusal{E::kMissingHandle, rf::kNone});
inline constexpr auto kNeedPlane = list(Refusal{E::kMissingPlane, rf::kNone});
inline constexpr auto kNeedAligned = list(Refusal{E::kNotAligned, rf::kNone});
inline constexpr auto kStalePlane = list(Refusal{E::kMeasurementStale, rf::kPlane});
// A picked point, taken to the base frame (core::point_in_base).
constexpr auto point_refusals(std::string_view point, bool indexed = false) {
  return list(Refusal{E::kNonFinite, point, indexed, true},
              Refusal{E::kPointOutOfDepthRange, point, indexed});
}
inline constexpr auto kQueueFull = list(Refusal{E::kQueueFull, rf::kNone});
// Drive and Approach: may the base move (5.18, 5.19, their items 1-5).
inline constexpr auto kBaseMayDrive =
    list(Refusal{E::kFaultLatched, rf::kNone}, Refusal{E::kMotionInProgress, rf::kNone},
         Refusal{E::kDriveNotAllowed, rf::kNone}, Refusal{E::kDriveNotAllowed, rf::kArm});
// AlignBase and Approach are never refused QUEUE_FULL: their move is handed to the loop at the end
// of the read (Engine::end_read_batch), after the Ack; a move the loop cannot take then is closed
// by its events. The black box (5.23-5.25): off, too many outstanding, or its reader did not answer
// in time.
inline constexpr auto kBlackBox =
    list(Refusal{E::kNotSupported, rf::kNone}, Refusal{E::kQueueFull, rf::kNone},
         Refusal{E::kDriverError, rf::kNone});

template <>
struct Schema<Hello> : MessageRow<MessageType::kHello, "Hello", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy{.sender = Sender::kAny};
  static constexpr auto refusals = list(
      Refusal{E::kShuttingDown, rf::kNone}, Refusal{E::kTooManyClients, rf::kNone},
      Refusal{E::kAlreadyGreeted, rf::kNone}, Refusal{E::kUnsupportedVersion, rf::kVersionMajor},
      Refusal{E::kNotController, rf::kRequestedRole}, Refusal{E::kControllerBusy, rf::kTakeOver});
  using fields =
      Fields<Field<"version_major", &Hello::version_major>,
             Field<"version_minor", &Hello::version_minor>,
             Field<"requested_role", &Hello::requested_role>, Field<"take_over", &Hello::take_over>,
             Field<"client_instance_id", &Hello::client_instance_id>,
             Field<"client_name", &Hello::client_name>>;
};
template <>
struct Schema<Ping> : MessageRow<MessageType::kPing, "Ping", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy{.sender = Sender::kAny};
  static constexpr auto refusals = kSession;
  using fields = Fields<Field<"client_time_ns", &Ping::client_time_ns>>;
};
template <>
struct Schema<MeasureDoorWidth>
    : MessageRow<MessageType::kMeasureDoorWidth, "MeasureDoorWidth", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy = kMeasurement;
  static constexpr auto refusals = join(
      kControllerSession, kMoving, point_refusals(cf::kP1), point_refusals(cf::kP2),
      list(Refusal{E::kPointsTooClose, cf::kP2}, Refusal{E::kAmbiguousDirection, cf::kP2},
           Refusal{E::kPointsNotSideBySide, cf::kP2}, Refusal{E::kWidthOutOfRange, cf::kWidth}));
  using ack_body = SpanAck;
  using fields = Fields<Field<"p1", &MeasureDoorWidth::p1_hinge>,
                        Field<"p2", &MeasureDoorWidth::p2_moving_edge>>;
};
template <>
struct Schema<MeasureHandle>
    : MessageRow<MessageType::kMeasureHandle, "MeasureHandle", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy = kMeasurement;
  static constexpr auto refusals = join(
      kControllerSession, kMoving, kNeedWidth, point_refusals(cf::kP1), point_refusals(cf::kP2),
      list(Refusal{E::kPointsTooClose, cf::kP2}, Refusal{E::kAmbiguousDirection, cf::kP2},
           Refusal{E::kPointsNotSideBySide, cf::kP2},
           Refusal{E::kHandleLengthOutOfRange, cf::kHandleLength}));
  using ack_body = SpanAck;
  using fields =
      Fields<Field<"p1", &MeasureHandle::p1_axis>, Field<"p2", &MeasureHandle::p2_free_end>>;
};
template <>
struct Schema<MeasureDoorPlane>
    : MessageRow<MessageType::kMeasureDoorPlane, "MeasureDoorPlane", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy = kMeasurement;
  static constexpr auto refusals =
      join(kControllerSession, kMoving, kNeedWidth, kNeedHandle, point_refusals(cf::kPoints, true),
           list(Refusal{E::kPointsTooClose, cf::kPoints, true},
                Refusal{E::kPointsCollinear, cf::kPoints},
                Refusal{E::kPlaneResidualTooLarge, cf::kRmsResidual},
                Refusal{E::kPlaneNotVertical, cf::kPoints},
                Refusal{E::kYawOutOfRange, cf::kYawDeviation}));
  using ack_body = PlaneAck;
  using fields =
      Fields<Field<"count", &MeasureDoorPlane::count, 0, PlaneCount>,
             Field<"points", &MeasureDoorPlane::points, 0, CountedBy<&MeasureDoorPlane::count>>>;
};
template <>
struct Schema<SetContactPoint>
    : MessageRow<MessageType::kSetContactPoint, "SetContactPoint", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy = kMeasurement;
  static constexpr auto refusals =
      join(kControllerSession, kMoving, kStalePlane, kNeedWidth, kNeedHandle, kNeedPlane,
           kNeedAligned, point_refusals(cf::kContact), list(Refusal{E::kOutOfReach, cf::kContact}));
  using ack_body = ContactAck;
  using fields = Fields<Field<"contact", &SetContactPoint::contact>>;
};
template <>
struct Schema<AlignBase> : MessageRow<MessageType::kAlignBase, "AlignBase", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy = kMotionFromRest;
  static constexpr auto refusals =
      join(kControllerSession, kMoving, kStalePlane, kNeedWidth, kNeedHandle, kNeedPlane,
           list(Refusal{E::kWrongState, rf::kNone}, Refusal{E::kYawOutOfRange, cf::kYawDeviation},
                Refusal{E::kDriveNotAllowed, rf::kArm}));
  using fields = Fields<>;
};
template <>
struct Schema<Engage> : MessageRow<MessageType::kEngage, "Engage", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy = kMotionFromRest;
  // The arm's hand-off (drivers::Manipulator::hand_off) refuses as the driver says, naming `arm`.
  static constexpr auto refusals = join(
      kControllerSession, kMoving, kStalePlane, list(Refusal{E::kMeasurementStale, rf::kContact}),
      kNeedWidth, kNeedHandle, kNeedPlane, kNeedAligned,
      list(Refusal{E::kMissingContactPoint, rf::kNone}, Refusal{E::kWrongState, rf::kNone},
           Refusal{E::kArmDisconnected, rf::kArm}, Refusal{E::kWrongState, rf::kArm},
           Refusal{E::kDriverNotActive, rf::kArm}));
  using fields = Fields<>;
};
template <>
struct Schema<Stop> : MessageRow<MessageType::kStop, "Stop", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy{.sender = Sender::kStop};
  // Only for a TLS identity that may not stop (on a refused connection: TOO_MANY_CLIENTS).
  static constexpr auto refusals =
      list(Refusal{E::kNotController, rf::kNone}, Refusal{E::kTooManyClients, rf::kNone});
  using fields = Fields<>;
};
template <>
struct Schema<EmergencyStop>
    : MessageRow<MessageType::kEmergencyStop, "EmergencyStop", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy{.sender = Sender::kStop};
  static constexpr auto refusals = Schema<Stop>::refusals;
  using fields = Fields<>;
};
template <>
struct Schema<Reset> : MessageRow<MessageType::kReset, "Reset", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy = kCommand;
  static constexpr auto refusals =
      join(kControllerSession,
           list(Refusal{E::kLoopStalled, rf::kNone}, Refusal{E::kMotionInProgress, rf::kNone},
                Refusal{E::kArmDisconnected, rf::kArm}, Refusal{E::kArmNotClear, rf::kArm}),
           kQueueFull);
  using fields = Fields<Field<"clear_parameters", &Reset::clear_parameters>>;
};
template <>
struct Schema<GetStatus> : MessageRow<MessageType::kGetStatus, "GetStatus", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy{.sender = Sender::kAny};
  static constexpr auto refusals = kSession;
  using fields = Fields<>;
};
template <>
struct Schema<Subscribe> : MessageRow<MessageType::kSubscribe, "Subscribe", kHostToDaemon, 0> {
  static constexpr MessagePolicy policy{.sender = Sender::kAny};
  static constexpr auto refusals =
      join(kSession, list(Refusal{E::kRateLimited, rf::kTelemetryRate}));
  using fields = Fields<Field<"telemetry_rate_hz", &Subscribe::telemetry_rate_hz>>;
};
template <>
struct Schema<Drive> : MessageRow<MessageType::kDrive, "Drive", kHostToDaemon, 1> {
  static constexpr MessagePolicy policy = kDriving;
  static constexpr auto refusals =
      join(kControllerSession, kNewer, kBaseMayDrive,
           list(Refusal{E::kAtMinimumStandoff, rf::kLinear}), kQueueFull);
  using fields = Fields<Field<"linear_m_s", &Drive::linear_m_s>,
                        Field<"angular_rad_s", &Drive::angular_rad_s>>;
};
template <>
struct Schema<Approach> : MessageRow<MessageType::kApproach, "Approach", kHostToDaemon, 1> {
  static constexpr MessagePolicy policy = kDriving;
  static constexpr auto refusals = join(
      kControllerSession, kNewer, kBaseMayDrive,
      list(Refusal{E::kStandoffOutOfRange, rf::kStandoff},
           Refusal{E::kMeasurementStale, rf::kPlane}, Refusal{E::kNoDoorDistance, rf::kNone},
           Refusal{E::kNotSquareToDoor, rf::kDoorYaw}, Refusal{E::kApproachTooFar, rf::kStandoff}));
  using ack_body = ApproachAck;
  using fields = Fields<Field<"standoff_m", &Approach::standoff_m>>;
};
template <>
struct Schema<GetRobotModel>
    : MessageRow<MessageType::kGetRobotModel, "GetRobotModel", kHostToDaemon, 1> {
  static constexpr MessagePolicy policy{.sender = Sender::kAny};
  static constexpr auto refusals = join(kSession, kNewer);
  using fields = Fields<>;
};
template <>
struct Schema<ResetLoopStatistics>
    : MessageRow<MessageType::kResetLoopStatistics, "ResetLoopStatistics", kHostToDaemon, 1> {
  static constexpr MessagePolicy policy = kCommand;
  static constexpr auto refusals = join(kControllerSession, kNewer);
  using fields = Fields<>;
};

template <>
struct Schema<ListRecordings>
    : MessageRow<MessageType::kListRecordings, "ListRecordings", kHostToDaemon, 2> {
  static constexpr MessagePolicy policy{.sender = Sender::kAny};
  static constexpr auto refusals = join(kSession, kNewer, kBlackBox);
  using fields = Fields<Field<"first", &ListRecordings::first>>;
};
template <>
struct Schema<FetchRecording>
    : MessageRow<MessageType::kFetchRecording, "FetchRecording", kHostToDaemon, 2> {
  static constexpr MessagePolicy policy{.sender = Sender::kAny};
  static constexpr auto refusals = join(
      kSession, kNewer, kBlackBox,
      list(Refusal{E::kNoSuchRecording, rf::kName}, Refusal{E::kRequestOutOfRange, rf::kMaxLength},
           Refusal{E::kRequestOutOfRange, rf::kOffset}));
  using fields =
      Fields<Field<"name", &FetchRecording::name>, Field<"offset", &FetchRecording::offset>,
             Field<"max_length", &FetchRecording::max_length>>;
};
template <>
struct Schema<SaveRecording>
    : MessageRow<MessageType::kSaveRecording, "SaveRecording", kHostToDaemon, 2> {
  static constexpr MessagePolicy policy{.sender = Sender::kAny};
  static constexpr auto refusals =
      join(kSession, kNewer, kBlackBox, list(Refusal{E::kRequestOutOfRange, rf::kLastS}));
  using fields = Fields<Field<"last_s", &SaveRecording::last_s>>;
};

// ---- daemon -> host -------------------------------------------------------------------------

template <>
struct Schema<Welcome> : MessageRow<MessageType::kWelcome, "Welcome", kDaemonToHost, 0> {
  using fields = Fields<Field<"version_major", &Welcome::version_major>,
                        Field<"version_minor", &Welcome::version_minor>,
                        Field<"granted_role", &Welcome::granted_role>,
                        Field<"session_id", &Welcome::session_id>,
                        Field<"daemon_version", &Welcome::daemon_version>,
                        Field<"loop_rate_hz", &Welcome::loop_rate_hz>,
                        Field<"deadman_timeout_s", &Welcome::deadman_timeout_s>,
                        Field<"min_door_width_m", &Welcome::min_door_width_m>,
                        Field<"max_door_width_m", &Welcome::max_door_width_m>,
                        Field<"min_handle_length_m", &Welcome::min_handle_length_m>,
                        Field<"max_handle_length_m", &Welcome::max_handle_length_m>,
                        Field<"max_yaw_correction_rad", &Welcome::max_yaw_correction_rad>,
                        Field<"driver_kind", &Welcome::driver_kind, 1>>;
};
template <>
struct Schema<Pong> : MessageRow<MessageType::kPong, "Pong", kDaemonToHost, 0> {
  using fields = Fields<Field<"client_time_ns", &Pong::client_time_ns>,
                        Field<"daemon_time_ns", &Pong::daemon_time_ns>>;
};
template <>
struct Schema<Ack> : MessageRow<MessageType::kAck, "Ack", kDaemonToHost, 0> {
  using fields =
      Fields<Field<"acknowledged", &Ack::acknowledged, 0, AckedType>, Field<"state", &Ack::state>,
             Field<"body", &Ack::body, 0, AckBodyOf<&Ack::acknowledged>>>;
};
template <>
struct Schema<ErrorReply> : MessageRow<MessageType::kError, "Error", kDaemonToHost, 0> {
  using fields =
      Fields<Field<"code", &ErrorReply::code>, Field<"offending_type", &ErrorReply::offending_type>,
             Field<"field", &ErrorReply::field>, Field<"message", &ErrorReply::message>>;
};
template <>
struct Schema<Event> : MessageRow<MessageType::kEvent, "Event", kDaemonToHost, 0> {
  using fields =
      Fields<Field<"kind", &Event::kind>, Field<"state", &Event::state>,
             Field<"fault", &Event::fault>, Field<"daemon_time_ns", &Event::daemon_time_ns>,
             Field<"detail", &Event::detail>, Field<"base_motion", &Event::base_motion, 2>>;
};
template <>
struct Schema<Status> : MessageRow<MessageType::kStatus, "Status", kDaemonToHost, 0> {
  using fields =
      Concat<Fields<Field<"state", &Status::state>, Field<"latched_fault", &Status::latched_fault>,
                    Field<"restored_from_disk", &Status::restored_from_disk>,
                    Field<"controller_connected", &Status::controller_connected>,
                    Field<"session_count", &Status::session_count>,
                    Field<"has_width", &Status::has_width>, Field<"width", &Status::width>,
                    Field<"has_handle", &Status::has_handle>, Field<"handle", &Status::handle>,
                    Field<"has_plane", &Status::has_plane>, Field<"plane", &Status::plane>,
                    Field<"has_contact", &Status::has_contact>, Field<"contact", &Status::contact>,
                    Field<"base_yaw_odometry_rad", &Status::base_yaw_odometry_rad>,
                    Field<"card", &Status::card>, Field<"arm", &Status::arm>,
                    Field<"arm_state", &Status::arm_state>, Field<"loop", &Status::loop>>,
             MotionBlock<Status>, Fields<Field<"realtime", &Status::realtime, 1>>,
             Fields<Field<"base_motion", &Status::base_motion, 2>,
                    Field<"recorder", &Status::recorder, 2>>>;
};
template <>
struct Schema<Telemetry> : MessageRow<MessageType::kTelemetry, "Telemetry", kDaemonToHost, 0> {
  using fields =
      Concat<Fields<Field<"daemon_time_ns", &Telemetry::daemon_time_ns>,
                    Field<"state", &Telemetry::state>, Field<"moving", &Telemetry::moving>,
                    Field<"left_wheel_rad", &Telemetry::left_wheel_rad>,
                    Field<"right_wheel_rad", &Telemetry::right_wheel_rad>,
                    Field<"left_counts", &Telemetry::left_counts>,
                    Field<"right_counts", &Telemetry::right_counts>,
                    Field<"base_yaw_odometry_rad", &Telemetry::base_yaw_odometry_rad>,
                    Field<"arm_state", &Telemetry::arm_state>, Field<"loop", &Telemetry::loop>>,
             MotionBlock<Telemetry>, Fields<Field<"base_motion", &Telemetry::base_motion, 2>>>;
};
template <>
struct Schema<RobotModel> : MessageRow<MessageType::kRobotModel, "RobotModel", kDaemonToHost, 1> {
  using R = RobotModel;
  using fields = Fields<
      Field<"camera_to_base", &R::camera_to_base>, Field<"wheel_radius_m", &R::wheel_radius_m>,
      Field<"turning_radius_m", &R::turning_radius_m>,
      Field<"encoder_counts_per_rev", &R::encoder_counts_per_rev>,
      Field<"gear_ratio", &R::gear_ratio>, Field<"left", &R::left>, Field<"right", &R::right>,
      Field<"max_wheel_speed_rad_s", &R::max_wheel_speed_rad_s>,
      Field<"max_wheel_accel_rad_s2", &R::max_wheel_accel_rad_s2>,
      Field<"max_linear_speed_m_s", &R::max_linear_speed_m_s>,
      Field<"max_angular_speed_rad_s", &R::max_angular_speed_rad_s>,
      Field<"max_linear_accel_m_s2", &R::max_linear_accel_m_s2>,
      Field<"max_angular_accel_rad_s2", &R::max_angular_accel_rad_s2>,
      Field<"drive_command_timeout_s", &R::drive_command_timeout_s>,
      Field<"approach_max_travel_m", &R::approach_max_travel_m>,
      Field<"approach_square_tolerance_rad", &R::approach_square_tolerance_rad>,
      Field<"approach_min_standoff_m", &R::approach_min_standoff_m>,
      Field<"stale_travel_m", &R::stale_travel_m>, Field<"stale_yaw_rad", &R::stale_yaw_rad>,
      Field<"arm_shoulder_m", &R::arm_shoulder_m>, Field<"arm_min_reach_m", &R::arm_min_reach_m>,
      Field<"arm_max_reach_m", &R::arm_max_reach_m>, Field<"arm_min_z_m", &R::arm_min_z_m>,
      Field<"arm_max_z_m", &R::arm_max_z_m>, Field<"min_depth_m", &R::min_depth_m>,
      Field<"max_depth_m", &R::max_depth_m>, Field<"min_door_width_m", &R::min_door_width_m>,
      Field<"max_door_width_m", &R::max_door_width_m>,
      Field<"min_handle_length_m", &R::min_handle_length_m>,
      Field<"max_handle_length_m", &R::max_handle_length_m>,
      Field<"max_yaw_correction_rad", &R::max_yaw_correction_rad>,
      Field<"aligned_tolerance_rad", &R::aligned_tolerance_rad>,
      Field<"min_point_separation_m", &R::min_point_separation_m>,
      Field<"min_lateral_fraction", &R::min_lateral_fraction>,
      Field<"collinearity", &R::collinearity>, Field<"max_plane_rms_m", &R::max_plane_rms_m>,
      Field<"max_door_tilt_rad", &R::max_door_tilt_rad>>;
};

template <>
struct Schema<RecordingList>
    : MessageRow<MessageType::kRecordingList, "RecordingList", kDaemonToHost, 2> {
  using fields =
      Fields<Field<"total", &RecordingList::total>, Field<"first", &RecordingList::first>,
             Field<"count", &RecordingList::count, 0, ListCount>,
             Field<"entries", &RecordingList::entries>>;
};
template <>
struct Schema<RecordingChunk>
    : MessageRow<MessageType::kRecordingChunk, "RecordingChunk", kDaemonToHost, 2> {
  using fields = Fields<Field<"offset", &RecordingChunk::offset>,
                        Field<"size_bytes", &RecordingChunk::size_bytes>,
                        Field<"data", &RecordingChunk::data>>;
};

// ---- the message table, in the order of the Message variant ---------------------------------

struct MessageInfo {
  MessageType type;
  std::string_view name;
  Direction direction;
  std::uint8_t since;  // the minor version that defined the type
  MessagePolicy policy;
  std::span<const Refusal> refusals;
};

template <std::size_t... I>
constexpr auto make_message_table(std::index_sequence<I...>) {
  return std::array<MessageInfo, sizeof...(I)>{MessageInfo{
      Schema<std::variant_alternative_t<I, Message>>::type,
      Schema<std::variant_alternative_t<I, Message>>::name.view(),
      Schema<std::variant_alternative_t<I, Message>>::direction,
      Schema<std::variant_alternative_t<I, Message>>::since,
      Schema<std::variant_alternative_t<I, Message>>::policy,
      std::span<const Refusal>(Schema<std::variant_alternative_t<I, Message>>::refusals)}...};
}
inline constexpr auto kMessageTable =
    make_message_table(std::make_index_sequence<std::variant_size_v<Message>>{});

constexpr bool types_are_unique() {
  for (std::size_t i = 0; i < kMessageTable.size(); ++i) {
    for (std::size_t k = i + 1; k < kMessageTable.size(); ++k) {
      if (kMessageTable[i].type == kMessageTable[k].type) return false;
    }
  }
  return true;
}
static_assert(types_are_unique(), "one message type per Message alternative");

// Type -> row index in one load (the decoder looks a type up in every frame; a search through
// the table was a sixth of its time): kRowOfType[t - kLowestType], kNoRow for a gap.
inline constexpr std::uint8_t kNoRow = 0xFF;
inline constexpr std::size_t kLowestType =
    static_cast<std::size_t>(std::ranges::min(kMessageTable, {}, &MessageInfo::type).type);
inline constexpr std::size_t kHighestType =
    static_cast<std::size_t>(std::ranges::max(kMessageTable, {}, &MessageInfo::type).type);
inline constexpr auto kRowOfType = [] {
  std::array<std::uint8_t, kHighestType - kLowestType + 1> rows{};
  rows.fill(kNoRow);
  for (std::size_t i = 0; i < kMessageTable.size(); ++i)
    rows[static_cast<std::size_t>(kMessageTable[i].type) - kLowestType] =
        static_cast<std::uint8_t>(i);
  return rows;
}();
static_assert(kMessageTable.size() < kNoRow);

// A request's row says who may send it; a daemon -> host row keeps the default policy.
constexpr bool policies_match_directions() {
  for (const MessageInfo& m : kMessageTable) {
    const bool request = m.direction == Direction::kHostToDaemon;
    if (request == (m.policy.sender == Sender::kDaemon)) return false;
    if (!request && (m.policy.deduplicated || m.policy.durable_ack || m.policy.starts_motion ||
                     m.policy.needs_wheels_at_rest)) {
      return false;
    }
  }
  return true;
}
static_assert(policies_match_directions(), "every request row has its policy (message_table.hpp)");

// A daemon -> host row has no refusals; a request row names each (code, field) once.
constexpr bool refusals_are_rows() {
  for (const MessageInfo& m : kMessageTable) {
    if (m.direction == Direction::kDaemonToHost && !m.refusals.empty()) return false;
    for (std::size_t i = 0; i < m.refusals.size(); ++i) {
      for (std::size_t k = i + 1; k < m.refusals.size(); ++k) {
        const Refusal& a = m.refusals[i];
        const Refusal& b = m.refusals[k];
        if (a.code == b.code && a.field == b.field && a.indexed == b.indexed &&
            a.per_axis == b.per_axis) {
          return false;
        }
      }
    }
  }
  return true;
}
static_assert(refusals_are_rows(), "each refusal once per request row (message_table.hpp)");

// The row of `t`, or nullptr for a type this version does not know.
constexpr const MessageInfo* find_message(MessageType t) noexcept {
  const auto type = static_cast<std::size_t>(t);
  if (type < kLowestType || type > kHighestType) return nullptr;
  const std::uint8_t row = kRowOfType[type - kLowestType];
  return row == kNoRow ? nullptr : &kMessageTable[row];
}

}  // namespace ajar::protocol::detail
