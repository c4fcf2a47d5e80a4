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

TEST(Json, MiniParserRejectsNonJson) {
  EXPECT_THROW(mini_json::parse("{\"a\": nan}"), std::runtime_error);
  EXPECT_THROW(mini_json::parse("{\"a\": 1,}"), std::runtime_error);
  EXPECT_THROW(mini_json::parse("{\"a\": \"x\ny\"}"), std::runtime_error);
}

}  // namespace
}  // namespace ajar::client
