// Shared helpers for the core tests: seeded random rigid transforms and random doors.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "ajar/core/geometry.hpp"

namespace ajar::core::test {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();
// The default tolerances (min separation 0.01 m, lateral fraction 0.5).
inline const Tolerances kTol{};

// The paper's camera-to-base transform (docs/geometry.md, "Worked example").
inline CameraToBase paper() {
  return *CameraToBase::from_matrix(paper_camera_to_base_m());
}

inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

// Random draws are made one statement at a time, in a fixed order, never as several arguments of
// one call: the order in which a call's arguments are evaluated is unspecified (GCC evaluates them
// right to left on x86-64 and left to right on arm64), so `Vec3(uniform(rng, ..), uniform(rng,
// ..), ..)` gave one seed different values on each architecture (scripts/test-arm64 found it:
// another door, a pick outside the camera's depth range). The order kept is the one x86-64 used,
// so seeds recorded there keep their meaning.
inline Vec3 uniform_vec3(std::mt19937_64& rng, const Vec3& lo, const Vec3& hi) {
  const double z = uniform(rng, lo.z(), hi.z());
  const double y = uniform(rng, lo.y(), hi.y());
  const double x = uniform(rng, lo.x(), hi.x());
  return {x, y, z};
}

// A uniformly random rotation and a translation within +-1 m, as a 4x4 matrix.
inline Eigen::Matrix4d random_rigid(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  const double qz = g(rng);
  const double qy = g(rng);
  const double qx = g(rng);
  const double qw = g(rng);
  Eigen::Quaterniond q(qw, qx, qy, qz);
  q.normalize();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = q.toRotationMatrix();
  m.topRightCorner<3, 1>() = uniform_vec3(rng, Vec3::Constant(-1.0), Vec3::Constant(1.0));
  return m;
}

// A door leaf in the base frame: `into_door` is the unit direction the base's +x must point along
// when squared up (the negated normal that faces the robot); its yaw is atan2(y, x).
struct Door {
  double yaw_rad = 0;
  double tilt_rad = 0;
  Vec3 centre_m = Vec3::Zero();
  Vec3 into_door = Vec3::UnitX();
  Vec3 left = Vec3::UnitY();  // in the leaf, horizontal, pointing to the robot's left
  Vec3 up = Vec3::UnitZ();    // in the leaf, perpendicular to `left`

  // A point on the leaf, `s` metres to the left of the centre and `h` metres up.
  Vec3 at(double s, double h) const { return centre_m + s * left + h * up; }
};

inline Door make_door(double yaw_rad, double tilt_rad, const Vec3& centre_m) {
  Door d;
  d.yaw_rad = yaw_rad;
  d.tilt_rad = tilt_rad;
  d.centre_m = centre_m;
  d.into_door = Vec3(std::cos(tilt_rad) * std::cos(yaw_rad), std::cos(tilt_rad) * std::sin(yaw_rad),
                     std::sin(tilt_rad));
  d.left = Vec3(-std::sin(yaw_rad), std::cos(yaw_rad), 0.0);
  d.up = d.into_door.cross(d.left);
  return d;
}

// A door in front of the robot at a random yaw within +-max_yaw, tilt within +-max_tilt.
inline Door random_door(std::mt19937_64& rng, double max_yaw, double max_tilt) {
  const Vec3 centre_m = uniform_vec3(rng, Vec3(0.8, -0.3, -0.2), Vec3(2.0, 0.3, 0.6));
  const double tilt_rad = uniform(rng, -max_tilt, max_tilt);
  const double yaw_rad = uniform(rng, -max_yaw, max_yaw);
  return make_door(yaw_rad, tilt_rad, centre_m);
}

// A random point of the leaf within +-s_max to the side and +-h_max up (drawn in that order of
// statements: see uniform_vec3).
inline Vec3 random_point_on(std::mt19937_64& rng, const Door& door, double s_max, double h_max) {
  const double h = uniform(rng, -h_max, h_max);
  const double s = uniform(rng, -s_max, s_max);
  return door.at(s, h);
}

// Height of the triangle over its longest edge / that edge (the library's collinearity measure).
inline double flatness(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double longest_sq =
      std::max({(b - a).squaredNorm(), (c - a).squaredNorm(), (c - b).squaredNorm()});
  return (b - a).cross(c - a).norm() / longest_sq;
}

// Three well-spread random points on the door (flatness >= 0.15, all >= 5 cm apart).
inline std::array<Vec3, 3> random_triangle(std::mt19937_64& rng, const Door& door) {
  for (;;) {
    std::array<Vec3, 3> p;
    for (Vec3& v : p)
      v = random_point_on(rng, door, 0.4, 0.5);
    if (flatness(p[0], p[1], p[2]) >= 0.15) return p;
  }
}

inline std::vector<Vec3> random_points(std::mt19937_64& rng, const Door& door, int n) {
  for (;;) {
    std::vector<Vec3> p;
    for (int i = 0; i < n; ++i)
      p.push_back(random_point_on(rng, door, 0.4, 0.5));
    bool spread = true;
    for (std::size_t j = 0; j < p.size(); ++j) {
      for (std::size_t i = 0; i < j; ++i)
        spread = spread && (p[j] - p[i]).norm() >= 0.05;
    }
    if (spread && flatness(p[0], p[1], p[2]) >= 0.15) return p;
  }
}

}  // namespace ajar::core::test
