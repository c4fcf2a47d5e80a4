#include "ajar/core/geometry.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <Eigen/SVD>

#include <fmt/format.h>

namespace ajar::core {

namespace {

double deg(double rad) {
  return rad * 180.0 / std::numbers::pi;
}

// Largest |counts| we convert: doubles hold every integer below 2^53 exactly.
constexpr double kMaxCounts = 9007199254740992.0;

// Within this distance (m) of the base origin a plane counts as passing through the robot's
// turning centre; its normal is then oriented by a fixed rule instead (see orient_toward_robot).
constexpr double kThroughOriginM = 1e-9;

int sign_of(int polarity) {
  return polarity < 0 ? -1 : 1;
}

// Orients a unit normal toward the base origin (the robot). A plane through the origin has no
// "robot side": prefer the normal facing backwards (-x), then right (-y), then down (-z).
Vec3 orient_toward_robot(const Vec3& n, const Vec3& point_on_plane) {
  const double s = n.dot(point_on_plane);  // the origin is on the side where n . p < 0
  if (s > kThroughOriginM) return -n;
  if (s < -kThroughOriginM) return n;
  for (int i = 0; i < 3; ++i) {
    if (n[i] > 0) return -n;
    if (n[i] < 0) return n;
  }
  return n;
}

// First pair (i < j, ordered by j then i) closer than the minimum separation.
Outcome check_separation(std::span<const Vec3> points, const Tolerances& tol) {
  for (std::size_t j = 1; j < points.size(); ++j) {
    for (std::size_t i = 0; i < j; ++i) {
      const double d = (points[j] - points[i]).norm();
      if (!(d >= tol.min_point_separation_m)) {
        return make_error(
            ErrorCode::kPointsTooClose, point_field(j),
            fmt::format("points[{}] is {:.4f} m from points[{}]; picked points must be at "
                        "least {:.3f} m apart",
                        j, d, i, tol.min_point_separation_m));
      }
    }
  }
  return Ok{};
}

Outcome check_points_finite(std::span<const Vec3> points) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (auto s = check_finite(points[i], point_field(i)); !s) return s;
  }
  return Ok{};
}

}  // namespace

// ---- Frames ----------------------------------------------------------------------------------

std::string point_field(std::size_t i) {
  return fmt::format("{}[{}]", fields::kPoints, i);
}

Eigen::Matrix4d paper_camera_to_base_m() {
  Eigen::Matrix4d t;
  t << 0, 0, 1, 0.150,   //
      -1, 0, 0, 0.015,   //
      0, -1, 0, -0.220,  //
      0, 0, 0, 1;
  return t;
}

Result<CameraToBase> CameraToBase::from_matrix(const Eigen::Matrix4d& matrix, double tolerance) {
  if (!matrix.allFinite()) {
    return make_error(ErrorCode::kNonFinite, "matrix",
                      "the camera->base transform contains NaN or infinity; every entry must be a "
                      "finite number");
  }
  if (matrix(3, 0) != 0.0 || matrix(3, 1) != 0.0 || matrix(3, 2) != 0.0 || matrix(3, 3) != 1.0) {
    return make_error(
        ErrorCode::kTransformNotRigid, "bottom_row",
        fmt::format("the camera->base transform's bottom row is [{:g} {:g} {:g} {:g}]; it must be "
                    "exactly [0 0 0 1]",
                    matrix(3, 0), matrix(3, 1), matrix(3, 2), matrix(3, 3)));
  }
  const Eigen::Matrix3d r = matrix.topLeftCorner<3, 3>();
  const double orthonormality_error =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(orthonormality_error <= tolerance)) {
    return make_error(
        ErrorCode::kTransformNotRigid, "rotation",
        fmt::format("the camera->base rotation is not orthonormal: R^T R differs from the "
                    "identity by up to {:.3g}; at most {:.3g} is allowed",
                    orthonormality_error, tolerance));
  }
  const double det = r.determinant();
  if (!(std::abs(det - 1.0) <= tolerance)) {
    return make_error(
        ErrorCode::kTransformNotRigid, "determinant",
        fmt::format("the camera->base rotation has determinant {:.6f}; a rotation has +1 "
                    "(within {:.3g}); -1 is a mirror image",
                    det, tolerance));
  }
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  if (orthonormality_error == 0.0) {
    iso.linear() = r;
  } else {
    // Snap to the nearest rotation so that to_camera (which transposes) inverts to_base exactly.
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
    iso.linear() = svd.matrixU() * svd.matrixV().transpose();
  }
  iso.translation() = matrix.topRightCorner<3, 1>();
  return CameraToBase(iso);
}

Vec3 CameraToBase::to_base(const FramedPoint& point) const {
  switch (point.frame) {
    case Frame::kCamera:
      return to_base(point.position_m);
    case Frame::kBase:
      return point.position_m;
  }
  return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
}

