#include <cmath>
#include <random>
#include <vector>

#include "ajar/client/simulate.hpp"

namespace ajar::client {

// ---- The world ---------------------------------------------------------------------------------

SimWorld::SimWorld(const Scenario& scenario, const Eigen::Matrix4d& camera_to_base_m)
    : scenario_(scenario), rng_(scenario.seed) {
  camera_to_base_.matrix() = camera_to_base_m;
}

core::Vec3 SimWorld::door_normal() const {
  return -core::Vec3(std::cos(scenario_.yaw_rad), std::sin(scenario_.yaw_rad), 0);
}

core::Vec3 SimWorld::door_point(double lateral_m, double z_m, double proud_m) const {
  const double c = std::cos(scenario_.yaw_rad);
  const double s = std::sin(scenario_.yaw_rad);
  const core::Vec3 foot(scenario_.distance_m * c, scenario_.distance_m * s, 0);
  const core::Vec3 lateral(-s, c, 0);
  return foot + lateral_m * lateral + core::Vec3(0, 0, z_m) + proud_m * door_normal();
}

namespace {
double hinge_sign(const Scenario& s) {
  return s.hinge == Scenario::Hinge::kLeft ? 1.0 : -1.0;
}
}  // namespace

core::Vec3 SimWorld::hinge_edge_point() const {
  const double h = hinge_sign(scenario_);
  const double lat =
      scenario_.lateral_offset_m + h * (scenario_.door_width_m / 2 - scenario_.edge_inset_m);
  return door_point(lat, scenario_.width_pick_height_m);
}

core::Vec3 SimWorld::moving_edge_point() const {
  const double h = hinge_sign(scenario_);
  const double lat =
      scenario_.lateral_offset_m - h * (scenario_.door_width_m / 2 - scenario_.edge_inset_m);
  return door_point(lat, scenario_.width_pick_height_m);
}

core::Vec3 SimWorld::handle_axis_point() const {
  const double h = hinge_sign(scenario_);
  const double lat = scenario_.lateral_offset_m - h * scenario_.door_width_m / 2 +
                     h * scenario_.handle_axis_from_edge_m;
  return door_point(lat, scenario_.handle_height_m, scenario_.handle_offset_m);
}

core::Vec3 SimWorld::handle_free_end_point() const {
  const double h = hinge_sign(scenario_);
  const double lat = scenario_.lateral_offset_m - h * scenario_.door_width_m / 2 +
                     h * (scenario_.handle_axis_from_edge_m + scenario_.handle_length_m);
  return door_point(lat, scenario_.handle_height_m, scenario_.handle_offset_m);
}

core::Vec3 SimWorld::contact_point() const {
  return handle_axis_point() + (handle_free_end_point() - handle_axis_point()) * (2.0 / 3.0);
}

std::vector<core::Vec3> SimWorld::plane_points(int count) {
  std::uniform_real_distribution<double> jitter(-0.03, 0.03);
  const double w = scenario_.door_width_m;
  const double c = scenario_.lateral_offset_m;
  const double z_lo = scenario_.door_bottom_z_m + 0.25 * scenario_.door_height_m;
  const double z_hi = scenario_.door_bottom_z_m + 0.75 * scenario_.door_height_m;
  std::vector<core::Vec3> points;
  if (count == 3) {
    // The paper's operator: a wide triangle on the leaf.
    points.push_back(door_point(c - 0.35 * w + jitter(rng_), z_lo + jitter(rng_)));
    points.push_back(door_point(c + 0.35 * w + jitter(rng_), z_lo + jitter(rng_)));
    points.push_back(door_point(c + jitter(rng_), z_hi + jitter(rng_)));
    return points;
  }
  for (int i = 0; i < count; ++i) {
    // A low-discrepancy spread over the leaf (lateral by the golden ratio, height evenly).
    const double u = std::fmod(0.1 + 0.6180339887 * i, 1.0) - 0.5;
    const double v = (i + 0.5) / count;
    points.push_back(
        door_point(c + 0.8 * w * u + jitter(rng_), z_lo + (z_hi - z_lo) * v + jitter(rng_)));
  }
  return points;
}

core::Vec3 SimWorld::to_camera(const core::Vec3& world_point, double base_yaw_rad) const {
  return to_camera(world_point, core::PlanarPose{0, 0, base_yaw_rad});
}

core::Vec3 SimWorld::to_camera(const core::Vec3& world_point, const core::PlanarPose& base) const {
  return camera_to_base_.inverse() * core::rebase(world_point, core::PlanarPose{}, base);
}

double SimWorld::true_distance_m(const core::PlanarPose& base) const {
  return door_normal().dot(core::Vec3(base.x_m, base.y_m, 0) - door_point(0, 0));
}

core::Vec3 SimWorld::pick(const core::Vec3& world_point, double base_yaw_rad) {
  return pick(world_point, core::PlanarPose{0, 0, base_yaw_rad});
}

core::Vec3 SimWorld::pick(const core::Vec3& world_point, const core::PlanarPose& base) {
  const double base_yaw_rad = base.yaw_rad;
  const core::Vec3 p = to_camera(world_point, base);
  if (p.z() <= 1e-3) return p;  // behind the camera: nothing sensible to add
  std::normal_distribution<double> unit(0.0, 1.0);
  const double f = scenario_.focal_length_px;
  // Pixel-picking error: a neighbouring pixel's ray, re-intersected with the picked surface (the
  // plane through the true point, parallel to the door).
  const double u = f * p.x() / p.z() + scenario_.pixel_noise_px * unit(rng_);
  const double v = f * p.y() / p.z() + scenario_.pixel_noise_px * unit(rng_);
  const core::Vec3 ray(u / f, v / f, 1.0);
  const core::Vec3 n_base = Eigen::AngleAxisd(-base_yaw_rad, core::Vec3::UnitZ()) * door_normal();
  const core::Vec3 n_cam = camera_to_base_.linear().transpose() * n_base;
  core::Vec3 picked = p;
  const double denom = n_cam.dot(ray);
  if (std::abs(denom) > 1e-6) {
    const double lambda = n_cam.dot(p) / denom;
    if (lambda > 0) picked = lambda * ray;
  }
  // Depth noise: sigma grows with the square of the depth (structured light).
  const double z = picked.z();
  const double sigma = scenario_.depth_noise_at_1m_m * z * z;
  const double z_noisy = z + sigma * unit(rng_);
  return picked * (z_noisy / z);
}

}  // namespace ajar::client
