// ajarctl --json output: every rendering is one valid JSON object with the documented fields.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "ajar/client/json.hpp"
#include "ajar/client/output.hpp"
#include "mini_json.hpp"

namespace ajar::client {
namespace {

using protocol::MessageType;
using protocol::ProcedureState;

// Builds the reply in place (no copies of the big variants: GCC 12 under ASan warns about them).
template <typename T>
T& reply_as(Response& r) {
  r.outcome = Outcome::kReply;
  r.request_id = 7;
  return r.reply.emplace<T>();
}

template <typename Body>
Body& ack_as(Response& r, MessageType acknowledged, ProcedureState state) {
  auto& ack = reply_as<protocol::Ack>(r);
  ack.acknowledged = acknowledged;
  ack.state = state;
  return ack.body.emplace<Body>();
}

mini_json::Value parse(const JsonObject& o) {
  const std::string text = o.str();
  EXPECT_EQ(text.find('\n'), std::string::npos) << "one object per line";
  return mini_json::parse(text);
}

TEST(Json, EscapesQuotesBackslashesAndControlCharacters) {
  const std::string nasty = "a\"b\\c\nd\te\x01f\x7f";
  JsonObject o;
  o.add("s", nasty);
  const auto v = parse(o);
  EXPECT_EQ(v["s"].string(), nasty);
  EXPECT_EQ(json_escape("\x01"), "\\u0001");
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
  EXPECT_TRUE(v["nan"].is_null());
  EXPECT_EQ(v["i"].number(), -42);
}

TEST(Json, WidthAckCarriesWidthDirectionAndBasePoints) {
  Response r;
  auto& span =
      ack_as<protocol::SpanAck>(r, MessageType::kMeasureDoorWidth, ProcedureState::kAwaitingHandle);
  span.length_m = 0.9152;
  span.direction = core::RotationDirection::kCounterClockwise;
  span.p1_base_m = core::Vec3(1.21, 0.43, 0.02);
  const auto v = parse(response_object("measure_width", r));
  EXPECT_EQ(v["type"].string(), "ack");
  EXPECT_EQ(v["command"].string(), "measure_width");
  EXPECT_TRUE(v["ok"].boolean());
  EXPECT_EQ(v["state"].string(), "awaiting_handle");
  EXPECT_EQ(v["width_m"].number(), 0.9152);
  EXPECT_EQ(v["direction"].string(), "CCW");
  ASSERT_EQ(v["p1_base_m"].array().size(), 3u);
  EXPECT_EQ(v["p1_base_m"].array()[1].number(), 0.43);
  EXPECT_FALSE(v.has("handle_length_m"));
}

TEST(Json, HandleAckUsesHandleLength) {
  Response r;
  ack_as<protocol::SpanAck>(r, MessageType::kMeasureHandle, ProcedureState::kAwaitingPlane)
      .length_m = 0.12;
  const auto v = parse(response_object("measure_handle", r));
  EXPECT_EQ(v["handle_length_m"].number(), 0.12);
  EXPECT_EQ(v["direction"].string(), "CW");
  EXPECT_FALSE(v.has("width_m"));
}

TEST(Json, PlaneAckCarriesYawAndWheelsLeftRight) {
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
  EXPECT_EQ(v["yaw_deviation_rad"].number(), -0.0277);
  EXPECT_EQ(v["wheel_angle_rad"]["left"].number(), 0.0693);
  EXPECT_EQ(v["wheel_angle_rad"]["right"].number(), -0.0693);
  EXPECT_EQ(v["wheel_counts"]["left"].number(), 5517);
  EXPECT_EQ(v["wheel_counts"]["right"].number(), 5517);
  EXPECT_EQ(v["point_count"].number(), 4);
}

TEST(Json, ContactAckCarriesContactBase) {
  Response r;
  auto& contact = ack_as<protocol::ContactAck>(r, MessageType::kSetContactPoint,
                                               ProcedureState::kReadyToEngage);
  contact.contact_base_m = core::Vec3(0.8, -0.01, 0.3);
  contact.reach_margin_m = 0.4;
  const auto v = parse(response_object("contact", r));
  ASSERT_EQ(v["contact_base_m"].array().size(), 3u);
  EXPECT_EQ(v["contact_base_m"].array()[0].number(), 0.8);
  EXPECT_EQ(v["contact_base_m"].array()[1].number(), -0.01);
  EXPECT_EQ(v["reach_margin_m"].number(), 0.4);
}

TEST(Json, RefusalCarriesErrorCodeFieldMessage) {
  Response r;
  r.outcome = Outcome::kRefused;
  r.error.code = ErrorCode::kPointsCollinear;
  r.error.field = "points[2]";
  r.error.message = "the points are \"in a row\"";
  const auto v = parse(response_object("measure_plane", r));
  EXPECT_EQ(v["type"].string(), "error");
  EXPECT_FALSE(v["ok"].boolean());
  EXPECT_EQ(v["error"]["code"].string(), "POINTS_COLLINEAR");
  EXPECT_EQ(v["error"]["field"].string(), "points[2]");
  EXPECT_EQ(v["error"]["message"].string(), "the points are \"in a row\"");
  EXPECT_EQ(v["error"]["number"].number(), 307);
}

TEST(Json, TimeoutAndDisconnectAreErrorsWithClientCodes) {
  Response r;
  r.outcome = Outcome::kTimeout;
  r.transport_error = "no reply";
  auto v = parse(response_object("status", r));
  EXPECT_EQ(v["error"]["code"].string(), "TIMEOUT");
  r.outcome = Outcome::kDisconnected;
  v = parse(response_object("status", r));
  EXPECT_EQ(v["error"]["code"].string(), "DISCONNECTED");
  EXPECT_EQ(v["error"]["field"].string(), "");
}

TEST(Json, StatusNestsStoredParametersOnlyWhenPresent) {
  Response r;
  auto& s = reply_as<protocol::Status>(r);
  s.state = ProcedureState::kAligned;
  s.has_width = true;
  s.width.length_m = 0.9;
  s.has_plane = true;
  s.plane.left_counts = -3;
  s.base_yaw_odometry_rad = 0.25;
  const auto v = parse(response_object("status", r));
  const auto& st = v["status"];
  EXPECT_EQ(st["state"].string(), "aligned");
  EXPECT_EQ(st["width"]["width_m"].number(), 0.9);
  EXPECT_FALSE(st.has("handle"));
  EXPECT_FALSE(st.has("contact"));
  EXPECT_EQ(st["plane"]["wheel_counts"]["left"].number(), -3);
  EXPECT_EQ(st["base_yaw_odometry_rad"].number(), 0.25);
  EXPECT_EQ(st["loop"]["cycles"].number(), 0);
}

TEST(Json, EventsAndTelemetryAreObjects) {
  protocol::Event e;
  e.kind = protocol::EventKind::kFaultLatched;
  e.state = ProcedureState::kFault;
  e.fault = ErrorCode::kDeadman;
  e.detail = "controller \"gui\" went silent";
  auto v = parse(event_object(e));
  EXPECT_EQ(v["type"].string(), "event");
  EXPECT_EQ(v["kind"].string(), "fault_latched");
  EXPECT_EQ(v["fault"].string(), "DEADMAN");
  EXPECT_EQ(v["detail"].string(), "controller \"gui\" went silent");

  protocol::Telemetry t;
  t.left_wheel_rad = -0.5;
  t.right_wheel_rad = 0.5;
  t.left_counts = -100;
  t.right_counts = -100;
  t.moving = true;
  v = parse(telemetry_object(t));
  EXPECT_EQ(v["type"].string(), "telemetry");
  EXPECT_TRUE(v["moving"].boolean());
  EXPECT_EQ(v["wheel_angle_rad"]["left"].number(), -0.5);
  EXPECT_EQ(v["wheel_counts"]["right"].number(), -100);
}

// Protocol 1.1: the MotionBlock (odometry, door, staleness, commanded velocity, loop timing) under
// the wire names, in Status and Telemetry alike; the door's values only when known.
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
  const auto& st = v["status"];
  EXPECT_EQ(st["odometry_x_m"].number(), 0.5);
  EXPECT_EQ(st["odometry_y_m"].number(), -0.25);
  EXPECT_EQ(st["door"]["distance_m"].number(), 1.25);
  EXPECT_FALSE(st["door"].has("yaw_rad")) << "has_yaw false: no yaw_rad";
  EXPECT_TRUE(st["staleness"]["plane"].boolean());
  EXPECT_FALSE(st["staleness"]["contact"].boolean());
  EXPECT_EQ(st["staleness"]["travel_since_plane_m"].number(), 0.31);
  EXPECT_EQ(st["commanded_linear_m_s"].number(), 0.2);
  EXPECT_EQ(st["commanded_angular_rad_s"].number(), -0.1);
  EXPECT_EQ(st["timing"]["recent"]["samples"].number(), 500);
  EXPECT_EQ(st["timing"]["recent"]["latency"]["p99_ns"].number(), 12345);
  EXPECT_EQ(st["realtime"]["policy"].string(), "fifo");
  EXPECT_EQ(st["realtime"]["priority"].number(), 80);
  EXPECT_NE(status_text(s).find("plane (base moved"), std::string::npos) << status_text(s);