// ---- Algorithm 1 -----------------------------------------------------------------------------

Result<Span> measure_span(const Vec3& p1_base_m, const Vec3& p2_base_m, const Tolerances& tol) {
  if (auto s = check_finite(p1_base_m, fields::kP1); !s) return std::move(s).error();
  if (auto s = check_finite(p2_base_m, fields::kP2); !s) return std::move(s).error();
  const double length = (p1_base_m - p2_base_m).norm();
  if (!(length >= tol.min_point_separation_m)) {
    return make_error(
        ErrorCode::kPointsTooClose, std::string(fields::kP2),
        fmt::format("p1 and p2 are {:.4f} m apart; the two points must be at least {:.3f} m "
                    "apart",
                    length, tol.min_point_separation_m));
  }
  const double dy = p1_base_m.y() - p2_base_m.y();
  if (!(std::abs(dy) >= tol.min_point_separation_m)) {
    return make_error(
        ErrorCode::kAmbiguousDirection, std::string(fields::kP2),
        fmt::format("p1 and p2 are at the same lateral position (y1 - y2 = {:.4f} m in the base "
                    "frame), so the direction of rotation is unknown; pick them at least "
                    "{:.3f} m apart sideways",
                    dy, tol.min_point_separation_m));
  }
  const double lateral_fraction = std::abs(dy) / length;
  if (!(lateral_fraction >= tol.min_lateral_fraction)) {
    return make_error(
        ErrorCode::kPointsNotSideBySide, std::string(fields::kP2),
        fmt::format("p1 and p2 are {:.3f} m apart but only {:.3f} m of that is sideways ({:.0f}%); "
                    "pick them side by side, at least {:.0f}% sideways",
                    length, std::abs(dy), lateral_fraction * 100.0,
                    tol.min_lateral_fraction * 100.0));
  }
  return Span{length,
              dy > 0 ? RotationDirection::kCounterClockwise : RotationDirection::kClockwise};
}

// ---- Door plane ------------------------------------------------------------------------------

Result<Plane> plane_from_three_points(const Vec3& a_m, const Vec3& b_m, const Vec3& c_m,
                                      const Tolerances& tol) {
  const std::array<Vec3, 3> points{a_m, b_m, c_m};
  if (auto s = check_points_finite(points); !s) return std::move(s).error();
  if (auto s = check_separation(points, tol); !s) return std::move(s).error();
  const Vec3 cross = (b_m - a_m).cross(c_m - a_m);  // eq. 3-4
  const double longest_sq =
      std::max({(b_m - a_m).squaredNorm(), (c_m - a_m).squaredNorm(), (c_m - b_m).squaredNorm()});
  // |AB x AC| = longest edge * height over it, so this is the triangle's height / longest edge.
  const double flatness = cross.norm() / longest_sq;
  if (!(flatness >= tol.collinearity)) {
    return make_error(
        ErrorCode::kPointsCollinear, std::string(fields::kPoints),
        fmt::format("the three points are nearly on one line (height / length = {:.4f}); they "
                    "must span a plane with at least {:.4f}: pick them further apart, not in a "
                    "row",
                    flatness, tol.collinearity));
  }
  Plane plane;
  plane.centroid_m = (a_m + b_m + c_m) / 3.0;
  plane.normal = orient_toward_robot(cross / cross.norm(), plane.centroid_m);
  plane.rms_residual_m = 0.0;
  return plane;
}

