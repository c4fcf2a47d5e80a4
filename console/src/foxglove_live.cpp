// Ajar live in Foxglove: the channel table with its JSON Schemas and the message builders
// (foxglove_live.hpp).
#include "foxglove_live.hpp"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <cmath>

#include "ajar/client/json.hpp"
#include "ajar/client/output.hpp"
#include "ajar/core/error.hpp"
#include "ajar/recorder/channels.hpp"

namespace ajar::console {

using Json = nlohmann::ordered_json;

namespace {

// ---- JSON Schema pieces (draft 2020-12 keywords: type, properties, required, items, enum) ----
Json number() {
  return {{"type", "number"}};
}
Json integer(std::optional<std::int64_t> minimum = std::nullopt) {
  Json j{{"type", "integer"}};
  if (minimum) j["minimum"] = *minimum;
  return j;
}
Json string() {
  return {{"type", "string"}};
}
Json boolean() {
  return {{"type", "boolean"}};
}
Json array(Json items) {
  return {{"type", "array"}, {"items", std::move(items)}};
}
Json object(const std::string& title, Json properties, bool all_required = true) {
  Json j{{"type", "object"}};
  if (!title.empty()) j["title"] = title;
  Json required = Json::array();
  for (const auto& [k, v] : properties.items())
    required.push_back(k);
  j["properties"] = std::move(properties);
  if (all_required) j["required"] = std::move(required);
  return j;
}
Json time_schema() {
  return object("time", {{"sec", integer(0)},
                         {"nsec", {{"type", "integer"}, {"minimum", 0}, {"maximum", 999999999}}}});
}
Json duration_schema() {
  return object("duration",
                {{"sec", integer()},
                 {"nsec", {{"type", "integer"}, {"minimum", 0}, {"maximum", 999999999}}}});
}
Json vec3_schema(const char* title = "foxglove.Vector3") {
  return object(title, {{"x", number()}, {"y", number()}, {"z", number()}});
}
Json quat_schema() {
  return object("foxglove.Quaternion",
                {{"x", number()}, {"y", number()}, {"z", number()}, {"w", number()}});
}
Json pose_schema() {
  return object("foxglove.Pose", {{"position", vec3_schema()}, {"orientation", quat_schema()}});
}
Json color_schema() {
  return object("foxglove.Color",
                {{"r", number()}, {"g", number()}, {"b", number()}, {"a", number()}});
}

Json frame_transform_schema() {
  Json s = object("foxglove.FrameTransform", {{"timestamp", time_schema()},
                                              {"parent_frame_id", string()},
                                              {"child_frame_id", string()},
                                              {"translation", vec3_schema()},
                                              {"rotation", quat_schema()}});
  s["description"] = "A transform between two reference frames in 3D space";
  return s;
}

Json scene_update_schema() {
  const Json shape =
      object("", {{"pose", pose_schema()}, {"size", vec3_schema()}, {"color", color_schema()}});
  Json cube = shape;
  cube["title"] = "foxglove.CubePrimitive";
  Json sphere = shape;
  sphere["title"] = "foxglove.SpherePrimitive";
  const Json line =
      object("foxglove.LinePrimitive",
             {{"type", {{"title", "foxglove.LineType"}, {"enum", {0, 1, 2}}}},  // strip, loop, list
              {"pose", pose_schema()},
              {"thickness", number()},
              {"scale_invariant", boolean()},
              {"points", array(vec3_schema("foxglove.Point3"))},
              {"color", color_schema()},
              {"colors", array(color_schema())},
              {"indices", array(integer(0))}});
  const Json text = object("foxglove.TextPrimitive", {{"pose", pose_schema()},
                                                      {"billboard", boolean()},
                                                      {"font_size", number()},
                                                      {"scale_invariant", boolean()},
                                                      {"color", color_schema()},
                                                      {"text", string()}});
  const Json arrow = object("foxglove.ArrowPrimitive", {{"pose", pose_schema()},
                                                        {"shaft_length", number()},
                                                        {"shaft_diameter", number()},
                                                        {"head_length", number()},
                                                        {"head_diameter", number()},
                                                        {"color", color_schema()}});
  const Json entity =
      object("foxglove.SceneEntity",
             {{"timestamp", time_schema()},
              {"frame_id", string()},
              {"id", string()},
              {"lifetime", duration_schema()},
              {"frame_locked", boolean()},
              {"metadata",
               array(object("foxglove.KeyValuePair", {{"key", string()}, {"value", string()}}))},
              {"arrows", array(arrow)},
              {"cubes", array(cube)},
              {"spheres", array(sphere)},
              // Ajar sends none of these (always empty); foxglove.SceneEntity requires the arrays.
              {"cylinders", array({{"type", "object"}})},
              {"lines", array(line)},
              {"triangles", array({{"type", "object"}})},
              {"texts", array(text)},
              {"models", array({{"type", "object"}})}});
  const Json deletion = object(
      "foxglove.SceneEntityDeletion",
      {{"timestamp", time_schema()},
       {"type",
        {{"title", "foxglove.SceneEntityDeletionType"}, {"enum", {0, 1}}}},  // matching id, all
       {"id", string()}});
  Json s =
      object("foxglove.SceneUpdate", {{"deletions", array(deletion)}, {"entities", array(entity)}});
  s["description"] = "An update to the entities displayed in a 3D scene";
  return s;
}

Json compressed_image_schema() {
  Json data = string();
  data["contentEncoding"] = "base64";
  Json s = object("foxglove.CompressedImage", {{"timestamp", time_schema()},
                                               {"frame_id", string()},
                                               {"data", data},
                                               {"format", {{"enum", {"jpeg", "png"}}}}});
  s["description"] = "A compressed image";
  return s;
}

Json camera_calibration_schema() {
  const auto fixed = [](int n) {
    Json a = array(number());
    a["minItems"] = n;
    a["maxItems"] = n;
    return a;
  };
  Json s = object("foxglove.CameraCalibration", {{"timestamp", time_schema()},
                                                 {"frame_id", string()},
                                                 {"width", integer(0)},
                                                 {"height", integer(0)},
                                                 {"distortion_model", string()},
                                                 {"D", array(number())},
                                                 {"K", fixed(9)},
                                                 {"R", fixed(9)},
                                                 {"P", fixed(12)}});
  s["description"] = "Camera calibration parameters (a pinhole camera: no distortion)";
  return s;
}

// ---- message pieces ----
Json stamp(std::uint64_t unix_ns) {
  return {{"sec", unix_ns / 1000000000U}, {"nsec", unix_ns % 1000000000U}};
}
Json vec3(const Eigen::Vector3d& v) {
  return {{"x", v.x()}, {"y", v.y()}, {"z", v.z()}};
}
Json quat(const Eigen::Quaterniond& q) {
  return {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}};
}
Json pose(const Eigen::Vector3d& p, const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity()) {
  return {{"position", vec3(p)}, {"orientation", quat(q)}};
}
Json color(double r, double g, double b, double a = 1.0) {
  return {{"r", r}, {"g", g}, {"b", b}, {"a", a}};
}
Json sphere(const Eigen::Vector3d& p, double d, const Json& c) {
  return {{"pose", pose(p)}, {"size", vec3(Eigen::Vector3d::Constant(d))}, {"color", c}};
}
Json line(const std::vector<Eigen::Vector3d>& points, const Json& c) {
  Json pts = Json::array();
  for (const auto& p : points)
    pts.push_back(vec3(p));
  return {{"type", 2},
          {"pose", pose(Eigen::Vector3d::Zero())},
          {"thickness", 0.01},
          {"scale_invariant", false},
          {"points", pts},
          {"color", c},
          {"colors", Json::array()},
          {"indices", Json::array()}};
}
Json text(const Eigen::Vector3d& p, const std::string& words) {
  return {{"pose", pose(p)},         {"billboard", true},       {"font_size", 14.0},
          {"scale_invariant", true}, {"color", color(1, 1, 1)}, {"text", words}};
}
Json entity(const std::string& id, std::uint64_t unix_ns) {
  return {{"timestamp", stamp(unix_ns)},
          {"frame_id", "base_link"},
          {"id", id},
          {"lifetime", {{"sec", 0}, {"nsec", 0}}},
          {"frame_locked", false},
          {"metadata", Json::array()},
          {"arrows", Json::array()},
          {"cubes", Json::array()},
          {"spheres", Json::array()},
          {"cylinders", Json::array()},
          {"lines", Json::array()},
          {"triangles", Json::array()},
          {"texts", Json::array()},
          {"models", Json::array()}};
}
void meta(Json& e, const std::string& key, const std::string& value) {
  e["metadata"].push_back({{"key", key}, {"value", value}});
}
std::string metres(double v) {
  std::array<char, 32> b{};
  std::snprintf(b.data(), b.size(), "%.3f m", v);
  return b.data();
}

// A rotation whose x axis is `x` and whose z axis is as close to up as x allows.
Eigen::Quaterniond facing(const Eigen::Vector3d& x) {
  Eigen::Vector3d ax = x.normalized();
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ() - ax.dot(Eigen::Vector3d::UnitZ()) * ax;
  if (up.norm() < 1e-6) up = Eigen::Vector3d::UnitY();
  up.normalize();
  Eigen::Matrix3d r;
  r.col(0) = ax;
  r.col(1) = up.cross(ax);
  r.col(2) = up;
  return Eigen::Quaterniond(r).normalized();
}

constexpr double kDoorHeight_m = 2.0;    // drawn height of the plane (the daemon measures none)
constexpr double kDefaultWidth_m = 0.9;  // drawn width of a plane measured before the width

std::string base64(const std::vector<std::uint8_t>& bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t v = (std::uint32_t{bytes[i]} << 16) | (std::uint32_t{bytes[i + 1]} << 8) |
                            std::uint32_t{bytes[i + 2]};
    out += kAlphabet[(v >> 18) & 63U];
    out += kAlphabet[(v >> 12) & 63U];
    out += kAlphabet[(v >> 6) & 63U];
    out += kAlphabet[v & 63U];
  }
  if (i < bytes.size()) {
    std::uint32_t v = std::uint32_t{bytes[i]} << 16;
    if (i + 1 < bytes.size()) v |= std::uint32_t{bytes[i + 1]} << 8;
    out += kAlphabet[(v >> 18) & 63U];
    out += kAlphabet[(v >> 12) & 63U];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63U] : '=';
    out += '=';
  }
  return out;
}

}  // namespace

