// The procedure's measurements as whole, validated operations: framed points in, derived values
// out, or the first Error found (with the offending field in the request's terms). This is what the
// daemon calls for each host request; everything here is pure.
#pragma once

#include <span>

#include "ajar/core/geometry.hpp"

namespace ajar::core {

// Door width (paper IV.A): P1 on the hinge side, P2 near the moving edge. Checks, in order:
// finite ("p1.x".."p2.z"), known frame ("p1.frame"), depth range ("p1"/"p2"), Algorithm 1
// degeneracies ("p2"), width range ("width_m"). p1_base_m / p2_base_m: the points in the base
// frame.
struct SpanMeasurement {
  Span span;
  Vec3 p1_base_m = Vec3::Zero();
  Vec3 p2_base_m = Vec3::Zero();
};
Result<SpanMeasurement> measure_door_width(const FramedPoint& p1, const FramedPoint& p2,
                                           const CameraToBase& t, const Limits& limits);

// Handle length (paper IV.B): P1 on the handle's rotation axis, P2 at its free end.
// Same checks; range check on "handle_length_m".
Result<SpanMeasurement> measure_handle(const FramedPoint& p1, const FramedPoint& p2,
                                       const CameraToBase& t, const Limits& limits);

// Door plane (paper V.A), 3..16 points ("points[i]"): finite, depth, degeneracy, plane fit
// (three points: cross product; more: least squares), RMS residual ("rms_residual_m"), tilt,
// yaw within the maximum correction ("yaw_deviation_rad"); then the wheel command (eq. 6-7).
// Count outside kMinPlanePoints..kMaxPlanePoints: kBadCount ("points"). No heap allocation for the
// points themselves; the SVD of 4+ points allocates.
inline constexpr int kMinPlanePoints = 3;
inline constexpr int kMaxPlanePoints = 16;  // more: kBadCount, field "points"
struct PlaneMeasurement {
  Plane plane;
  double yaw_deviation_rad = 0;
  WheelCommand wheels;
  int point_count = 0;
};
Result<PlaneMeasurement> measure_door_plane(std::span<const FramedPoint> points,
                                            const CameraToBase& t, const Limits& limits,
                                            const BaseGeometry& base);

// Contact point (paper IV.C): finite ("contact.x"), depth, within the arm's workspace ("contact").
// reach_margin_m: see reach_margin_m() (>= 0 here).
struct ContactMeasurement {
  Vec3 contact_base_m = Vec3::Zero();
  double reach_margin_m = 0;
};
Result<ContactMeasurement> measure_contact_point(const FramedPoint& p, const CameraToBase& t,
                                                 const Limits& limits);

}  // namespace ajar::core