  protocol::Telemetry t;
  t.odometry_x_m = 0.1;
  t.door.has_distance = true;
  t.door.distance_m = 0.75;
  t.door.has_yaw = true;
  t.door.yaw_rad = 0.02;
  t.commanded_linear_m_s = 0.05;
  v = parse(telemetry_object(t));
  EXPECT_EQ(v["odometry_x_m"].number(), 0.1);
  EXPECT_EQ(v["door"]["distance_m"].number(), 0.75);
  EXPECT_EQ(v["door"]["yaw_rad"].number(), 0.02);
  EXPECT_EQ(v["commanded_linear_m_s"].number(), 0.05);
  EXPECT_FALSE(v["staleness"]["plane"].boolean());
  const std::string text = telemetry_text(t);
  EXPECT_NE(text.find("door 0.7500 m"), std::string::npos) << text;
  EXPECT_NE(text.find("commanded +0.050 m/s"), std::string::npos) << text;
  // Without a known distance the door is absent, not 0.
  t.door = {};
  EXPECT_FALSE(parse(telemetry_object(t))["door"].has("distance_m"));
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
  EXPECT_EQ(v["type"].string(), "robot_model");
  const auto& rm = v["robot_model"];
  EXPECT_EQ(rm["camera_to_base"].array()[1].array()[0].number(), -1);
  EXPECT_EQ(rm["camera_to_base"].array()[2].array()[3].number(), -0.22);
  EXPECT_EQ(rm["wheel_radius_m"].number(), 0.1);
  EXPECT_EQ(rm["right"]["polarity"].number(), -1);
  EXPECT_EQ(rm["right"]["card_axis"].number(), 2);
  EXPECT_EQ(rm["drive_command_timeout_s"].number(), 0.5);
  EXPECT_NE(response_text("model", r).find("drive_command_timeout_s:"), std::string::npos);

  Response a;
  auto& body =
      ack_as<protocol::ApproachAck>(a, MessageType::kApproach, ProcedureState::kAwaitingWidth);
  body.travel_m = 0.25;
  body.start_distance_m = 1.0;
  body.left_counts = 198944;
  body.right_counts = -198944;
  v = parse(response_object("approach", a));
  EXPECT_EQ(v["acknowledged"].string(), "Approach");
  EXPECT_EQ(v["travel_m"].number(), 0.25);
  EXPECT_EQ(v["start_distance_m"].number(), 1.0);
  EXPECT_EQ(v["wheel_counts"]["right"].number(), -198944);

  protocol::Welcome w;
  w.driver_kind = protocol::DriverKind::kReal;
  EXPECT_EQ(parse(welcome_object(w))["driver_kind"].string(), "real");
}

TEST(Json, MiniParserRejectsNonJson) {
  EXPECT_THROW(mini_json::parse("{\"a\": nan}"), std::runtime_error);
  EXPECT_THROW(mini_json::parse("{\"a\": 1,}"), std::runtime_error);
  EXPECT_THROW(mini_json::parse("{\"a\": \"x\ny\"}"), std::runtime_error);
}

}  // namespace
}  // namespace ajar::client