std::vector<foxglove::Channel> foxglove_channels() {
  // Telemetry and events: the recorder's rows (topic, schema), so a recording and the live view
  // look the same in Foxglove.
  const auto recorded = [](FoxgloveChannel id, std::uint16_t recorder_channel) {
    const auto* row = recorder::channel_by_id(recorder_channel);
    foxglove::Channel c;
    c.id = id;
    c.topic = std::string(row->topic);
    c.encoding = std::string(row->message_encoding);
    c.schema_name = std::string(row->schema_name);
    c.schema_encoding = std::string(row->schema_encoding);
    c.schema = std::string(row->schema);
    return c;
  };
  const auto channel = [](FoxgloveChannel id, const char* topic, const Json& schema, bool latched) {
    foxglove::Channel c;
    c.id = id;
    c.topic = topic;
    c.schema_name = schema["title"].get<std::string>();
    c.schema = schema.dump();
    c.latched = latched;
    return c;
  };
  return {
      recorded(kFoxgloveTelemetry, recorder::kTelemetryChannel),
      recorded(kFoxgloveEvents, recorder::kEventsChannel),
      channel(kFoxgloveOdometry, "/tf", frame_transform_schema(), false),
      channel(kFoxgloveCameraMount, "/tf_static", frame_transform_schema(), true),
      channel(kFoxgloveDoor, "/ajar/door", scene_update_schema(), true),
      channel(kFoxgloveImage, "/ajar/camera/image", compressed_image_schema(), false),
      channel(kFoxgloveCalibration, "/ajar/camera/calibration", camera_calibration_schema(), true)};
}

