// The RGBD camera as the operator console sees it (paper, section III.A): a pinhole model that
// turns a clicked pixel and its depth into a camera-frame point, and the pick rule for pixels
// without a depth measurement. Pure: no I/O, no threads, no logging. The point then goes to the
// base frame with CameraToBase (eq. 1), whose matrix comes from the daemon (RobotModel), never
// from a host-side copy of the config.
//
// Pixel convention: (u, v) with u to the right and v down, pixel centres at integer coordinates
// (the TUM RGB-D / OpenNI convention). Depth is the camera-frame z (metres), not the ray length.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include "ajar/core/result.hpp"
#include "ajar/core/types.hpp"

namespace ajar::core {

struct PinholeIntrinsics {
  double fx_px = 570.3;  // focal lengths (pixels); ASUS Xtion Pro Live class at 640x480
  double fy_px = 570.3;
  double cx_px = 319.5;  // principal point (pixels)
  double cy_px = 239.5;
  int width_px = 640;
  int height_px = 480;
};

// Ok, or kNonFinite / kBadCount naming "fx_px", "fy_px", "cx_px", "cy_px", "width_px",
// "height_px": focal lengths > 0, image 1..16384 pixels a side, principal point finite.
Outcome check_intrinsics(const PinholeIntrinsics& k);

// Pinhole deprojection: the camera-frame point at depth `depth_m` (camera z) seen at pixel (u, v):
// x = (u - cx) z / fx, y = (v - cy) z / fy, z = depth.
Vec3 deproject(const PinholeIntrinsics& k, double u_px, double v_px, double depth_m);

// The inverse: the pixel where a camera-frame point appears. Empty when the point is not in front
// of the camera (z <= 0 or not finite).
struct Pixel {
  double u_px = 0;
  double v_px = 0;
};
std::optional<Pixel> project(const PinholeIntrinsics& k, const Vec3& camera_point_m);

// A depth image as the console holds it: row-major, width x height metres of camera z; a hole (no
// measurement: specular, too near, shadowed) is 0 or NaN. Does not own the samples.
struct DepthView {
  std::span<const float> depth_m;
  int width_px = 0;
  int height_px = 0;
  // 0 for a hole (0, NaN, negative, infinite), else the depth.
  float at(int u_px, int v_px) const;
};

// How a click is turned into depth. A click on a hole takes the median of the valid depths in the
// (2 r + 1)^2 window around it when at least min_valid_fraction of the window is valid.
struct PickRule {
  int window_radius_px = 3;
  double min_valid_fraction = 0.3;
};

struct DepthPick {
  Vec3 camera_m = Vec3::Zero();  // the deprojected point, camera frame
  double depth_m = 0;
  bool from_window = false;  // the pixel itself was a hole: depth is the window median
  int valid_in_window = 0;   // valid samples in the window (only counted when from_window)
};

// The point under the pixel (rounded to the nearest pixel centre). Errors:
//   kBadCount, field "pixel": (u, v) outside the image or the view does not match the intrinsics;
//   kNonFinite, field "pixel": u or v not finite;
//   kPointOutOfDepthRange, field "depth": a hole whose window holds too few valid depths — the
//   message names the pixel, how many of the window's samples were valid and asks for a
//   measurable area (the paper's advice).
Result<DepthPick> pick_point(const PinholeIntrinsics& k, const DepthView& depth, double u_px,
                             double v_px, const PickRule& rule = {});

}  // namespace ajar::core
