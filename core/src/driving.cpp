#include "ajar/core/driving.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace ajar::core {
namespace {

double finite_or_zero(double v) noexcept {
  return std::isfinite(v) ? v : 0.0;
}

double wrap(double a) noexcept {
  a = std::remainder(a, 2.0 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}

// One component of the speed limiter.
double limit(double target, double previous, double max_speed, double max_accel,
             double dt_s) noexcept {
  const double v = std::clamp(finite_or_zero(target), -max_speed, max_speed);
  const double step = max_accel * std::max(dt_s, 0.0);
  return std::clamp(v, previous - step, previous + step);
}

Vec3 rotate_z(const Vec3& v, double yaw_rad) noexcept {
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y(), v.z()};
}

}  // namespace

WheelVelocity wheel_velocity(BodyVelocity body, const BaseGeometry& base) noexcept {
  const double v = finite_or_zero(body.linear_m_s);
  const double w = finite_or_zero(body.angular_rad_s);
  WheelVelocity out{(v - w * base.turning_radius_m) / base.wheel_radius_m,
                    (v + w * base.turning_radius_m) / base.wheel_radius_m};
  const double fastest = std::max(std::abs(out.left_rad_s), std::abs(out.right_rad_s));
  if (fastest > base.max_wheel_speed_rad_s && fastest > 0) {
    const double scale = base.max_wheel_speed_rad_s / fastest;
    out.left_rad_s *= scale;
    out.right_rad_s *= scale;
  }
  return out;
}

BodyVelocity body_velocity(WheelVelocity wheels, const BaseGeometry& base) noexcept {
  return {base.wheel_radius_m * (wheels.left_rad_s + wheels.right_rad_s) / 2.0,
          base.wheel_radius_m * (wheels.right_rad_s - wheels.left_rad_s) /
              (2.0 * base.turning_radius_m)};
}

BodyVelocity limit_velocity(BodyVelocity target, BodyVelocity previous, double dt_s,
                            const DriveLimits& limits) noexcept {
  return {limit(target.linear_m_s, previous.linear_m_s, limits.max_linear_speed_m_s,
                limits.max_linear_accel_m_s2, dt_s),
          limit(target.angular_rad_s, previous.angular_rad_s, limits.max_angular_speed_rad_s,
                limits.max_angular_accel_rad_s2, dt_s)};
}

PlanarPose integrate_odometry(const PlanarPose& pose, double d_left_rad, double d_right_rad,
                              const BaseGeometry& base) noexcept {
  const double ds = base.wheel_radius_m * (d_left_rad + d_right_rad) / 2.0;
  const double dyaw =
      base.wheel_radius_m * (d_right_rad - d_left_rad) / (2.0 * base.turning_radius_m);
  const double heading = pose.yaw_rad + dyaw / 2.0;
  return {pose.x_m + ds * std::cos(heading), pose.y_m + ds * std::sin(heading),
          pose.yaw_rad + dyaw};
}

double travel_m(const PlanarPose& from, const PlanarPose& to) noexcept {
  return std::hypot(to.x_m - from.x_m, to.y_m - from.y_m);
}

double turn_rad(const PlanarPose& from, const PlanarPose& to) noexcept {
  return wrap(to.yaw_rad - from.yaw_rad);
}

Vec3 rebase(const Vec3& point_m, const PlanarPose& at, const PlanarPose& now) noexcept {
  // To the odometry frame from `at`, then into the frame of `now`.
  const Vec3 odom = rotate_z(point_m, at.yaw_rad) + Vec3(at.x_m, at.y_m, 0.0);
  return rotate_z(odom - Vec3(now.x_m, now.y_m, 0.0), -now.yaw_rad);
}

DoorView door_from_plane(const Plane& plane, const PlanarPose& at, const PlanarPose& now) noexcept {
  const Vec3 n = rotate_z(plane.normal, at.yaw_rad - now.yaw_rad);
  const Vec3 c = rebase(plane.centroid_m, at, now);
  return {-n.dot(c), yaw_from_normal_rad(n)};
}

DoorView door_from_width(const Vec3& p1_m, const Vec3& p2_m, const PlanarPose& at,
                         const PlanarPose& now) noexcept {
  const Vec3 a = rebase(p1_m, at, now), b = rebase(p2_m, at, now);
  const Vec3 mid = (a + b) / 2.0;
  Vec3 n(b.y() - a.y(), a.x() - b.x(), 0.0);  // horizontal, perpendicular to the door's line
  const double length = n.norm();
  if (!(length > 0)) return {mid.x(), 0.0};
  n /= length;
  if (n.dot(-mid) < 0) n = -n;  // toward the robot
  return {-n.dot(mid), yaw_from_normal_rad(n)};
}

namespace {

// A normal and a point of the door measured at `at` (base frame then), as a line in the odometry
// frame: the pose {0, 0, 0} is the odometry origin.
DoorLine door_line(const Vec3& normal_at, const Vec3& point_at, const PlanarPose& at) noexcept {
  const Vec3 n = rotate_z(normal_at, at.yaw_rad);
  const Vec3 c = rebase(point_at, at, PlanarPose{});
  return {n.x(), n.y(), -n.dot(c)};
}

}  // namespace

DoorLine door_line_from_plane(const Plane& plane, const PlanarPose& at) noexcept {
  return door_line(plane.normal, plane.centroid_m, at);
}

DoorLine door_line_from_width(const Vec3& p1_m, const Vec3& p2_m, const PlanarPose& at) noexcept {
  const Vec3 mid = (p1_m + p2_m) / 2.0;
  Vec3 n(p2_m.y() - p1_m.y(), p1_m.x() - p2_m.x(), 0.0);
  const double length = n.norm();
  if (!(length > 0))
    n = Vec3(-1.0, 0.0, 0.0);  // as door_from_width: straight ahead
  else
    n /= length;
  if (n.dot(-mid) < 0) n = -n;  // toward the robot when it was measured
  return door_line(n, mid, at);
}

StraightCommand straight_command(double travel_m, const BaseGeometry& base) noexcept {
  StraightCommand c;
  const double theta = travel_m / base.wheel_radius_m;
  const std::optional<std::int64_t> counts = wheel_rad_to_motor_counts(theta, base);
  if (!counts) return c;
  c.wheel_rad = theta;
  c.left_counts = *counts * (base.left.polarity < 0 ? -1 : 1);
  c.right_counts = *counts * (base.right.polarity < 0 ? -1 : 1);
  return c;
}

}  // namespace ajar::core