// The recorder's ajar.Telemetry (recorder/include/ajar/recorder/channels.hpp) with the rest of
// the sample's fields (the door, staleness, counts and the loop's statistics) after them.
std::string foxglove_telemetry_json(const protocol::Telemetry& t) {
  return Json{{"daemon_time_ns", t.daemon_time_ns},
              {"state", std::string(protocol::to_string(t.state))},
              {"moving", t.moving},
              {"left_wheel_rad", t.left_wheel_rad},
              {"right_wheel_rad", t.right_wheel_rad},
              {"base_yaw_odometry_rad", t.base_yaw_odometry_rad},
              {"odometry_x_m", t.odometry_x_m},
              {"odometry_y_m", t.odometry_y_m},
              {"arm_state", std::string(protocol::to_string(t.arm_state))},
              {"commanded_linear_m_s", t.commanded_linear_m_s},
              {"commanded_angular_rad_s", t.commanded_angular_rad_s},
              {"left_counts", t.left_counts},
              {"right_counts", t.right_counts},
              {"door_has_distance", t.door.has_distance},
              {"door_distance_m", t.door.distance_m},
              {"door_has_yaw", t.door.has_yaw},
              {"door_yaw_rad", t.door.yaw_rad},
              {"plane_stale", t.staleness.plane},
              {"contact_stale", t.staleness.contact},
              {"loop", Json::parse(client::loop_object(t.loop).str())}}
      .dump();
}

