#include "ajar/console/door_scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

namespace ajar::console {
namespace {

constexpr double kHandleHalfThickness_m = 0.012;  // the bar's half height and half depth
constexpr double kStemHalfWidth_m = 0.010;
constexpr double kFrameBand_m = 0.035;  // dark door frame drawn on the wall around the leaf
constexpr double kNoHit = std::numeric_limits<double>::infinity();

using Rgb = std::array<double, 3>;

// Door-local coordinates: s along the wall (robot's left at yaw 0), n from the wall toward the
// robot, z up (world z). Same construction as client::SimWorld::door_point.
struct DoorFrame {
  core::Vec3 foot, lateral, normal;
  core::Vec3 local(const core::Vec3& p) const {
    const core::Vec3 d = p - foot;
    return {d.dot(lateral), d.dot(normal), p.z()};
  }
  core::Vec3 local_dir(const core::Vec3& d) const { return {d.dot(lateral), d.dot(normal), d.z()}; }
};

struct Box {
  core::Vec3 lo, hi;
};

// Slab test; returns the entry t (> 0) and which local axis the entry face is normal to.
double hit_box(const Box& b, const core::Vec3& o, const core::Vec3& d, int& axis) {
  double t0 = 0;
  double t1 = kNoHit;
  axis = -1;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-12) {
      if (o[i] < b.lo[i] || o[i] > b.hi[i]) return kNoHit;
      continue;
    }
    double ta = (b.lo[i] - o[i]) / d[i];
    double tb = (b.hi[i] - o[i]) / d[i];
    if (ta > tb) std::swap(ta, tb);
    if (ta > t0) {
      t0 = ta;
      axis = i;
    }
    t1 = std::min(t1, tb);
    if (t0 > t1) return kNoHit;
  }
  return axis < 0 ? kNoHit : t0;
}

std::uint32_t hash32(std::uint64_t x) {
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  x *= 0xc4ceb9fe1a85ec53ULL;
  x ^= x >> 33;
  return static_cast<std::uint32_t>(x);
}

std::uint8_t to_byte(double v) {
  return static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
}

}  // namespace

DoorScene::DoorScene(const client::Scenario& scenario, const SensorModel& sensor)
    : scenario_(scenario), sensor_(sensor) {}

Eigen::Isometry3d DoorScene::camera_in_world(const BasePose& pose,
                                             const Eigen::Isometry3d& camera_to_base) {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(core::Vec3(pose.x_m, pose.y_m, 0));
  base.rotate(Eigen::AngleAxisd(pose.yaw_rad, core::Vec3::UnitZ()));
  return base * camera_to_base;
}

void DoorScene::render(const BasePose& pose, const Eigen::Isometry3d& camera_to_base,
                       std::uint64_t sequence, bool noise, Frame& out) const {
  Exact exact;
  render_exact(pose, camera_to_base, exact);
  if (noise) {
    add_sensor_effects(exact, sequence, out);
  } else {
    out = std::move(exact.frame);
    out.sequence = sequence;
  }
}

namespace {
// A fixed table of standard normal samples: each frame reads it from a random offset with a random
// odd stride, so the noise differs frame to frame at a fraction of the cost of sampling.
const std::vector<float>& normal_table() {
  static const std::vector<float> table = [] {
    std::mt19937_64 rng(0x5EED);
    std::normal_distribution<float> unit(0.0F, 1.0F);
    std::vector<float> t(1U << 20);
    for (auto& x : t)
      x = unit(rng);
    return t;
  }();
  return table;
}
}  // namespace

