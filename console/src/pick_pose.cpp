#include "ajar/console/pick_pose.hpp"

#include <Eigen/SVD>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace ajar::console {

PickMotion pick_motion(const core::PlanarPose& at, const core::PlanarPose& now,
                       const StaleRule& rule) {
  PickMotion m;
  m.travel_m = core::travel_m(at, now);
  m.turn_rad = core::turn_rad(at, now);
  const bool moved = m.travel_m > kPickMovedTravel_m || std::abs(m.turn_rad) > kPickMovedTurn_rad;
  if (!moved) return m;
  // The daemon's rule: stale once beyond either threshold (docs/procedure.md). Without the
  // daemon's thresholds any motion is too far.
  const bool stale = rule.travel_m <= 0 || rule.yaw_rad <= 0 || m.travel_m > rule.travel_m ||
                     std::abs(m.turn_rad) > rule.yaw_rad;
  m.place = stale ? PickPlace::kStale : PickPlace::kMoved;
  return m;
}

std::string moved_text(const PickMotion& m) {
  std::array<char, 96> buf{};
  std::snprintf(buf.data(), buf.size(), "the base moved %.3f m / %.1f\u00b0 since", m.travel_m,
                std::abs(m.turn_rad) * 180 / std::numbers::pi);
  return buf.data();
}

core::Vec3 camera_point_now(const core::Vec3& camera_m, const core::PlanarPose& at,
                            const core::PlanarPose& now, const core::CameraToBase& camera_to_base) {
  return camera_to_base.to_camera(core::rebase(camera_to_base.to_base(camera_m), at, now));
}

std::string out_of_view(const Camera& cam, const core::Vec3& base_m, double travel_m) {
  const core::Vec3 moved = base_m - core::Vec3(travel_m, 0, 0);  // the base drove +x by travel_m
  const core::Vec3 c = cam.camera_to_base.to_camera(moved);
  if (!(c.z() > 0)) return "behind the camera";
  if (cam.min_depth_m > 0 && c.z() < cam.min_depth_m) {
    std::array<char, 80> buf{};
    std::snprintf(buf.data(), buf.size(), "closer than the camera's %.2f m minimum depth",
                  cam.min_depth_m);
    return buf.data();
  }
  if (cam.max_depth_m > 0 && c.z() > cam.max_depth_m) return "beyond the camera's depth range";
  const auto px = core::project(cam.intrinsics, c);
  if (!px) return "behind the camera";
  const double m = cam.margin_px;
  const auto& k = cam.intrinsics;
  if (px->u_px < m) return "leaves the image at the left";
  if (px->u_px > k.width_px - 1 - m) return "leaves the image at the right";
  if (px->v_px < m) return "leaves the image at the top";
  if (px->v_px > k.height_px - 1 - m) return "leaves the image at the bottom";
  return "";
}

std::vector<ViewLimit> view_limits(const Camera& cam, const std::vector<Landmark>& landmarks,
                                   double distance_m, double lowest_m) {
  constexpr double kStep_m = 0.005;
  std::vector<ViewLimit> out;
  for (const auto& l : landmarks) {
    ViewLimit v;
    v.name = l.name;
    v.why = out_of_view(cam, l.base_m, 0);
    if (!v.why.empty()) {
      out.push_back(v);  // out of view already: infinity
      continue;
    }
    v.min_standoff_m = distance_m;
    // Drive closer in small steps until it leaves the view (or the lowest standoff is reached).
    for (double s = distance_m - kStep_m; s >= lowest_m - 1e-9; s -= kStep_m) {
      const std::string why = out_of_view(cam, l.base_m, distance_m - s);
      if (!why.empty()) {
        v.why = why;
        break;
      }
      v.min_standoff_m = s;
    }
    if (v.why.empty()) v.min_standoff_m = std::min(v.min_standoff_m, lowest_m);
    out.push_back(v);
  }
  return out;
}

double default_standoff(const std::vector<ViewLimit>& limits, double lowest_m, double preferred_m,
                        double distance_m) {
  double need = std::max(lowest_m, preferred_m);
  for (const auto& l : limits) {
    if (std::isfinite(l.min_standoff_m)) need = std::max(need, l.min_standoff_m);
  }
  need = std::ceil(need * 20 - 1e-9) / 20;  // up to 5 cm
  if (std::isfinite(distance_m) && need > distance_m) need = distance_m;
  return need;
}

double along_edges(const core::Vec3& p1_m, const core::Vec3& p2_m, const core::Vec3& p_m) {
  const Eigen::Vector2d a(p1_m.x(), p1_m.y());
  const Eigen::Vector2d d = Eigen::Vector2d(p2_m.x(), p2_m.y()) - a;
  const double len2 = d.squaredNorm();
  if (!(len2 > 0)) return 0.5;
  return (Eigen::Vector2d(p_m.x(), p_m.y()) - a).dot(d) / len2;
}

std::string hinge_side_problem(const core::Vec3& p1_m, const core::Vec3& p2_m,
                               const core::Vec3& handle_axis_m) {
  const double t = along_edges(p1_m, p2_m, handle_axis_m);
  if (t > 0.5) return "";
  const double width = Eigen::Vector2d(p2_m.x() - p1_m.x(), p2_m.y() - p1_m.y()).norm();
  std::array<char, 320> buf{};
  std::snprintf(buf.data(), buf.size(),
                "the handle is %.2f m from P1 (the hinge side you picked) and %.2f m from P2: a "
                "handle sits next to the moving edge, so P1 and P2 look reversed and the door "
                "would open the other way: measure the width again (P1 on the HINGE side)",
                std::abs(t) * width, std::abs(1 - t) * width);
  return buf.data();
}

std::optional<core::Plane> fit_points(const std::vector<core::Vec3>& points_m) {
  if (points_m.size() < 3) return std::nullopt;
  core::Vec3 c = core::Vec3::Zero();
  for (const auto& p : points_m)
    c += p;
  c /= static_cast<double>(points_m.size());
  Eigen::MatrixXd a(static_cast<Eigen::Index>(points_m.size()), 3);
  for (std::size_t i = 0; i < points_m.size(); ++i)
    a.row(static_cast<Eigen::Index>(i)) = (points_m[i] - c).transpose();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinV);
  const auto& s = svd.singularValues();
  if (!(s(1) > 1e-9 * std::max(1.0, s(0)))) return std::nullopt;  // collinear
  core::Plane plane;
  plane.normal = svd.matrixV().col(2).normalized();
  if (plane.normal.dot(-c) < 0) plane.normal = -plane.normal;  // toward the origin
  plane.centroid_m = c;
  double sum = 0;
  for (const auto& p : points_m)
    sum += std::pow(distance_to_plane(plane, p), 2);
  plane.rms_residual_m = std::sqrt(sum / static_cast<double>(points_m.size()));
  return plane;
}

double distance_to_plane(const core::Plane& plane, const core::Vec3& p_m) {
  return std::abs((p_m - plane.centroid_m).dot(plane.normal));
}

}  // namespace ajar::console