// The recorder's ajar.Event.
std::string foxglove_event_json(const protocol::Event& e) {
  return Json{{"daemon_time_ns", e.daemon_time_ns},
              {"kind", std::string(protocol::to_string(e.kind))},
              {"state", std::string(protocol::to_string(e.state))},
              {"fault", std::string(ajar::to_string(e.fault))},
              {"detail", std::string(e.detail.view())}}
      .dump();
}

std::string foxglove_odometry_json(const protocol::Telemetry& t, std::uint64_t unix_ns) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(t.base_yaw_odometry_rad, Eigen::Vector3d::UnitZ()));
  return Json{{"timestamp", stamp(unix_ns)},
              {"parent_frame_id", "odom"},
              {"child_frame_id", "base_link"},
              {"translation", vec3({t.odometry_x_m, t.odometry_y_m, 0})},
              {"rotation", quat(q)}}
      .dump();
}

std::string foxglove_camera_mount_json(const protocol::RobotModel& m, std::uint64_t unix_ns) {
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col)
      r(row, col) = m.camera_to_base[static_cast<std::size_t>(row * 4 + col)];
    t(row) = m.camera_to_base[static_cast<std::size_t>(row * 4 + 3)];
  }
  return Json{{"timestamp", stamp(unix_ns)},
              {"parent_frame_id", "base_link"},
              {"child_frame_id", "camera"},
              {"translation", vec3(t)},
              {"rotation", quat(Eigen::Quaterniond(r).normalized())}}
      .dump();
}

