// The console tests' camera: a flat grey wall 2 m ahead of a small pinhole camera (principal point
// in the middle), at a fixed rate; with left_half_hole the left half of the image has no depth.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "ajar/console/frame.hpp"

namespace ajar::console::testing {

class WallSource final : public FrameSource {
 public:
  WallSource(int width_px, int height_px, double f_px, double rate_hz, bool left_half_hole)
      : width_px_(width_px),
        height_px_(height_px),
        f_px_(f_px),
        rate_hz_(rate_hz),
        left_half_hole_(left_half_hole) {}
  std::string describe() const override { return "test wall"; }
  double rate_hz() const override { return rate_hz_; }
  bool next(const BasePose&, Frame& out, std::string&) override {
    out.intrinsics.width_px = width_px_;
    out.intrinsics.height_px = height_px_;
    out.intrinsics.fx_px = out.intrinsics.fy_px = f_px_;
    out.intrinsics.cx_px = (width_px_ - 1) / 2.0;
    out.intrinsics.cy_px = (height_px_ - 1) / 2.0;
    const auto pixels = static_cast<std::size_t>(width_px_ * height_px_);
    out.rgb.assign(pixels * 3, 128);
    out.depth_m.assign(pixels, 2.0F);
    for (int v = 0; left_half_hole_ && v < height_px_; ++v) {
      for (int u = 0; u < width_px_ / 2; ++u)
        out.depth_m[static_cast<std::size_t>(v * width_px_ + u)] = 0.0F;
    }
    out.sequence = ++sequence_;
    return true;
  }

 private:
  int width_px_;
  int height_px_;
  double f_px_;
  double rate_hz_;
  bool left_half_hole_;
  std::uint64_t sequence_ = 0;
};

}  // namespace ajar::console::testing