void DoorScene::add_sensor_effects(const Exact& exact, std::uint64_t sequence, Frame& out) const {
  out.intrinsics = exact.frame.intrinsics;
  out.rgb = exact.frame.rgb;
  out.sequence = sequence;
  out.depth_m.assign(exact.frame.depth_m.size(), 0.0F);
  const auto& table = normal_table();
  const std::size_t mask = table.size() - 1;
  const std::uint64_t h = hash32(scenario_.seed * 0x9E3779B97F4A7C15ULL + sequence) |
                          (std::uint64_t{hash32(sequence * 31 + 7)} << 32);
  std::size_t at = static_cast<std::size_t>(h) & mask;
  const std::size_t stride = (static_cast<std::size_t>(h >> 32) & mask) | 1U;
  const auto width = static_cast<std::size_t>(out.intrinsics.width_px);
  const auto hole_threshold = static_cast<std::uint32_t>(sensor_.handle_hole_fraction * 1000);
  for (std::size_t i = 0; i < out.depth_m.size(); ++i) {
    if (!exact.specular.empty() && exact.specular[i] != 0) {
      for (std::size_t ch = 0; ch < 3; ++ch) {
        const int lifted = out.rgb[i * 3 + ch] + 40;  // a highlight on the polished metal
        out.rgb[i * 3 + ch] = static_cast<std::uint8_t>(std::min(lifted, 255));
      }
    }
    double z = exact.frame.depth_m[i];
    if (z <= 0) continue;
    at = (at + stride) & mask;
    z += sensor_.depth_noise_at_1m_m * z * z * static_cast<double>(table[at]);
    if (sensor_.depth_step_m > 0) z = std::round(z / sensor_.depth_step_m) * sensor_.depth_step_m;
    if (!exact.specular.empty() && exact.specular[i] != 0) {
      const auto hv = hash32(((i / width) << 20) ^ (i % width) ^ (sequence << 40));
      if (hv % 1000 < hole_threshold) continue;
    }
    if (z < sensor_.min_range_m || z > sensor_.max_range_m) continue;
    out.depth_m[i] = static_cast<float>(z);
  }
}