std::string foxglove_door_json(const protocol::Status& s, std::uint64_t unix_ns,
                               bool entities_only) {
  const std::uint64_t t = entities_only ? 0 : unix_ns;
  Json entities = Json::array();
  const Json edge_colour = color(0.2, 0.8, 0.3);
  if (s.has_width) {
    Json e = entity("door_width", t);
    const Eigen::Vector3d p1 = s.width.p1_base_m, p2 = s.width.p2_base_m;
    e["lines"].push_back(line({p1, p2}, edge_colour));
    e["spheres"].push_back(sphere(p1, 0.05, color(0.2, 0.8, 0.3)));  // hinge side
    e["spheres"].push_back(sphere(p2, 0.05, color(1.0, 0.6, 0.1)));  // moving edge
    e["texts"].push_back(text((p1 + p2) / 2 + Eigen::Vector3d(0, 0, 0.1),
                              "width " + metres(s.width.length_m) + ", opens " +
                                  std::string(core::to_string(s.width.direction))));
    meta(e, "width_m", std::to_string(s.width.length_m));
    meta(e, "direction", std::string(core::to_string(s.width.direction)));
    entities.push_back(std::move(e));
  }
  if (s.has_handle) {
    Json e = entity("handle", t);
    const Eigen::Vector3d p1 = s.handle.p1_base_m, p2 = s.handle.p2_base_m;
    e["lines"].push_back(line({p1, p2}, color(0.9, 0.9, 0.2)));
    e["spheres"].push_back(sphere(p1, 0.03, color(0.9, 0.9, 0.2)));
    e["spheres"].push_back(sphere(p2, 0.03, color(0.9, 0.9, 0.2)));
    e["texts"].push_back(
        text(p2 + Eigen::Vector3d(0, 0, 0.08), "handle " + metres(s.handle.length_m)));
    meta(e, "length_m", std::to_string(s.handle.length_m));
    entities.push_back(std::move(e));
  }
  if (s.has_plane && s.plane.normal.norm() > 0.5) {
    const Eigen::Vector3d n = s.plane.normal.normalized();  // toward the robot
    // A point of the door: the width points' middle when measured, else the foot of the
    // perpendicular from the base origin (the daemon's door distance).
    Eigen::Vector3d centre = -n * (s.door.has_distance ? s.door.distance_m : 1.0);
    double width_m = kDefaultWidth_m;
    if (s.has_width) {
      centre = (s.width.p1_base_m + s.width.p2_base_m) / 2;
      width_m = s.width.length_m;
    }
    centre.z() = kDoorHeight_m / 2;
    const bool stale = s.staleness.plane;
    Json e = entity("door_plane", t);
    e["cubes"].push_back(
        {{"pose", pose(centre, facing(n))},
         {"size", vec3({0.02, width_m, kDoorHeight_m})},
         {"color", stale ? color(0.5, 0.5, 0.5, 0.35) : color(0.2, 0.5, 1.0, 0.35)}});
    e["arrows"].push_back({{"pose", pose(centre, facing(n))},
                           {"shaft_length", 0.3},
                           {"shaft_diameter", 0.02},
                           {"head_length", 0.08},
                           {"head_diameter", 0.05},
                           {"color", color(0.2, 0.5, 1.0)}});
    meta(e, "normal",
         std::to_string(n.x()) + " " + std::to_string(n.y()) + " " + std::to_string(n.z()));
    meta(e, "yaw_deviation_rad", std::to_string(s.plane.yaw_deviation_rad));
    meta(e, "stale", stale ? "true" : "false");
    entities.push_back(std::move(e));
  }
  if (s.has_contact) {
    Json e = entity("contact", t);
    const Eigen::Vector3d c = s.contact.contact_base_m;
    const bool stale = s.staleness.contact;
    e["spheres"].push_back(sphere(c, 0.06, stale ? color(0.5, 0.5, 0.5) : color(1.0, 0.2, 0.2)));
    e["texts"].push_back(text(c + Eigen::Vector3d(0, 0, 0.1),
                              std::string(stale ? "contact (STALE)" : "contact") +
                                  ", reach margin " + metres(s.contact.reach_margin_m)));
    meta(e, "reach_margin_m", std::to_string(s.contact.reach_margin_m));
    meta(e, "stale", stale ? "true" : "false");
    entities.push_back(std::move(e));
  }
  if (entities_only) return entities.dump();
  // Each update replaces the whole scene: what the daemon no longer stores disappears.
  const Json deletions = Json::array({{{"timestamp", stamp(unix_ns)}, {"type", 1}, {"id", ""}}});
  return Json{{"deletions", deletions}, {"entities", entities}}.dump();
}

