#include "ajar/core/camera.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <fmt/format.h>

namespace ajar::core {
namespace {

constexpr int kMaxSidePx = 16384;

}  // namespace

Outcome check_intrinsics(const PinholeIntrinsics& k) {
  const std::array<std::pair<const char*, double>, 4> values{
      {{"fx_px", k.fx_px}, {"fy_px", k.fy_px}, {"cx_px", k.cx_px}, {"cy_px", k.cy_px}}};
  for (const auto& [field, value] : values) {
    if (!std::isfinite(value)) {
      return make_error(ErrorCode::kNonFinite, field, std::string(field) + " is not finite");
    }
  }
  if (k.fx_px <= 0) return make_error(ErrorCode::kBadCount, "fx_px", "focal length fx must be > 0");
  if (k.fy_px <= 0) return make_error(ErrorCode::kBadCount, "fy_px", "focal length fy must be > 0");
  if (k.width_px < 1 || k.width_px > kMaxSidePx) {
    return make_error(ErrorCode::kBadCount, "width_px", "image width must be 1..16384 pixels");
  }
  if (k.height_px < 1 || k.height_px > kMaxSidePx) {
    return make_error(ErrorCode::kBadCount, "height_px", "image height must be 1..16384 pixels");
  }
  return Ok{};
}

Vec3 deproject(const PinholeIntrinsics& k, double u_px, double v_px, double depth_m) {
  return {(u_px - k.cx_px) * depth_m / k.fx_px, (v_px - k.cy_px) * depth_m / k.fy_px, depth_m};
}

std::optional<Pixel> project(const PinholeIntrinsics& k, const Vec3& p) {
  if (!p.allFinite() || p.z() <= 0) return std::nullopt;
  return Pixel{k.cx_px + k.fx_px * p.x() / p.z(), k.cy_px + k.fy_px * p.y() / p.z()};
}

float DepthView::at(int u_px, int v_px) const {
  const auto i = static_cast<std::size_t>(v_px) * static_cast<std::size_t>(width_px) +
                 static_cast<std::size_t>(u_px);
  const float d = depth_m[i];
  return (std::isfinite(d) && d > 0.0F) ? d : 0.0F;
}

Result<DepthPick> pick_point(const PinholeIntrinsics& k, const DepthView& depth, double u_px,
                             double v_px, const PickRule& rule) {
  if (!std::isfinite(u_px) || !std::isfinite(v_px)) {
    return make_error(ErrorCode::kNonFinite, "pixel", "the clicked pixel is not finite");
  }
  if (depth.width_px != k.width_px || depth.height_px != k.height_px ||
      depth.depth_m.size() !=
          static_cast<std::size_t>(depth.width_px) * static_cast<std::size_t>(depth.height_px)) {
    return make_error(ErrorCode::kBadCount, "pixel",
                      "the depth image does not match the camera intrinsics");
  }
  const double ur = std::round(u_px);
  const double vr = std::round(v_px);
  if (ur < 0 || vr < 0 || ur >= k.width_px || vr >= k.height_px) {
    return make_error(ErrorCode::kBadCount, "pixel",
                      fmt::format("pixel ({:.1f}, {:.1f}) is outside the image", u_px, v_px));
  }
  const int u = static_cast<int>(ur);
  const int v = static_cast<int>(vr);
  DepthPick pick;
  double z = static_cast<double>(depth.at(u, v));
  if (z <= 0) {
    const int r = std::max(0, rule.window_radius_px);
    // At most a 33x33 window on the stack; larger radii are clamped.
    std::array<float, 33 * 33> samples{};
    const int rr = std::min(r, 16);
    int valid = 0;
    int total = 0;
    for (int dv = -rr; dv <= rr; ++dv) {
      for (int du = -rr; du <= rr; ++du) {
        const int uu = u + du;
        const int vv = v + dv;
        if (uu < 0 || vv < 0 || uu >= depth.width_px || vv >= depth.height_px) continue;
        ++total;
        const float d = depth.at(uu, vv);
        if (d > 0) samples[static_cast<std::size_t>(valid++)] = d;
      }
    }
    const double needed = rule.min_valid_fraction * total;
    if (valid == 0 || valid < needed) {
      return make_error(ErrorCode::kPointOutOfDepthRange, "depth",
                        fmt::format("no depth at pixel ({}, {}): only {} of {} pixels around it "
                                    "are measured; pick a measurable area",
                                    u, v, valid, total));
    }
    auto* first = samples.data();
    auto* mid = first + valid / 2;
    std::nth_element(first, mid, first + valid);
    z = static_cast<double>(*mid);
    if (valid % 2 == 0) {
      const float lower = *std::max_element(first, mid);
      z = (z + static_cast<double>(lower)) / 2.0;
    }
    pick.from_window = true;
    pick.valid_in_window = valid;
  }
  pick.depth_m = z;
  pick.camera_m = deproject(k, u_px, v_px, z);
  return pick;
}

}  // namespace ajar::core
