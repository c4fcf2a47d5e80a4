// Typical messages of every type (and every Ack body kind), shared by the vector generator, the
// round-trip tests and the benchmark. Values are realistic and use every byte of their fields.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ajar/core/measurements.hpp"
#include "ajar/protocol/acks.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/robot_model.hpp"

namespace ajar::protocol::samples {

struct Sample {
  std::string name;
  Envelope envelope;
};

// The minor version a sample's vector is written in: the oldest that has its type (and, for an
// Ack, the acknowledged type), but at least 1.1, so that the vectors of 1.1 stay byte for byte
// what they were before 1.2 (the proof that 1.0/1.1 sessions did not change).
inline std::uint8_t vector_minor(const Message& m) {
  std::uint8_t minor = std::max<std::uint8_t>(1, minor_of(type_of(m)));
  if (const auto* ack = std::get_if<Ack>(&m)) minor = std::max(minor, minor_of(ack->acknowledged));
  return minor;
}

inline core::FramedPoint camera_point(double x, double y, double z) {
  return {core::Frame::kCamera, core::Vec3(x, y, z)};
}
inline core::FramedPoint base_point(double x, double y, double z) {
  return {core::Frame::kBase, core::Vec3(x, y, z)};
}

inline LoopStatistics loop_stats() {
  LoopStatistics l;
  l.rate_hz = 1000.0f;
  l.cycles = 123456789;
  l.overruns = 3;
  l.period_p50_ns = 1000012;
  l.period_p99_ns = 1004500;
  l.period_max_ns = 1250000;
  l.jitter_p99_ns = 4500;
  return l;
}

inline LoopTiming loop_timing() {
  LoopTiming t;
  t.window_s = 10.0f;
  const auto window = [](std::uint64_t samples, std::uint32_t scale) {
    TimingWindow w;
    w.samples = samples;
    w.latency = {12 * scale, 38 * scale, 61 * scale, 140 * scale};
    w.execution = {4 * scale, 9 * scale, 15 * scale, 33 * scale};
    w.period = {2000012, 2000950, 2004100, 2011000 + scale};
    return w;
  };
  t.all = window(123456789, 1000);
  t.recent = window(5000, 900);
  return t;
}

template <typename T>
void fill_motion(T& m) {
  m.odometry_x_m = 0.4125;
  m.odometry_y_m = -0.0375;
  m.door.has_distance = true;
  m.door.distance_m = 1.0125;
  m.door.has_yaw = true;
  m.door.yaw_rad = -0.0412;
  m.staleness.plane = true;
  m.staleness.contact = false;
  m.staleness.travel_since_plane_m = 0.3125;
  m.commanded_linear_m_s = 0.25;
  m.commanded_angular_rad_s = -0.125;
  m.timing = loop_timing();
}

inline core::BaseGeometry sample_base();
inline core::Limits sample_limits();
inline const core::CameraToBase& sample_transform();

// The RobotModel of the robot the samples are measured on (what ajard would send for it), with
// example values for the 1.1 drive/approach/staleness limits.
inline RobotModel robot_model() {
  const core::DriveLimits drive{.max_linear_speed_m_s = 0.3,
                                .max_angular_speed_rad_s = 0.5,
                                .max_linear_accel_m_s2 = 0.4,
                                .max_angular_accel_rad_s2 = 1.0,
                                .command_timeout_s = 0.5,
                                .approach_max_travel_m = 2.0,
                                .approach_square_tolerance_rad = 0.2,
                                .approach_min_standoff_m = 0.5,
                                .stale_travel_m = 0.05,
                                .stale_yaw_rad = 0.02};
  RobotModel r = robot_model_from(sample_transform().isometry().matrix(), sample_base(),
                                  sample_limits(), drive);
  r.aligned_tolerance_rad = 0.01;
  return r;
}

// The robot the samples are measured on: the paper's camera->base transform and the default base
// geometry and limits (core/robot_model.hpp); robot_model() reports exactly these.
inline const core::CameraToBase& sample_transform() {
  static const core::CameraToBase t =
      core::CameraToBase::from_matrix(core::paper_camera_to_base_m()).value();
  return t;
}
inline core::Limits sample_limits() {
  return core::Limits{};
}
inline core::BaseGeometry sample_base() {
  return core::BaseGeometry{};
}

// The requests of the golden vectors; their Acks below are computed from them through core, as the
// daemon computes them (so the ack_* vectors are worked examples of docs/geometry.md).
inline MeasureDoorWidth width_request() {
  return {camera_point(-0.452, 0.118, 1.634), camera_point(0.463, 0.121, 1.702)};
}
inline MeasureHandle handle_request() {
  return {camera_point(0.31, -0.05, 1.2), camera_point(0.42, -0.045, 1.21)};
}
inline MeasureDoorPlane plane3_request() {
  MeasureDoorPlane plane3;
  plane3.count = 3;
  plane3.points[0] = camera_point(-0.4, -0.3, 1.6);
  plane3.points[1] = camera_point(0.4, -0.3, 1.65);
  plane3.points[2] = camera_point(0.0, 0.35, 1.62);
  return plane3;
}
inline SetContactPoint contact_request() {
  return {camera_point(0.015, -0.72, 1.0)};
}

template <typename T>
T value_or_throw(Result<T> r, const char* what) {
  if (!r) throw std::runtime_error(std::string(what) + ": " + r.error().message);
  return std::move(r).value();
}
inline SpanAck width_ack() {
  const auto r = width_request();
  return span_ack_from(value_or_throw(
      core::measure_door_width(r.p1_hinge, r.p2_moving_edge, sample_transform(), sample_limits()),
      "width sample"));
}
inline SpanAck handle_ack() {
  const auto r = handle_request();
  return span_ack_from(value_or_throw(
      core::measure_handle(r.p1_axis, r.p2_free_end, sample_transform(), sample_limits()),
      "handle sample"));
}
inline PlaneAck plane_ack() {
  const auto r = plane3_request();
  const auto m = value_or_throw(
      core::measure_door_plane(std::span<const core::FramedPoint>(r.points.data(), r.count),
                               sample_transform(), sample_limits(), sample_base()),
      "plane sample");
  return plane_ack_from(m);
}
inline ContactAck contact_ack() {
  const auto m = value_or_throw(
      core::measure_contact_point(contact_request().contact, sample_transform(), sample_limits()),
      "contact sample");
  return {m.contact_base_m, m.reach_margin_m};
}

// Hello and Welcome as 1.1 peers send them (their vectors are 1.1 frames, unchanged by 1.2).
inline Hello hello_sample() {
  Hello hello;
  hello.version_minor = 1;
  hello.requested_role = Role::kController;
  hello.client_instance_id = 0x0123456789ABCDEFull;
  hello.client_name = "door-gui 2.3";
  return hello;
}

inline Hello observer_hello_sample() {
  Hello observer;
  observer.version_minor = 1;
  observer.requested_role = Role::kObserver;
  observer.client_instance_id = 0x1122334455667788ull;
  observer.client_name = "Türöffner-Monitor";  // UTF-8 multi-byte characters
  return observer;
}

// The most points a plane takes: 15 camera points on a grid and one in the base frame.
inline MeasureDoorPlane plane16_request() {
  MeasureDoorPlane plane16;
  plane16.count = 16;
  for (std::size_t i = 0; i < 16; ++i) {
    const double u = static_cast<double>(i % 4) * 0.2 - 0.3;
    const double v = static_cast<double>(i / 4) * 0.15 - 0.2;
    plane16.points[i] = i == 15 ? base_point(1.5, 0.1, 1.1) : camera_point(u, v, 1.6 + 0.05 * u);
  }
  return plane16;
}

inline FetchRecording fetch_sample() {
  FetchRecording fetch;
  fetch.name = "ajard-20261126T130502Z-0007.mcap";
  fetch.offset = 1048576;
  fetch.max_length = 960;
  return fetch;
}

inline Welcome welcome_sample() {
  Welcome welcome;
  welcome.version_minor = 1;
  welcome.granted_role = Role::kController;
  welcome.session_id = 0xA1B2C3D4E5F60718ull;
  welcome.daemon_version = "0.1.0";
  welcome.loop_rate_hz = 1000.0f;
  welcome.deadman_timeout_s = 0.5f;
  welcome.min_door_width_m = 0.6f;
  welcome.max_door_width_m = 1.2f;
  welcome.min_handle_length_m = 0.08f;
  welcome.max_handle_length_m = 0.25f;
  welcome.max_yaw_correction_rad = 0.5236f;
  welcome.driver_kind = DriverKind::kReal;
  return welcome;
}

// The 9th to 11th newest of 11 recordings.
inline RecordingList recording_list_sample() {
  RecordingList list;
  list.total = 11;
  list.first = 8;
  list.count = 3;
  for (std::uint8_t i = 0; i < 3; ++i) {
    RecordingInfo& e = list.entries[i];
    e.name.assign("ajard-20261126T0" + std::to_string(9 - i) + "0000000Z.mcap");
    e.size_bytes = 67108864u - 4096u * i;
    e.start_unix_ns = 1795683600000000000ull - 3600000000000ull * i;
    e.end_unix_ns = e.start_unix_ns + 600000000000ull;
  }
  return list;
}

// The reply to SaveRecording.
inline RecordingList saved_list_sample() {
  RecordingList saved;
  saved.total = 2;
  saved.count = 2;
  saved.entries[0].name = "saved/ajard-20261126T131000000Z.mcap";
  saved.entries[0].size_bytes = 5242880;
  saved.entries[0].start_unix_ns = 1795698600000000000ull;
  saved.entries[0].end_unix_ns = 1795698845500000000ull;
  saved.entries[0].saved = true;
  saved.entries[1].name = "saved/ajard-20261126T130000000Z.mcap";
  saved.entries[1].size_bytes = 67108001;
  saved.entries[1].start_unix_ns = 1795698000000000000ull;
  saved.entries[1].end_unix_ns = 1795698600000000000ull;
  saved.entries[1].saved = true;
  return saved;
}

inline RecordingChunk chunk_sample() {
  RecordingChunk chunk;
  chunk.offset = 1048576;
  chunk.size_bytes = 1049000;
  std::array<std::uint8_t, 424> tail{};
  for (std::size_t i = 0; i < tail.size(); ++i)
    tail[i] = static_cast<std::uint8_t>(i * 37 + 11);
  chunk.data.assign(tail.data(), tail.size());  // the last 424 bytes of the file
  return chunk;
}

inline ErrorReply error_sample() {
  ErrorReply error;
  error.code = ErrorCode::kPointsCollinear;
  error.offending_type = MessageType::kMeasureDoorPlane;
  error.field = "points[2]";
  error.message = "The three plane points lie on one line; pick points spread over the door.";
  return error;
}

inline Event fault_event_sample() {
  Event fault;
  fault.kind = EventKind::kFaultLatched;
  fault.state = ProcedureState::kFault;
  fault.fault = ErrorCode::kFollowingError;
  fault.daemon_time_ns = 5123456789ull;
  fault.detail = "left wheel following error 0.012 rad";
  return fault;
}

inline Event finished_event_sample() {
  Event finished;
  finished.kind = EventKind::kMotionFinished;
  finished.state = ProcedureState::kAligned;
  finished.daemon_time_ns = 6000000000ull;
  finished.detail = "base aligned";
  return finished;
}

// 1.2 (absent from the `status` vector, which is 1.1; the v1_2_status vector has them).
inline void fill_recorder(Status& status) {
  status.base_motion = BaseMotion::kApproaching;
  status.recorder.enabled = true;
  status.recorder.mode = RecorderMode::kRecording;
  status.recorder.file = "ajard-20261126T130501123Z.mcap";
  status.recorder.file_bytes = 1234567;
  status.recorder.directory_bytes = 45678901;
  status.recorder.max_bytes = 536870912;
  status.recorder.saved_bytes = 2345678;
  status.recorder.disk_free_bytes = 9876543210;
  status.recorder.records_written = 456789;
  status.recorder.loop_samples = 400000;
  status.recorder.loop_dropped = 17;
  status.recorder.io_records = 56800;
  status.recorder.io_dropped = 3;
  status.recorder.records_lost = 11;
  status.recorder.disk_refusals = 1;
  status.recorder.last_write_ns = 4000000123ull;
}

inline Status status_sample() {
  Status status;
  status.state = ProcedureState::kReadyToEngage;
  status.latched_fault = ErrorCode::kOk;
  status.restored_from_disk = true;
  status.controller_connected = true;
  status.session_count = 2;
  status.has_width = true;
  status.width = width_ack();
  status.has_handle = true;
  status.handle = handle_ack();
  status.has_plane = true;
  status.plane = plane_ack();
  status.has_contact = true;
  status.contact = contact_ack();
  status.base_yaw_odometry_rad = 0.05236;
  status.card = DriverState::kActive;
  status.arm = DriverState::kActive;
  status.arm_state = ArmState::kIdle;
  status.loop = loop_stats();
  fill_motion(status);
  status.realtime = {SchedulingPolicy::kFifo, 80, true};
  fill_recorder(status);
  return status;
}

inline Telemetry telemetry_sample() {
  Telemetry telemetry;
  telemetry.daemon_time_ns = 5500000000ull;
  telemetry.state = ProcedureState::kAligning;
  telemetry.moving = true;
  telemetry.left_wheel_rad = -0.0912;
  telemetry.right_wheel_rad = 0.0913;
  telemetry.left_counts = -1451;
  telemetry.right_counts = 1453;
  telemetry.base_yaw_odometry_rad = 0.0261;
  telemetry.arm_state = ArmState::kIdle;
  telemetry.loop = loop_stats();
  fill_motion(telemetry);
  return telemetry;
}

// Adds one sample: its name, its envelope's request id, message and flags.
class SampleList {
 public:
  void add(std::string name, std::uint32_t id, Message m, std::uint16_t flags = 0) {
    samples_.push_back({std::move(name), Envelope{id, flags, std::move(m)}});
  }
  std::vector<Sample> take() { return std::move(samples_); }

