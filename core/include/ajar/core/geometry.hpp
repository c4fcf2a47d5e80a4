// The paper's math, done right. Pure functions: no I/O, no threads, no logging.
// docs/geometry.md explains the frames, the yaw sign convention and the relation to eq. 5.
#pragma once

#include <span>
#include <string_view>

#include <Eigen/Geometry>

#include "ajar/core/result.hpp"
#include "ajar/core/robot_model.hpp"
#include "ajar/core/types.hpp"

namespace ajar::core {

// ---- Frames (eq. 1-2) ------------------------------------------------------------------------

// The paper's ^B_C T (eq. 2), converted from centimetres to metres.
Eigen::Matrix4d paper_camera_to_base_m();

// A rigid camera -> base transform. Construct only through from_matrix(), which checks rigidity.
class CameraToBase {
 public:
  // Accepts a 4x4 homogeneous matrix whose rotation is orthonormal to `tolerance` (max abs entry
  // of R^T R - I), det(R) = +1 within tolerance, and bottom row exactly 0 0 0 1; all finite.
  // The error's field is "rotation", "determinant", "bottom_row" or "matrix".
  static Result<CameraToBase> from_matrix(const Eigen::Matrix4d& matrix, double tolerance = 1e-6);

  Vec3 to_base(const Vec3& camera_point_m) const { return transform_ * camera_point_m; }
  Vec3 to_camera(const Vec3& base_point_m) const { return transform_.inverse() * base_point_m; }
  // Expresses a framed point in the base frame.
  Vec3 to_base(const FramedPoint& point) const;
  const Eigen::Isometry3d& isometry() const { return transform_; }

 private:
  explicit CameraToBase(const Eigen::Isometry3d& t) : transform_(t) {}
  Eigen::Isometry3d transform_;
};

// ---- Algorithm 1: distance and direction of rotation -----------------------------------------

struct Span {
  double length_m = 0;
  RotationDirection direction = RotationDirection::kClockwise;
};

// Algorithm 1 in the base frame: length = |P1P2|; y1 - y2 > 0 -> CCW, < 0 -> CW.
// Where the paper silently answers CW, this refuses: kPointsTooClose (|P1P2| below the minimum
// separation), kAmbiguousDirection (|y1 - y2| below the minimum separation) or
// kPointsNotSideBySide (|y1 - y2| / |P1P2| below min_lateral_fraction). kNonFinite for NaN/inf.
// Fields are "p1" / "p2".
Result<Span> measure_span(const Vec3& p1_base_m, const Vec3& p2_base_m, const Tolerances& tol);

// ---- Door plane (eq. 3-4 and least squares) ---------------------------------------------------

struct Plane {
  Vec3 normal = Vec3::UnitX();        // unit normal, oriented toward the base origin (the robot)
  Vec3 centroid_m = Vec3::Zero();     // mean of the points
  double rms_residual_m = 0;          // RMS of point-to-plane distances (0 for three points)
};

// Exactly three points, normal by cross product (eq. 3-4), then oriented toward the robot.
// Refuses duplicates / too-close points (kPointsTooClose, field "points[i]") and collinear points
// (kPointsCollinear) with a scale-aware measure: |PA PB x PA PC| / (longest edge)^2.
Result<Plane> plane_from_three_points(const Vec3& a_m, const Vec3& b_m, const Vec3& c_m,
                                      const Tolerances& tol);

// N >= 3 points: least-squares plane (SVD of the centred points) with its RMS residual.
// Degeneracy is scale-aware: second singular value / first below tol.collinearity -> collinear.
// With exactly three points the normal equals plane_from_three_points'.
Result<Plane> fit_plane(std::span<const Vec3> points_base_m, const Tolerances& tol);

// ---- Signed yaw deviation ----------------------------------------------------------------------

// The signed angle (radians, counter-clockwise about base +z positive, in (-pi/2, pi/2)) that the
// base must turn so that its +x axis points squarely into the door, i.e. along -normal projected on
// the floor. Independent of the order the points were picked in (the normal is oriented toward the
// robot first). kPlaneNotVertical when the normal tilts more than tol.max_door_tilt_rad from
// horizontal.
Result<double> yaw_deviation_rad(const Plane& plane, const Tolerances& tol);

// ---- Wheel angles (eq. 6-7) --------------------------------------------------------------------

struct WheelCommand {
  // θ_W = θ_diff · R_B / R_W. Turning counter-clockwise (positive yaw) rolls the right wheel
  // forward and the left wheel backward: left = -θ_W, right = +θ_W (wheel-forward positive).
  double left_wheel_rad = 0;
  double right_wheel_rad = 0;
  // Motor counts on the card, including each axis' polarity: round-half-away-from-zero of
  // θ_wheel / 2π · gear_ratio · counts_per_rev.
  std::int64_t left_counts = 0;
  std::int64_t right_counts = 0;
  // The base yaw the rounded counts actually produce, and what rounding leaves undone
  // (requested - achieved).
  double achieved_yaw_rad = 0;
  double residual_yaw_rad = 0;
};

WheelCommand wheel_command(double yaw_rad, const BaseGeometry& base);

// Wheel rotation (rad, wheel-forward positive) for a motor count on an axis, and back.
double counts_to_wheel_rad(std::int64_t counts, const WheelAxis& axis, const BaseGeometry& base);
// Base yaw (rad, CCW positive) implied by left/right wheel rotations (differential drive in place).
double base_yaw_from_wheels_rad(double left_wheel_rad, double right_wheel_rad,
                                const BaseGeometry& base);

// ---- Validation predicates ----------------------------------------------------------------------
// Each returns Ok or an Error whose field names the offending input (using `field`).

Status check_finite(const Vec3& p, std::string_view field);
// A point given in the camera frame must lie within [min_depth_m, max_depth_m] along camera z.
// A base-frame point is taken back to the camera frame first.
Status check_depth(const FramedPoint& p, const CameraToBase& t, const Limits& limits,
                   std::string_view field);
Status check_door_width(double width_m, const Limits& limits, std::string_view field = "width_m");
Status check_handle_length(double length_m, const Limits& limits,
                           std::string_view field = "handle_length_m");
Status check_yaw(double yaw_rad, const Limits& limits, std::string_view field = "yaw_deviation_rad");

// Reach margin (m): how far inside the arm workspace a base-frame point is; negative = outside.
double reach_margin_m(const Vec3& p_base_m, const ArmWorkspace& arm);
Status check_reach(const Vec3& p_base_m, const ArmWorkspace& arm, std::string_view field);

}  // namespace ajar::core