std::string foxglove_image_json(const std::vector<std::uint8_t>& png, std::uint64_t unix_ns) {
  return Json{{"timestamp", stamp(unix_ns)},
              {"frame_id", "camera"},
              {"data", base64(png)},
              {"format", "png"}}
      .dump();
}

// The pinhole model of core/camera.hpp (pixel centres at integers), no distortion: an Image panel
// draws the 3D scene over the camera image with it.
std::string foxglove_calibration_json(const core::PinholeIntrinsics& k, std::uint64_t unix_ns) {
  return Json{{"timestamp", stamp(unix_ns)},
              {"frame_id", "camera"},
              {"width", k.width_px},
              {"height", k.height_px},
              {"distortion_model", "plumb_bob"},
              {"D", {0.0, 0.0, 0.0, 0.0, 0.0}},
              {"K", {k.fx_px, 0.0, k.cx_px, 0.0, k.fy_px, k.cy_px, 0.0, 0.0, 1.0}},
              {"R", {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}},
              {"P", {k.fx_px, 0.0, k.cx_px, 0.0, 0.0, k.fy_px, k.cy_px, 0.0, 0.0, 0.0, 1.0, 0.0}}}
      .dump();
}

FoxgloveLive::FoxgloveLive(foxglove::ServerOptions options)
    : server_(std::move(options), foxglove_channels()) {}

void FoxgloveLive::on_telemetry(const protocol::Telemetry& t) {
  const auto now = foxglove::unix_time_ns();
  if (server_.subscribed(kFoxgloveTelemetry))
    server_.publish(kFoxgloveTelemetry, now, [t] { return foxglove_telemetry_json(t); });
  if (server_.subscribed(kFoxgloveOdometry))
    server_.publish(kFoxgloveOdometry, now, [t, now] { return foxglove_odometry_json(t, now); });
}

void FoxgloveLive::on_event(const protocol::Event& e) {
  server_.publish(kFoxgloveEvents, foxglove::unix_time_ns(),
                  [e] { return foxglove_event_json(e); });
}

void FoxgloveLive::on_status(const protocol::Status& s) {
  std::string entities = foxglove_door_json(s, 0, true);
  if (entities == last_door_) return;
  last_door_ = std::move(entities);
  const auto now = foxglove::unix_time_ns();
  server_.publish(kFoxgloveDoor, now, [s, now] { return foxglove_door_json(s, now); });
}

void FoxgloveLive::on_model(const protocol::RobotModel& m) {
  const auto now = foxglove::unix_time_ns();
  server_.publish(kFoxgloveCameraMount, now,
                  [m, now] { return foxglove_camera_mount_json(m, now); });
}

void FoxgloveLive::on_image(std::shared_ptr<const std::vector<std::uint8_t>> png,
                            std::uint64_t unix_ns, const core::PinholeIntrinsics& k) {
  const auto same = [](const core::PinholeIntrinsics& a, const core::PinholeIntrinsics& b) {
    return a.fx_px == b.fx_px && a.fy_px == b.fy_px && a.cx_px == b.cx_px && a.cy_px == b.cy_px &&
           a.width_px == b.width_px && a.height_px == b.height_px;
  };
  if (!last_intrinsics_ || !same(*last_intrinsics_, k)) {
    last_intrinsics_ = k;
    server_.publish(kFoxgloveCalibration, unix_ns,
                    [k, unix_ns] { return foxglove_calibration_json(k, unix_ns); });
  }
  if (!png || png->empty()) return;
  server_.publish(kFoxgloveImage, unix_ns,
                  [png = std::move(png), unix_ns] { return foxglove_image_json(*png, unix_ns); });
}

}  // namespace ajar::console