 private:
  std::vector<Sample> samples_;
};

// host -> daemon
inline void add_requests(SampleList& s) {
  const Hello hello = hello_sample();
  s.add("hello_controller", 1, hello);
  s.add("hello_observer_utf8", 1, observer_hello_sample());
  Hello take_over = hello;
  take_over.take_over = true;
  s.add("hello_take_over", 1, take_over);
  s.add("ping", 2, Ping{1700000000123456789ull});
  s.add("ping_retransmit", 2, Ping{1700000000123456789ull}, kFlagRetransmit);
  s.add("measure_door_width", 3, width_request());
  s.add("measure_handle", 4, handle_request());
  s.add("measure_door_plane_3", 5, plane3_request());
  s.add("measure_door_plane_16", 6, plane16_request());
  s.add("set_contact_point", 7, contact_request());
  s.add("align_base", 8, AlignBase{});
  s.add("engage", 9, Engage{});
  s.add("stop", 10, Stop{});
  s.add("emergency_stop", 11, EmergencyStop{});
  s.add("reset", 12, Reset{false});
  s.add("reset_clear_parameters", 13, Reset{true});
  s.add("get_status", 14, GetStatus{});
  s.add("subscribe", 15, Subscribe{50.0f});
  s.add("drive", 16, Drive{0.25, -0.125});
  s.add("approach", 17, Approach{0.75});
  s.add("get_robot_model", 18, GetRobotModel{});
  s.add("reset_loop_statistics", 19, ResetLoopStatistics{});
  s.add("list_recordings", 20, ListRecordings{8});
  s.add("fetch_recording", 21, fetch_sample());
  s.add("save_recording", 22, SaveRecording{300.0f});
}

// daemon -> host
inline void add_replies_and_events(SampleList& s) {
  s.add("welcome", 1, welcome_sample());
  s.add("pong", 2, Pong{1700000000123456789ull, 987654321012ull});
  s.add("ack_measure_door_width", 3,
        Ack{MessageType::kMeasureDoorWidth, ProcedureState::kAwaitingHandle, width_ack()});
  s.add("ack_measure_handle", 4,
        Ack{MessageType::kMeasureHandle, ProcedureState::kAwaitingPlane, handle_ack()});
  s.add("ack_measure_door_plane", 5,
        Ack{MessageType::kMeasureDoorPlane, ProcedureState::kReadyToAlign, plane_ack()});
  s.add("ack_set_contact_point", 7,
        Ack{MessageType::kSetContactPoint, ProcedureState::kReadyToEngage, contact_ack()});
  s.add("ack_align_base", 8, Ack{MessageType::kAlignBase, ProcedureState::kAligning, EmptyAck{}});
  s.add("ack_stop", 10, Ack{MessageType::kStop, ProcedureState::kAligned, EmptyAck{}});
  s.add("ack_drive", 16, Ack{MessageType::kDrive, ProcedureState::kAwaitingHandle, EmptyAck{}});
  s.add("ack_approach", 17,
        Ack{MessageType::kApproach, ProcedureState::kAwaitingHandle,
            ApproachAck{0.25, 1.0, 198944, -198944}});
  s.add("robot_model", 18, robot_model());
  s.add("recording_list", 20, recording_list_sample());
  s.add("recording_list_saved", 22, saved_list_sample());
  s.add("recording_chunk", 21, chunk_sample());
  s.add("error_points_collinear", 5, error_sample());
  s.add("event_fault_latched", 0, fault_event_sample());
  s.add("event_motion_finished", 0, finished_event_sample());
  s.add("status", 14, status_sample());
  s.add("telemetry", 0, telemetry_sample());
}

inline std::vector<Sample> all() {
  SampleList s;
  add_requests(s);
  add_replies_and_events(s);
  return s.take();
}

}  // namespace ajar::protocol::samples