namespace {
// The scene in door-local coordinates (DoorFrame): the wall with the leaf (s in leaf_lo..leaf_hi,
// z in floor_z..top_z) and its frame around it, the floor at floor_z, the handle's bar and stem.
struct SceneGeometry {
  DoorFrame door;
  double leaf_lo = 0, leaf_hi = 0, floor_z = 0, top_z = 0;
  Box bar, stem;
};

SceneGeometry scene_geometry(const client::Scenario& s) {
  const double c = std::cos(s.yaw_rad);
  const double sn = std::sin(s.yaw_rad);
  SceneGeometry g;
  g.door = DoorFrame{core::Vec3(s.distance_m * c, s.distance_m * sn, 0), core::Vec3(-sn, c, 0),
                     core::Vec3(-c, -sn, 0)};
  const double hinge = s.hinge == client::Scenario::Hinge::kLeft ? 1.0 : -1.0;
  g.leaf_lo = s.lateral_offset_m - s.door_width_m / 2;
  g.leaf_hi = s.lateral_offset_m + s.door_width_m / 2;
  g.floor_z = s.door_bottom_z_m;
  g.top_z = s.door_bottom_z_m + s.door_height_m;
  const double axis_s =
      s.lateral_offset_m - hinge * s.door_width_m / 2 + hinge * s.handle_axis_from_edge_m;
  const double free_s = axis_s + hinge * s.handle_length_m;
  const double h = s.handle_height_m;
  const double front = s.handle_offset_m;
  g.bar = Box{{std::min(axis_s, free_s) - kStemHalfWidth_m, front - 2 * kHandleHalfThickness_m,
               h - kHandleHalfThickness_m},
              {std::max(axis_s, free_s) + kStemHalfWidth_m, front, h + kHandleHalfThickness_m}};
  g.stem = Box{{axis_s - kStemHalfWidth_m, 0, h - kStemHalfWidth_m},
               {axis_s + kStemHalfWidth_m, front, h + kStemHalfWidth_m}};
  return g;
}

// The nearest surface a ray meets so far: its t along the ray, colour, the cosine of the angle
// between the ray and its normal (the shading), and whether it is the handle's specular face.
struct Hit {
  double t = kNoHit;
  Rgb colour{40, 44, 52};  // nothing hit: dark background
  double cosine = 1;
  bool specular = false;
};

// Wall and leaf: n = 0, seen from the robot's side.
void hit_wall(const SceneGeometry& g, const core::Vec3& origin, const core::Vec3& d, Hit& hit) {
  if (!(d.y() < -1e-12 && origin.y() > 0)) return;
  const double tw = -origin.y() / d.y();
  const double ws = origin.x() + tw * d.x();
  const double wz = origin.z() + tw * d.z();
  if (!(wz >= g.floor_z)) return;
  hit.t = tw;
  hit.cosine = -d.y() / (d.norm());
  const bool on_leaf = ws >= g.leaf_lo && ws <= g.leaf_hi && wz <= g.top_z;
  const bool on_frame = !on_leaf && ws >= g.leaf_lo - kFrameBand_m &&
                        ws <= g.leaf_hi + kFrameBand_m && wz <= g.top_z + kFrameBand_m;
  if (on_leaf) {
    const double grain = 10 * std::sin(ws * 37.0 + 3 * std::sin(wz * 5.0));
    hit.colour = {150 + grain, 98 + grain * 0.7, 58 + grain * 0.4};
  } else if (on_frame) {
    hit.colour = {70, 62, 55};
  } else {
    hit.colour = {205, 200, 188};
  }
}

// The floor: a checkerboard of 0.5 m squares, in front of the wall.
void hit_floor(const SceneGeometry& g, const core::Vec3& origin, const core::Vec3& d, Hit& hit) {
  if (!(d.z() < -1e-12)) return;
  const double tf = (g.floor_z - origin.z()) / d.z();
  const double fn = origin.y() + tf * d.y();
  if (!(tf > 0 && tf < hit.t && fn >= 0)) return;
  hit.t = tf;
  hit.cosine = -d.z() / d.norm();
  const double fx = origin.x() + tf * d.x();
  const bool dark =
      (static_cast<long>(std::floor(fx / 0.5)) + static_cast<long>(std::floor(fn / 0.5))) % 2 != 0;
  hit.colour = dark ? Rgb{110, 112, 118} : Rgb{135, 137, 143};
}

// Handle: the bar and its stem.
void hit_handle(const SceneGeometry& g, const core::Vec3& origin, const core::Vec3& d, Hit& hit) {
  int axis = -1;
  const double tb = hit_box(g.bar, origin, d, axis);
  if (tb < hit.t) {
    hit.t = tb;
    hit.cosine = std::abs(d[axis]) / d.norm();
    hit.colour = {185, 188, 195};
    hit.specular = axis == 1;  // the front face (normal along n)
  }
  const double ts = hit_box(g.stem, origin, d, axis);
  if (ts < hit.t) {
    hit.t = ts;
    hit.cosine = std::abs(d[axis]) / d.norm();
    hit.colour = {160, 163, 170};
    hit.specular = false;
  }
}
}  // namespace

