// ajarctl --json output: every rendering is one valid JSON object with the documented fields.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ajar/client/json.hpp"
#include "ajar/client/output.hpp"
#include "json_samples.hpp"

namespace ajar::client {
namespace {

using protocol::MessageType;
using protocol::ProcedureState;

// Builds the reply in place (no copies of the big variants: GCC 12 under ASan warns about them).
template <typename T>
T& reply_as(Response& r) {
  r.outcome = CallOutcome::kReply;
  r.request_id = 7;
  r.session_minor = protocol::kVersionMinor;
  return r.reply.emplace<T>();
}

template <typename Body>
Body& ack_as(Response& r, MessageType acknowledged, ProcedureState state) {
  auto& ack = reply_as<protocol::Ack>(r);
  ack.acknowledged = acknowledged;
  ack.state = state;
  return ack.body.emplace<Body>();
}

using Json = nlohmann::json;

// The text must be one JSON object on one line (a strict parse: throws on anything else).
Json parse(const JsonObject& o) {
  const std::string text = o.str();
  EXPECT_EQ(text.find('\n'), std::string::npos) << "one object per line";
  Json v = Json::parse(text);
  EXPECT_TRUE(v.is_object()) << text;
  return v;
}

TEST(Json, EscapesQuotesBackslashesAndControlCharacters) {
  const std::string nasty = "a\"b\\c\nd\te\x01f\x7f";
  JsonObject o;
  o.add("s", nasty);
  const auto v = parse(o);
  EXPECT_EQ(v.at("s").get<std::string>(), nasty);
  EXPECT_EQ(JsonObject().add("s", "\x01").str(), R"({"s":"\u0001"})");
}

TEST(Json, NumbersRoundTripExactlyAndNonFiniteIsNull) {
  for (double x : {0.1, -1.0 / 3.0, 1e-300, 6.02214076e23, 0.9152, -0.0277305606204600}) {
    EXPECT_EQ(std::strtod(json_number(x).c_str(), nullptr), x) << json_number(x);
  }
  EXPECT_EQ(json_number(std::numeric_limits<double>::quiet_NaN()), "null");
  EXPECT_EQ(json_number(std::numeric_limits<double>::infinity()), "null");
  JsonObject o;
  o.add("nan", std::nan(""))
      .add("i", std::int64_t{-42})
      .add("u", std::uint64_t{18446744073709551615u});
  const auto v = parse(o);
  EXPECT_TRUE(v.at("nan").is_null());
  EXPECT_EQ(v.at("i").get<double>(), -42);
}

TEST(Json, WidthAckCarriesWidthDirectionAndBasePoints) {
  Response r;
  auto& span =
      ack_as<protocol::SpanAck>(r, MessageType::kMeasureDoorWidth, ProcedureState::kAwaitingHandle);
  span.length_m = 0.9152;
  span.direction = core::RotationDirection::kCounterClockwise;
  span.p1_base_m = core::Vec3(1.21, 0.43, 0.02);
  const auto v = parse(response_object("measure_width", r));
  EXPECT_EQ(v.at("type").get<std::string>(), "ack");
  EXPECT_EQ(v.at("command").get<std::string>(), "measure_width");
  EXPECT_TRUE(v.at("ok").get<bool>());
  EXPECT_EQ(v.at("state").get<std::string>(), "awaiting_handle");
  EXPECT_EQ(v.at("acknowledged").get<std::string>(), "MeasureDoorWidth");
  EXPECT_EQ(v.at("length_m").get<double>(), 0.9152);
  EXPECT_EQ(v.at("direction").get<std::string>(), "CCW");
  ASSERT_EQ(v.at("p1_base_m").size(), 3u);
  EXPECT_EQ(v.at("p1_base_m").at("y").get<double>(), 0.43);
  EXPECT_FALSE(v.contains("width_m")) << "the wire's name: length_m";
}

TEST(Json, HandleAckCarriesItsLength) {
  Response r;
  ack_as<protocol::SpanAck>(r, MessageType::kMeasureHandle, ProcedureState::kAwaitingPlane)
      .length_m = 0.12;
  const auto v = parse(response_object("measure_handle", r));
  EXPECT_EQ(v.at("acknowledged").get<std::string>(), "MeasureHandle");
  EXPECT_EQ(v.at("length_m").get<double>(), 0.12);
  EXPECT_EQ(v.at("direction").get<std::string>(), "CW");
  EXPECT_FALSE(v.contains("handle_length_m"));
}

TEST(Json, PlaneAckCarriesYawAndWheels) {
  Response r;
  auto& plane =
      ack_as<protocol::PlaneAck>(r, MessageType::kMeasureDoorPlane, ProcedureState::kReadyToAlign);
  plane.yaw_deviation_rad = -0.0277;
  plane.left_wheel_rad = 0.0693;
  plane.right_wheel_rad = -0.0693;
  plane.left_counts = 5517;
  plane.right_counts = 5517;
  plane.point_count = 4;
  const auto v = parse(response_object("measure_plane", r));
  EXPECT_EQ(v.at("yaw_deviation_rad").get<double>(), -0.0277);
  EXPECT_EQ(v.at("left_wheel_rad").get<double>(), 0.0693);
  EXPECT_EQ(v.at("right_wheel_rad").get<double>(), -0.0693);
  EXPECT_EQ(v.at("left_counts").get<double>(), 5517);
  EXPECT_EQ(v.at("right_counts").get<double>(), 5517);
  EXPECT_EQ(v.at("normal").size(), 3u);
  EXPECT_EQ(v.at("point_count").get<double>(), 4);
}

TEST(Json, ContactAckCarriesContactBase) {
  Response r;
  auto& contact = ack_as<protocol::ContactAck>(r, MessageType::kSetContactPoint,
                                               ProcedureState::kReadyToEngage);
  contact.contact_base_m = core::Vec3(0.8, -0.01, 0.3);
  contact.reach_margin_m = 0.4;
  const auto v = parse(response_object("contact", r));
  ASSERT_EQ(v.at("contact_base_m").size(), 3u);
  EXPECT_EQ(v.at("contact_base_m").at("x").get<double>(), 0.8);
  EXPECT_EQ(v.at("contact_base_m").at("y").get<double>(), -0.01);
  EXPECT_EQ(v.at("reach_margin_m").get<double>(), 0.4);
}

TEST(Json, RefusalCarriesErrorCodeFieldMessage) {
  Response r;
  r.outcome = CallOutcome::kRefused;
  r.error.code = ErrorCode::kPointsCollinear;
  r.error.offending_type = MessageType::kMeasureDoorPlane;
  r.error.field = "points[2]";
  r.error.message = "the points are \"in a row\"";
  const auto v = parse(response_object("measure_plane", r));
  EXPECT_EQ(v.at("type").get<std::string>(), "error");
  EXPECT_FALSE(v.at("ok").get<bool>());
  EXPECT_EQ(v.at("error").at("code").get<std::string>(), "POINTS_COLLINEAR");
  EXPECT_EQ(v.at("error").at("offending_type").get<std::string>(), "MeasureDoorPlane");
  EXPECT_EQ(v.at("error").at("field").get<std::string>(), "points[2]");
  EXPECT_EQ(v.at("error").at("message").get<std::string>(), "the points are \"in a row\"");
  EXPECT_EQ(v.at("error").at("number").get<double>(), 307);
}

TEST(Json, TimeoutAndDisconnectAreErrorsWithClientCodes) {
  Response r;
  r.outcome = CallOutcome::kTimeout;
  r.transport_error = "no reply";
  auto v = parse(response_object("status", r));
  EXPECT_EQ(v.at("error").at("code").get<std::string>(), "TIMEOUT");
  r.outcome = CallOutcome::kDisconnected;
  v = parse(response_object("status", r));
  EXPECT_EQ(v.at("error").at("code").get<std::string>(), "DISCONNECTED");
  EXPECT_EQ(v.at("error").at("field").get<std::string>(), "");
}

// Every block of the layout, with the flag that says whether it holds a stored value.
TEST(Json, StatusNestsStoredParametersWithTheirFlags) {
  Response r;
  auto& s = reply_as<protocol::Status>(r);
  s.state = ProcedureState::kAligned;
  s.has_width = true;
  s.width.length_m = 0.9;
  s.has_plane = true;
  s.plane.left_counts = -3;
  s.base_yaw_odometry_rad = 0.25;
  const auto v = parse(response_object("status", r));
  const auto& st = v.at("status");
  EXPECT_EQ(st.at("state").get<std::string>(), "aligned");
  EXPECT_TRUE(st.at("has_width").get<bool>());
  EXPECT_EQ(st.at("width").at("length_m").get<double>(), 0.9);
  EXPECT_FALSE(st.at("has_handle").get<bool>());
  EXPECT_EQ(st.at("handle").at("length_m").get<double>(), 0);
  EXPECT_FALSE(st.at("has_contact").get<bool>());
  EXPECT_EQ(st.at("plane").at("left_counts").get<double>(), -3);
  EXPECT_EQ(st.at("base_yaw_odometry_rad").get<double>(), 0.25);
  EXPECT_EQ(st.at("loop").at("cycles").get<double>(), 0);
}

TEST(Json, EventsAndTelemetryAreObjects) {
  protocol::Event e;
  e.kind = protocol::EventKind::kFaultLatched;
  e.state = ProcedureState::kFault;
  e.fault = ErrorCode::kDeadman;
  e.detail = "controller \"gui\" went silent";
  auto v = parse(event_object(e));
  EXPECT_EQ(v.at("type").get<std::string>(), "event");
  EXPECT_EQ(v.at("kind").get<std::string>(), "fault_latched");
  EXPECT_EQ(v.at("fault").get<std::string>(), "DEADMAN");
  EXPECT_EQ(v.at("detail").get<std::string>(), "controller \"gui\" went silent");

  protocol::Telemetry t;
  t.left_wheel_rad = -0.5;
  t.right_wheel_rad = 0.5;
  t.left_counts = -100;
  t.right_counts = -100;
  t.moving = true;
  v = parse(telemetry_object(t));
  EXPECT_EQ(v.at("type").get<std::string>(), "telemetry");
  EXPECT_TRUE(v.at("moving").get<bool>());
  EXPECT_EQ(v.at("left_wheel_rad").get<double>(), -0.5);
  EXPECT_EQ(v.at("right_counts").get<double>(), -100);
}

// Protocol 1.1: the MotionBlock (odometry, door, staleness, commanded velocity, loop timing) under
// the wire names, in Status and Telemetry alike; the door's values with the flags that say whether
// they are known.
TEST(Json, StatusAndTelemetryCarryTheMotionBlock) {
  Response r;
  auto& s = reply_as<protocol::Status>(r);
  s.odometry_x_m = 0.5;
  s.odometry_y_m = -0.25;
  s.door.has_distance = true;
  s.door.distance_m = 1.25;
  s.staleness.plane = true;
  s.staleness.travel_since_plane_m = 0.31;
  s.has_plane = true;
  s.commanded_linear_m_s = 0.2;
  s.commanded_angular_rad_s = -0.1;
  s.timing.window_s = 1.0f;
  s.timing.recent.samples = 500;
  s.timing.recent.latency.p99_ns = 12345;
  s.realtime.policy = protocol::SchedulingPolicy::kFifo;
  s.realtime.priority = 80;
  s.realtime.memory_locked = true;
  auto v = parse(response_object("status", r));
  const auto& st = v.at("status");
  EXPECT_EQ(st.at("odometry_x_m").get<double>(), 0.5);
  EXPECT_EQ(st.at("odometry_y_m").get<double>(), -0.25);
  EXPECT_TRUE(st.at("door").at("has_distance").get<bool>());
  EXPECT_EQ(st.at("door").at("distance_m").get<double>(), 1.25);
  EXPECT_FALSE(st.at("door").at("has_yaw").get<bool>());
  EXPECT_TRUE(st.at("staleness").at("plane").get<bool>());
  EXPECT_FALSE(st.at("staleness").at("contact").get<bool>());
  EXPECT_EQ(st.at("staleness").at("travel_since_plane_m").get<double>(), 0.31);
  EXPECT_EQ(st.at("commanded_linear_m_s").get<double>(), 0.2);
  EXPECT_EQ(st.at("commanded_angular_rad_s").get<double>(), -0.1);
  EXPECT_EQ(st.at("timing").at("recent").at("samples").get<double>(), 500);
  EXPECT_EQ(st.at("timing").at("recent").at("latency").at("p99_ns").get<double>(), 12345);
  EXPECT_EQ(st.at("realtime").at("policy").get<std::string>(), "fifo");
  EXPECT_EQ(st.at("realtime").at("priority").get<double>(), 80);
  EXPECT_NE(status_text(s).find("plane (base moved"), std::string::npos) << status_text(s);

  protocol::Telemetry t;
  t.odometry_x_m = 0.1;
  t.door.has_distance = true;
  t.door.distance_m = 0.75;
  t.door.has_yaw = true;
  t.door.yaw_rad = 0.02;
  t.commanded_linear_m_s = 0.05;
  v = parse(telemetry_object(t));
  EXPECT_EQ(v.at("odometry_x_m").get<double>(), 0.1);
  EXPECT_EQ(v.at("door").at("distance_m").get<double>(), 0.75);
  EXPECT_EQ(v.at("door").at("yaw_rad").get<double>(), 0.02);
  EXPECT_EQ(v.at("commanded_linear_m_s").get<double>(), 0.05);
  EXPECT_FALSE(v.at("staleness").at("plane").get<bool>());
  const std::string text = telemetry_text(t);
  EXPECT_NE(text.find("door 0.7500 m"), std::string::npos) << text;
  EXPECT_NE(text.find("commanded +0.050 m/s"), std::string::npos) << text;
  // Without a known distance the flag says so (the text leaves the door out).
  t.door = {};
  EXPECT_FALSE(parse(telemetry_object(t)).at("door").at("has_distance").get<bool>());
  EXPECT_EQ(telemetry_text(t).find("door"), std::string::npos);
}

TEST(Json, RobotModelApproachAckAndDriverKind) {
  Response r;
  auto& m = reply_as<protocol::RobotModel>(r);
  m.camera_to_base = {0, 0, 1, 0.15, -1, 0, 0, 0.015, 0, -1, 0, -0.22};
  m.wheel_radius_m = 0.1;
  m.right.polarity = -1;
  m.right.card_axis = 2;
  m.drive_command_timeout_s = 0.5;
  auto v = parse(response_object("model", r));
  EXPECT_EQ(v.at("type").get<std::string>(), "robot_model");
  const auto& rm = v.at("robot_model");
  ASSERT_EQ(rm.at("camera_to_base").size(), 12u);  // rows of [R | t], as on the wire
  EXPECT_EQ(rm.at("camera_to_base").at(4).get<double>(), -1);
  EXPECT_EQ(rm.at("camera_to_base").at(11).get<double>(), -0.22);
  EXPECT_EQ(rm.at("wheel_radius_m").get<double>(), 0.1);
  EXPECT_EQ(rm.at("right").at("polarity").get<double>(), -1);
  EXPECT_EQ(rm.at("right").at("card_axis").get<double>(), 2);
  EXPECT_EQ(rm.at("drive_command_timeout_s").get<double>(), 0.5);
  EXPECT_NE(response_text("model", r).find("drive_command_timeout_s:"), std::string::npos);

  Response a;
  auto& body =
      ack_as<protocol::ApproachAck>(a, MessageType::kApproach, ProcedureState::kAwaitingWidth);
  body.travel_m = 0.25;
  body.start_distance_m = 1.0;
  body.left_counts = 198944;
  body.right_counts = -198944;
  v = parse(response_object("approach", a));
  EXPECT_EQ(v.at("acknowledged").get<std::string>(), "Approach");
  EXPECT_EQ(v.at("travel_m").get<double>(), 0.25);
  EXPECT_EQ(v.at("start_distance_m").get<double>(), 1.0);
  EXPECT_EQ(v.at("right_counts").get<double>(), -198944);

  protocol::Welcome w;
  w.driver_kind = protocol::DriverKind::kReal;
  EXPECT_EQ(parse(welcome_object(w)).at("driver_kind").get<std::string>(), "real");
}

// The same keys, in the same order, with the same values (numbers compared as numbers: 1 and 1.0
// are equal, NaN is null) as tests/client/json_golden.jsonl: a change of what ajarctl prints is a
// change of that file (AJAR_UPDATE_JSON_GOLDEN=1 rewrites it from the samples; review its diff).
TEST(Json, EveryRenderingMatchesTheGoldenLines) {
  using Ordered = nlohmann::ordered_json;
  const auto samples = json_samples::all();
  if (std::getenv("AJAR_UPDATE_JSON_GOLDEN") != nullptr) {
    std::ofstream out(AJAR_SOURCE_DIR "/tests/client/json_golden.jsonl");
    for (const auto& [name, object] : samples)
      out << Ordered::parse(object.str()).dump(-1, ' ', false, Ordered::error_handler_t::replace)
          << "\n";
  }
  std::ifstream golden(AJAR_SOURCE_DIR "/tests/client/json_golden.jsonl");
  ASSERT_TRUE(golden) << "tests/client/json_golden.jsonl";
  std::string line;
  std::size_t n = 0;
  for (; std::getline(golden, line); ++n) {
    ASSERT_LT(n, samples.size()) << "more golden lines than samples";
    const auto& [name, object] = samples[n];
    const std::string now = object.str();
    EXPECT_EQ(Ordered::parse(now), Ordered::parse(line))
        << name << "\n now: " << now << "\n was: " << line;
    EXPECT_EQ(now.find('\n'), std::string::npos) << name;
  }
  EXPECT_EQ(n, samples.size()) << "a sample without its golden line";
}

// Status.recorder (1.2): under the wire names in --json, two lines of text; only when the session
// speaks 1.2 (a 1.1 daemon's Status has no recorder: zeros would say "off", which it never said).
TEST(Json, StatusShowsTheRecorderOnlyFromA12Session) {
  protocol::Status s = json_samples::status();
  s.recorder = json_samples::recorder();
  const auto v = parse(status_object(s, 2));
  const auto& r = v.at("recorder");
  EXPECT_EQ(r.at("mode").get<std::string>(), "disk_full");
  EXPECT_EQ(r.at("file").get<std::string>(), "ajard-20261126T130501123Z.mcap");
  EXPECT_EQ(r.at("loop_dropped").get<std::uint64_t>(), 12u);
  EXPECT_EQ(r.at("io_dropped").get<std::uint64_t>(), 3u);
  EXPECT_EQ(r.at("records_lost").get<std::uint64_t>(), 7u);
  EXPECT_EQ(r.at("disk_free_bytes").get<std::uint64_t>(), 18446744073709551615u);
  EXPECT_EQ(r.size(), 16u) << "every field of RecorderState";
  EXPECT_FALSE(parse(status_object(s, 1)).contains("recorder"));
  const std::string text = status_text(s, 2);
  EXPECT_NE(text.find("black box:        disk_full, ajard-20261126T130501123Z.mcap 120.6 KiB; "
                      "94.2 MiB of the 512.0 MiB budget"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("black box counts: 1000 written; loop 900 samples, 12 dropped; I/O 300 "
                      "records, 3 dropped; 7 lost to the disk (2 refusals); last write at "
                      "5.000 s"),
            std::string::npos)
      << text;
  EXPECT_EQ(status_text(s, 1).find("black box"), std::string::npos);
}

// Bytes that are not UTF-8 (a daemon's message is any bytes) still give valid JSON, never a throw.
TEST(Json, InvalidUtf8IsReplacedNotThrown) {
  JsonObject o;
  o.add("message", "gripper \xff\xfe stuck");
  std::string text;
  ASSERT_NO_THROW(text = o.str());
  EXPECT_EQ(parse(o).at("message").get<std::string>(), "gripper \xef\xbf\xbd\xef\xbf\xbd stuck");
}

TEST(Json, ArraysNestAndAMovedFromObjectIsEmpty) {
  JsonArray row;
  row.add(0.5).add(std::int64_t{-3}).add("x");
  JsonArray rows;
  rows.add(row).add(JsonObject().add("k", true));
  JsonObject o;
  o.add("rows", rows).add_null("none").add("rows", JsonArray().add(rows));
  EXPECT_EQ(o.str(), R"({"rows":[[[0.5,-3,"x"],{"k":true}]],"none":null})")
      << "a key added twice keeps its first place and its last value";
  EXPECT_EQ(rows.size(), 2u);
  JsonObject moved = std::move(o);
  EXPECT_FALSE(moved.empty());
  EXPECT_TRUE(o.empty());  // NOLINT(bugprone-use-after-move): the documented moved-from state
  EXPECT_EQ(o.str(), "{}");
  o.add("again", 1);
  EXPECT_EQ(o.str(), R"({"again":1})");
}

}  // namespace
}  // namespace ajar::client
