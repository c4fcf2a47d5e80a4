// Picks that know where the base was, and the geometry guidance the page shows. Pure math over
// core (no I/O, no threads); ajar-console's server calls it, tests/console checks it.
//
// Every pick keeps the base pose (the daemon's odometry, the frame of the base when ajard started)
// of the frame it was taken on. After the base moves, the pick's camera-frame point is seen from
// the new pose through the daemon's camera -> base calibration (eq. 1) and odometry
// (core::rebase): that is where its marker is drawn, and what is sent when the motion is small.
// The rule for "too far" is the daemon's own staleness rule (docs/procedure.md): the base origin
// moved more than drive.stale_travel_m or turned more than drive.stale_yaw_rad (RobotModel),
// measured by the same core::travel_m / core::turn_rad.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ajar/core/camera.hpp"
#include "ajar/core/driving.hpp"
#include "ajar/core/geometry.hpp"

namespace ajar::console {

// Below these the base counts as not having moved (encoder quantisation, not motion).
inline constexpr double kPickMovedTravel_m = 0.0005;
inline constexpr double kPickMovedTurn_rad = 0.0005;

struct StaleRule {
  double travel_m = 0;  // RobotModel::stale_travel_m; 0 (unknown): any motion is too far
  double yaw_rad = 0;   // RobotModel::stale_yaw_rad
};

enum class PickPlace {
  kHere,   // the base has not moved since the pick
  kMoved,  // moved within the rule: the point is seen from the new pose (reprojected, transformed)
  kStale,  // moved beyond the rule: pick again
};

struct PickMotion {
  double travel_m = 0;  // straight-line displacement of the base origin since the pick
  double turn_rad = 0;  // turn since the pick, (-pi, pi]
  PickPlace place = PickPlace::kHere;
};
PickMotion pick_motion(const core::PlanarPose& at, const core::PlanarPose& now,
                       const StaleRule& rule);

// "the base moved 0.070 m / 1.3° since"
std::string moved_text(const PickMotion& m);

// A camera-frame point picked at pose `at`, in the camera frame at pose `now`.
core::Vec3 camera_point_now(const core::Vec3& camera_m, const core::PlanarPose& at,
                            const core::PlanarPose& now, const core::CameraToBase& camera_to_base);

// ---- Geometry guidance -------------------------------------------------------------------------

// A point of the door the console measured (base frame now), e.g. "hinge edge (P1)".
struct Landmark {
  std::string name;
  core::Vec3 base_m = core::Vec3::Zero();
};

struct Camera {
  core::PinholeIntrinsics intrinsics;
  core::CameraToBase camera_to_base;
  double min_depth_m = 0;  // RobotModel: the depth the sensor measures (camera z)
  double max_depth_m = 0;
  double margin_px = 8;  // a point closer than this to the image border counts as leaving it
};

// Empty when `base_m`, after the base drove `travel_m` straight forward, is in the image (inside
// the margin) and within the depth range; otherwise why not: "leaves the image at the top",
// "closer than the camera's 0.45 m minimum depth", "behind the camera".
std::string out_of_view(const Camera& cam, const core::Vec3& base_m, double travel_m);

struct ViewLimit {
  std::string name;
  // The smallest standoff from the door at which the landmark is still in view (the base drives
  // straight to it from `distance_m`); infinity when it is out of view already.
  double min_standoff_m = std::numeric_limits<double>::infinity();
  std::string why;  // what happens below min_standoff_m
};

// For an Approach from `distance_m` (the door distance now) down to `lowest_m`, in 5 mm steps.
std::vector<ViewLimit> view_limits(const Camera& cam, const std::vector<Landmark>& landmarks,
                                   double distance_m, double lowest_m);

// The standoff that keeps every landmark in view: the largest min_standoff_m rounded up to 5 cm,
// and at least `lowest_m` (drive.approach_min_standoff_m) and `preferred_m` (the paper's 0.75 m);
// never above `distance_m` (then no approach keeps them: stay where the base is).
double default_standoff(const std::vector<ViewLimit>& limits, double lowest_m, double preferred_m,
                        double distance_m);

// The handle is next to the moving edge of a door, never the hinge: with P1 (hinge side), P2
// (moving edge) and the handle's axis in one base frame, the axis must lie nearer P2 along the
// P1->P2 line. Empty when it does; else the warning naming the distances.
std::string hinge_side_problem(const core::Vec3& p1_m, const core::Vec3& p2_m,
                               const core::Vec3& handle_axis_m);

// Least-squares plane through `points_m` (at least 3, not collinear), and each point's distance
// from it; empty when the points cannot be fitted.
std::optional<core::Plane> fit_points(const std::vector<core::Vec3>& points_m);
double distance_to_plane(const core::Plane& plane, const core::Vec3& p_m);

// Lateral position of `p_m` along the P1->P2 line, as a fraction: 0 at P1, 1 at P2 (floor plane).
double along_edges(const core::Vec3& p1_m, const core::Vec3& p2_m, const core::Vec3& p_m);

}  // namespace ajar::console
