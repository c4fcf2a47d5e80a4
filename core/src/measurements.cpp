#include "ajar/core/measurements.hpp"

#include <array>
#include <string>

#include <fmt/format.h>

namespace ajar::core {

namespace {

// A picked point, checked (finite, known frame, within the sensor's depth range), in the base
// frame.
Result<Vec3> point_in_base(const FramedPoint& p, const CameraToBase& t, const Limits& limits,
                           std::string_view field) {
  if (auto s = check_finite(p.position_m, field); !s) return std::move(s).error();
  if (auto s = check_depth(p, t, limits, field); !s) return std::move(s).error();
  const Vec3 base = t.to_base(p);
  if (auto s = check_finite(base, field); !s) return std::move(s).error();
  return base;
}

using RangeCheck = Outcome (*)(double, const Limits&, std::string_view);

Result<SpanMeasurement> measure_two_points(const FramedPoint& p1, const FramedPoint& p2,
                                           const CameraToBase& t, const Limits& limits,
                                           RangeCheck check_length, std::string_view length_field) {
  auto b1 = point_in_base(p1, t, limits, fields::kP1);
  if (!b1) return std::move(b1).error();
  auto b2 = point_in_base(p2, t, limits, fields::kP2);
  if (!b2) return std::move(b2).error();
  auto span = measure_span(*b1, *b2, limits.tolerances);
  if (!span) return std::move(span).error();
  if (auto s = check_length(span->length_m, limits, length_field); !s) {
    return std::move(s).error();
  }
  return SpanMeasurement{*span, *b1, *b2};
}

}  // namespace

Result<SpanMeasurement> measure_door_width(const FramedPoint& p1, const FramedPoint& p2,
                                           const CameraToBase& t, const Limits& limits) {
  return measure_two_points(p1, p2, t, limits, &check_door_width, fields::kWidth);
}

Result<SpanMeasurement> measure_handle(const FramedPoint& p1, const FramedPoint& p2,
                                       const CameraToBase& t, const Limits& limits) {
  return measure_two_points(p1, p2, t, limits, &check_handle_length, fields::kHandleLength);
}

Result<PlaneMeasurement> measure_door_plane(std::span<const FramedPoint> points,
                                            const CameraToBase& t, const Limits& limits,
                                            const BaseGeometry& base) {
  const std::size_t n = points.size();
  if (n < static_cast<std::size_t>(kMinPlanePoints) ||
      n > static_cast<std::size_t>(kMaxPlanePoints)) {
    return make_error(ErrorCode::kBadCount, std::string(fields::kPoints),
                      fmt::format("the door plane needs {} to {} points; got {}", kMinPlanePoints,
                                  kMaxPlanePoints, n));
  }
  std::array<Vec3, kMaxPlanePoints> in_base;
  for (std::size_t i = 0; i < n; ++i) {
    auto b = point_in_base(points[i], t, limits, point_field(i));
    if (!b) return std::move(b).error();
    in_base[i] = *b;
  }
  const Tolerances& tol = limits.tolerances;
  auto plane = fit_plane(std::span<const Vec3>(in_base.data(), n), tol);
  if (!plane) return std::move(plane).error();
  if (!(plane->rms_residual_m <= tol.max_plane_rms_m)) {
    return make_error(
        ErrorCode::kPlaneResidualTooLarge, std::string(fields::kRmsResidual),
        fmt::format("the {} points are {:.4f} m (RMS) off a common plane; at most {:.4f} m is "
                    "allowed: pick points on the flat door leaf",
                    n, plane->rms_residual_m, tol.max_plane_rms_m));
  }
  auto yaw = yaw_deviation_rad(*plane, tol);
  if (!yaw) return std::move(yaw).error();
  if (auto s = check_yaw(*yaw, limits); !s) return std::move(s).error();
  PlaneMeasurement m;
  m.plane = *plane;
  m.yaw_deviation_rad = *yaw;
  m.wheels = wheel_command(*yaw, base);
  m.point_count = static_cast<int>(n);
  return m;
}

Result<ContactMeasurement> measure_contact_point(const FramedPoint& p, const CameraToBase& t,
                                                 const Limits& limits) {
  auto b = point_in_base(p, t, limits, fields::kContact);
  if (!b) return std::move(b).error();
  if (auto s = check_reach(*b, limits.arm, fields::kContact); !s) return std::move(s).error();
  return ContactMeasurement{*b, reach_margin_m(*b, limits.arm)};
}

}  // namespace ajar::core