Result<Plane> fit_plane(std::span<const Vec3> points_base_m, const Tolerances& tol) {
  const std::size_t n = points_base_m.size();
  if (n < 3) {
    return make_error(ErrorCode::kBadCount, std::string(fields::kPoints),
                      fmt::format("a plane needs at least 3 points; got {}", n));
  }
  if (n == 3) {
    return plane_from_three_points(points_base_m[0], points_base_m[1], points_base_m[2], tol);
  }
  if (auto s = check_points_finite(points_base_m); !s) return std::move(s).error();
  if (auto s = check_separation(points_base_m, tol); !s) return std::move(s).error();

  Vec3 centroid = Vec3::Zero();
  for (const Vec3& p : points_base_m)
    centroid += p;
  centroid /= static_cast<double>(n);
  Eigen::Matrix<double, Eigen::Dynamic, 3> centred(static_cast<Eigen::Index>(n), 3);
  for (std::size_t i = 0; i < n; ++i) {
    centred.row(static_cast<Eigen::Index>(i)) = (points_base_m[i] - centroid).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 3>> svd(centred,
                                                                       Eigen::ComputeFullV);
  const Vec3 sv = svd.singularValues();
  const double flatness = sv(1) / sv(0);
  if (!(flatness >= tol.collinearity)) {
    return make_error(
        ErrorCode::kPointsCollinear, std::string(fields::kPoints),
        fmt::format("the {} points are nearly on one line (spread ratio {:.4f}); they must "
                    "span a plane with at least {:.4f}: pick them further apart, not in a row",
                    n, flatness, tol.collinearity));
  }
  Plane plane;
  plane.centroid_m = centroid;
  plane.normal = orient_toward_robot(svd.matrixV().col(2).normalized(), centroid);
  double sum_sq = 0.0;
  for (const Vec3& p : points_base_m) {
    const double d = (p - centroid).dot(plane.normal);
    sum_sq += d * d;
  }
  plane.rms_residual_m = std::sqrt(sum_sq / static_cast<double>(n));
  return plane;
}

// ---- Signed yaw ------------------------------------------------------------------------------

Result<double> yaw_deviation_rad(const Plane& plane, const Tolerances& tol) {
  const double norm = plane.normal.norm();
  if (!plane.normal.allFinite() || !(norm > 0.0)) {
    return make_error(ErrorCode::kNonFinite, "normal",
                      "the plane's normal is not a finite, non-zero vector");
  }
  const Vec3 n = plane.normal / norm;
  const double horizontal = std::hypot(n.x(), n.y());
  const double tilt = std::atan2(std::abs(n.z()), horizontal);
  if (!(tilt <= tol.max_door_tilt_rad)) {
    return make_error(
        ErrorCode::kPlaneNotVertical, std::string(fields::kPoints),
        fmt::format("the door plane's normal tilts {:.3f} rad ({:.1f} deg) out of the horizontal; "
                    "a door may tilt at most {:.3f} rad ({:.1f} deg): pick points on the door "
                    "leaf, not on the floor or ceiling",
                    tilt, deg(tilt), tol.max_door_tilt_rad, deg(tol.max_door_tilt_rad)));
  }
  // The base's +x must point into the door: along -normal (the normal faces the robot).
  const double yaw = yaw_from_normal_rad(n);
  if (!(std::abs(yaw) < std::numbers::pi / 2)) {
    return make_error(
        ErrorCode::kYawOutOfRange, std::string(fields::kYawDeviation),
        fmt::format("the door plane does not face the front of the robot (squaring up would "
                    "take a turn of {:.3f} rad, {:.1f} deg); drive the robot in front of the door",
                    yaw, deg(yaw)));
  }
  return yaw;
}

double yaw_from_normal_rad(const Vec3& normal) noexcept {
  return std::atan2(-normal.y(), -normal.x());
}

// ---- Wheel angles ----------------------------------------------------------------------------

std::optional<std::int64_t> wheel_rad_to_motor_counts(double wheel_rad,
                                                      const BaseGeometry& base) noexcept {
  const double raw =
      wheel_rad / (2.0 * std::numbers::pi) * base.gear_ratio * base.encoder_counts_per_rev;
  if (!std::isfinite(raw) || !(std::abs(raw) < kMaxCounts)) return std::nullopt;
  return static_cast<std::int64_t>(std::round(raw));
}

double counts_to_wheel_rad(std::int64_t counts, const WheelAxis& axis, const BaseGeometry& base) {
  const double motor_counts = static_cast<double>(counts) * sign_of(axis.polarity);
  return motor_counts / (base.gear_ratio * base.encoder_counts_per_rev) * (2.0 * std::numbers::pi);
}

double base_yaw_from_wheels_rad(double left_wheel_rad, double right_wheel_rad,
                                const BaseGeometry& base) {
  return (right_wheel_rad - left_wheel_rad) / 2.0 * base.wheel_radius_m / base.turning_radius_m;
}

WheelCommand wheel_command(double yaw_rad, const BaseGeometry& base) {
  WheelCommand cmd;
  const double theta_w = yaw_rad * base.turning_radius_m / base.wheel_radius_m;  // eq. 7
  const std::optional<std::int64_t> motor_counts = wheel_rad_to_motor_counts(theta_w, base);
  if (!motor_counts) {
    cmd.residual_yaw_rad = yaw_rad;  // nothing moves
    return cmd;
  }
  cmd.left_wheel_rad = -theta_w;
  cmd.right_wheel_rad = theta_w;
  // Rounded half away from zero, so the two wheels' counts stay exact opposites.
  cmd.left_counts = -*motor_counts * sign_of(base.left.polarity);
  cmd.right_counts = *motor_counts * sign_of(base.right.polarity);
  cmd.achieved_yaw_rad =
      base_yaw_from_wheels_rad(counts_to_wheel_rad(cmd.left_counts, base.left, base),
                               counts_to_wheel_rad(cmd.right_counts, base.right, base), base);
  cmd.residual_yaw_rad = yaw_rad - cmd.achieved_yaw_rad;
  return cmd;
}

// ---- Validation predicates -------------------------------------------------------------------

Outcome check_finite(const Vec3& p, std::string_view field) {
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(p[i])) {
      std::string name = fmt::format("{}.{}", field, kAxis[i]);
      std::string message = fmt::format("{} is {}; every coordinate must be a finite number", name,
                                        std::isnan(p[i]) ? "NaN" : "infinite");
      return make_error(ErrorCode::kNonFinite, std::move(name), std::move(message));
    }
  }
  return Ok{};
}

