// The paper's math, done right. Pure functions: no I/O, no threads, no logging.
// docs/geometry.md explains the frames, the yaw sign convention and the relation to eq. 5.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <span>
#include <string_view>

#include <Eigen/Geometry>

#include "ajar/core/fields.hpp"
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
  // The error's field is "rotation", "determinant", "bottom_row" (code kTransformNotRigid) or
  // "matrix" (kNonFinite). An accepted rotation is snapped to the nearest exact rotation (SVD), so
  // to_camera inverts to_base to rounding error.
  static Result<CameraToBase> from_matrix(const Eigen::Matrix4d& matrix, double tolerance = 1e-6);

  Vec3 to_base(const Vec3& camera_point_m) const { return transform_ * camera_point_m; }
  Vec3 to_camera(const Vec3& base_point_m) const { return transform_.inverse() * base_point_m; }
  // Expresses a framed point in the base frame. A Frame value outside the enum gives NaNs (which
  // every later finite check refuses); check_depth reports it as kUnknownFrame.
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
// kPointsNotSideBySide (|y1 - y2| / |P1P2| below min_lateral_fraction), checked in that order, so
// y1 == y2 is always kAmbiguousDirection. kNonFinite for NaN/inf (field "p1.x" .. "p2.z"); the
// other errors name "p2". P1 is the hinge side: a door hinged on the robot's left (larger y)
// opens CCW.
Result<Span> measure_span(const Vec3& p1_base_m, const Vec3& p2_base_m, const Tolerances& tol);

// ---- Door plane (eq. 3-4 and least squares) ---------------------------------------------------

struct Plane {
  Vec3 normal = Vec3::UnitX();     // unit normal, oriented toward the base origin (the robot)
  Vec3 centroid_m = Vec3::Zero();  // mean of the points
  double rms_residual_m = 0;       // RMS of point-to-plane distances (0 for three points)
};

// Exactly three points, normal by cross product (eq. 3-4), then oriented toward the robot.
// Refuses duplicates / too-close points (kPointsTooClose, field "points[i]") and collinear points
// (kPointsCollinear) with a scale-aware measure: |PA PB x PA PC| / (longest edge)^2.
Result<Plane> plane_from_three_points(const Vec3& a_m, const Vec3& b_m, const Vec3& c_m,
                                      const Tolerances& tol);

// N >= 3 points: least-squares plane (SVD of the centred points) with its RMS residual.
// Degeneracy is scale-aware: second singular value / first below tol.collinearity -> collinear.
// With exactly three points it is plane_from_three_points. Fewer than 3: kBadCount ("points").
// Non-finite: kNonFinite ("points[i].x"). A plane through the base origin has no robot side: its
// normal is made to face -x (then -y, then -z).
Result<Plane> fit_plane(std::span<const Vec3> points_base_m, const Tolerances& tol);

// ---- Signed yaw deviation ----------------------------------------------------------------------

// The signed angle (radians, counter-clockwise about base +z positive, in (-pi/2, pi/2)) that the
// base must turn so that its +x axis points squarely into the door, i.e. along -normal projected on
// the floor: atan2(-n.y, -n.x). Independent of the order the points were picked in (the normal is
// oriented toward the robot first). kPlaneNotVertical (field "points") when the normal tilts more
// than tol.max_door_tilt_rad from horizontal; kYawOutOfRange ("yaw_deviation_rad") when the door
// does not face the robot's front half (|yaw| >= pi/2); kNonFinite for a zero or NaN normal.
Result<double> yaw_deviation_rad(const Plane& plane, const Tolerances& tol);

// The yaw (rad, CCW positive) that turns the base's +x onto -normal projected on the floor (the
// normal faces the robot): atan2(-n.y, -n.x). The one formula of the door's yaw: the plane's yaw
// deviation above and the door seen from odometry (driving.hpp) both use it.
double yaw_from_normal_rad(const Vec3& normal) noexcept;

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

// `base` must be valid (positive radii, gear ratio and counts per rev; the config checks it). A
// non-finite yaw, or one whose counts would exceed 2^53, gives an all-zero command (nothing moves)
// with residual_yaw_rad = yaw_rad.
WheelCommand wheel_command(double yaw_rad, const BaseGeometry& base);

// Motor counts (polarity not applied) for a wheel rotation: round-half-away-from-zero of
// wheel_rad / 2π · gear_ratio · counts_per_rev (so opposite rotations give exact opposite counts).
// nullopt when that is not finite or not below 2^53 (doubles hold every integer below it exactly):
// nothing may move then.
std::optional<std::int64_t> wheel_rad_to_motor_counts(double wheel_rad,
                                                      const BaseGeometry& base) noexcept;

// Wheel rotation (rad, wheel-forward positive) for a card count on an axis (polarity applied):
// counts * polarity / (gear_ratio * counts_per_rev) * 2pi. With base_yaw_from_wheels_rad this is
// the exact inverse of wheel_command: commanding the yaw read back from counts gives those counts.
double counts_to_wheel_rad(std::int64_t counts, const WheelAxis& axis, const BaseGeometry& base);
// Base yaw (rad, CCW positive) implied by left/right wheel rotations (differential drive in place):
// (right - left) / 2 * R_W / R_B.
double base_yaw_from_wheels_rad(double left_wheel_rad, double right_wheel_rad,
                                const BaseGeometry& base);

// ---- Validation predicates ----------------------------------------------------------------------
// Each returns Ok or an Error whose field names the offending input (using `field`).

// kNonFinite naming the coordinate: field "p2" -> "p2.z".
Outcome check_finite(const Vec3& p, std::string_view field);
// A point given in the camera frame must lie within [min_depth_m, max_depth_m] along camera z.
// A base-frame point is taken back to the camera frame first. Bounds inclusive.
// kPointOutOfDepthRange (field), kUnknownFrame (field + ".frame").
Outcome check_depth(const FramedPoint& p, const CameraToBase& t, const Limits& limits,
                    std::string_view field);
Outcome check_door_width(double width_m, const Limits& limits,
                         std::string_view field = fields::kWidth);
Outcome check_handle_length(double length_m, const Limits& limits,
                            std::string_view field = fields::kHandleLength);
Outcome check_yaw(double yaw_rad, const Limits& limits,
                  std::string_view field = fields::kYawDeviation);

// Ranges are inclusive; a NaN value gives kNonFinite. Messages carry the value and the range, e.g.
// "door width 40.000 m is outside the allowed range 0.500..2.000 m".
//
// Reach margin (m): the distance from a base-frame point to the nearest workspace boundary (inner
// sphere, outer sphere, bottom or top of the z band), i.e. min(r - min_reach, max_reach - r,
// z - min_z, max_z - z) with r = |p - shoulder|; negative = outside (then by how much it misses
// the most violated boundary). check_reach: kOutOfReach when the margin is negative.
double reach_margin_m(const Vec3& p_base_m, const ArmWorkspace& arm);
Outcome check_reach(const Vec3& p_base_m, const ArmWorkspace& arm, std::string_view field);

}  // namespace ajar::core