void DoorScene::render_exact(const BasePose& pose, const Eigen::Isometry3d& camera_to_base,
                             Exact& exact) const {
  Frame& out = exact.frame;
  const auto& k = sensor_.intrinsics;
  const SceneGeometry g = scene_geometry(scenario_);
  const Eigen::Isometry3d cam = camera_in_world(pose, camera_to_base);
  const core::Vec3 origin = g.door.local(cam.translation());
  const Eigen::Matrix3d rot = cam.linear();

  out.intrinsics = k;
  const auto n = static_cast<std::size_t>(k.width_px) * static_cast<std::size_t>(k.height_px);
  out.rgb.assign(n * 3, 0);
  out.depth_m.assign(n, 0.0F);
  exact.specular.assign(n, 0);

  for (int v = 0; v < k.height_px; ++v) {
    for (int u = 0; u < k.width_px; ++u) {
      const core::Vec3 ray_cam((u - k.cx_px) / k.fx_px, (v - k.cy_px) / k.fy_px, 1.0);
      const core::Vec3 d = g.door.local_dir(rot * ray_cam);
      Hit hit;
      hit_wall(g, origin, d, hit);
      hit_floor(g, origin, d, hit);
      hit_handle(g, origin, d, hit);
      const auto i = static_cast<std::size_t>(v) * static_cast<std::size_t>(k.width_px) +
                     static_cast<std::size_t>(u);
      const double shade = 0.35 + 0.65 * hit.cosine;
      for (std::size_t ch = 0; ch < 3; ++ch)
        out.rgb[i * 3 + ch] = to_byte(hit.colour[ch] * shade);
      exact.specular[i] = hit.specular ? 1 : 0;
      // The camera-frame ray has z = 1: t is the camera z. Exact depth: no range limit here.
      if (hit.t != kNoHit) out.depth_m[i] = static_cast<float>(hit.t);
    }
  }
}

Landmarks DoorScene::landmarks() const {
  const auto& s = scenario_;
  client::SimWorld world(s, Eigen::Matrix4d::Identity());
  Landmarks l;
  l.hinge_edge = world.hinge_edge_point();
  l.moving_edge = world.moving_edge_point();
  l.handle_axis = world.handle_axis_point();
  l.handle_free_end = world.handle_free_end_point();
  l.contact = world.contact_point();
  const double c = std::cos(s.yaw_rad);
  const double sn = std::sin(s.yaw_rad);
  const core::Vec3 foot(s.distance_m * c, s.distance_m * sn, 0);
  const core::Vec3 lateral(-sn, c, 0);
  const auto leaf = [&](double lat, double z) {
    return core::Vec3(foot + (s.lateral_offset_m + lat) * lateral + core::Vec3(0, 0, z));
  };
  // A wide triangle low on the leaf, between the floor and the handle (what the camera sees).
  const double z_lo = s.door_bottom_z_m + 0.12;
  const double z_hi = s.handle_height_m - 0.08;
  l.leaf_low_left = leaf(0.3 * s.door_width_m, z_lo);
  l.leaf_low_right = leaf(-0.3 * s.door_width_m, z_lo);
  l.leaf_high_middle = leaf(0.0, z_hi);
  return l;
}

SimulatedSource::SimulatedSource(const std::string& scenario_path, const client::Scenario& scenario,
                                 const SensorModel& sensor, double rate_hz,
                                 const Eigen::Matrix4d& camera_to_base)
    : path_(scenario_path), scene_(scenario, sensor), rate_hz_(rate_hz) {
  camera_to_base_.matrix() = camera_to_base;
}

std::string SimulatedSource::describe() const {
  return "simulated: " + path_;
}

void SimulatedSource::set_camera_to_base(const Eigen::Matrix4d& camera_to_base) {
  const std::lock_guard lock(mutex_);
  camera_to_base_.matrix() = camera_to_base;
}

Eigen::Isometry3d SimulatedSource::camera_to_base() const {
  const std::lock_guard lock(mutex_);
  return camera_to_base_;
}

bool SimulatedSource::next(const BasePose& pose, Frame& out, std::string& /*why*/) {
  const Eigen::Isometry3d transform = camera_to_base();
  if (!cache_valid_ || pose.x_m != cached_pose_.x_m || pose.y_m != cached_pose_.y_m ||
      pose.yaw_rad != cached_pose_.yaw_rad || transform.matrix() != cached_transform_) {
    scene_.render_exact(pose, transform, cache_);
    cached_pose_ = pose;
    cached_transform_ = transform.matrix();
    cache_valid_ = true;
  }
  scene_.add_sensor_effects(cache_, ++sequence_, out);
  out.timestamp_s = static_cast<double>(sequence_) / rate_hz_;
  return true;
}

}  // namespace ajar::console