Outcome check_depth(const FramedPoint& p, const CameraToBase& t, const Limits& limits,
                    std::string_view field) {
  double depth = 0.0;
  switch (p.frame) {
    case Frame::kCamera:
      depth = p.position_m.z();
      break;
    case Frame::kBase:
      depth = t.to_camera(p.position_m).z();
      break;
    default:
      return make_error(ErrorCode::kUnknownFrame, std::string(field) + ".frame",
                        fmt::format("{} names frame {}; it must be camera (0) or base (1)", field,
                                    static_cast<int>(p.frame)));
  }
  if (!(depth >= limits.min_depth_m && depth <= limits.max_depth_m)) {
    return make_error(
        ErrorCode::kPointOutOfDepthRange, std::string(field),
        fmt::format("{} is {:.3f} m from the camera along its optical axis; the sensor "
                    "measures depth {:.3f}..{:.3f} m",
                    field, depth, limits.min_depth_m, limits.max_depth_m));
  }
  return Ok{};
}

namespace {

Outcome check_range(double value, double lo, double hi, ErrorCode code, const char* what,
                    std::string_view field) {
  if (!std::isfinite(value)) {
    return make_error(ErrorCode::kNonFinite, std::string(field),
                      fmt::format("{} is not a finite number", what));
  }
  if (!(value >= lo && value <= hi)) {
    return make_error(code, std::string(field),
                      fmt::format("{} {:.3f} m is outside the allowed range {:.3f}..{:.3f} m", what,
                                  value, lo, hi));
  }
  return Ok{};
}

}  // namespace

Outcome check_door_width(double width_m, const Limits& limits, std::string_view field) {
  return check_range(width_m, limits.min_door_width_m, limits.max_door_width_m,
                     ErrorCode::kWidthOutOfRange, "door width", field);
}

Outcome check_handle_length(double length_m, const Limits& limits, std::string_view field) {
  return check_range(length_m, limits.min_handle_length_m, limits.max_handle_length_m,
                     ErrorCode::kHandleLengthOutOfRange, "handle length", field);
}

Outcome check_yaw(double yaw_rad, const Limits& limits, std::string_view field) {
  if (!std::isfinite(yaw_rad)) {
    return make_error(ErrorCode::kNonFinite, std::string(field),
                      "yaw correction is not a finite number");
  }
  if (!(std::abs(yaw_rad) <= limits.max_yaw_correction_rad)) {
    return make_error(
        ErrorCode::kYawOutOfRange, std::string(field),
        fmt::format("yaw correction {:.3f} rad ({:.1f} deg) is beyond the maximum {:.3f} rad "
                    "({:.1f} deg); drive the robot more squarely in front of the door",
                    yaw_rad, deg(yaw_rad), limits.max_yaw_correction_rad,
                    deg(limits.max_yaw_correction_rad)));
  }
  return Ok{};
}

double reach_margin_m(const Vec3& p_base_m, const ArmWorkspace& arm) {
  const double r = (p_base_m - arm.shoulder_m).norm();
  return std::min({r - arm.min_reach_m, arm.max_reach_m - r, p_base_m.z() - arm.min_z_m,
                   arm.max_z_m - p_base_m.z()});
}

Outcome check_reach(const Vec3& p_base_m, const ArmWorkspace& arm, std::string_view field) {
  if (auto s = check_finite(p_base_m, field); !s) return s;
  const double margin = reach_margin_m(p_base_m, arm);
  if (!(margin >= 0.0)) {
    const double r = (p_base_m - arm.shoulder_m).norm();
    return make_error(
        ErrorCode::kOutOfReach, std::string(field),
        fmt::format(
            "{} (base {:.3f}, {:.3f}, {:.3f} m) is outside the arm's workspace by {:.3f} m: "
            "it is {:.3f} m from the shoulder (reach {:.3f}..{:.3f} m) at height {:.3f} m "
            "(allowed {:.3f}..{:.3f} m)",
            field, p_base_m.x(), p_base_m.y(), p_base_m.z(), -margin, r, arm.min_reach_m,
            arm.max_reach_m, p_base_m.z(), arm.min_z_m, arm.max_z_m));
  }
  return Ok{};
}

}  // namespace ajar::core
