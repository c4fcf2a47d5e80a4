// One RGBD frame as the console serves it, and the interface every frame source implements
// (simulated door scene, recorded TUM RGB-D folder, live OpenNI2 sensor).
//
// A frame is registered: depth pixel (u, v) and colour pixel (u, v) see the same ray (the live
// source asks OpenNI2 for depth-to-colour registration; the others are rendered or recorded so).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ajar/core/camera.hpp"

namespace ajar::console {

struct Frame {
  core::PinholeIntrinsics intrinsics;
  std::vector<std::uint8_t> rgb;  // width x height x 3, row-major, 8-bit sRGB
  std::vector<float> depth_m;     // width x height camera z in metres; 0 = hole (no measurement)
  std::uint64_t sequence = 0;     // increases by one per frame of a source
  double timestamp_s = 0;         // source time (recorded: the file's timestamp)
  core::DepthView depth() const { return {depth_m, intrinsics.width_px, intrinsics.height_px}; }
};

// The mobile base's pose in the world (the base frame when ajard started: +x forward, +y left),
// from the daemon's odometry. Only the simulated source uses it.
struct BasePose {
  double x_m = 0;
  double y_m = 0;
  double yaw_rad = 0;  // CCW positive
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // "simulated: config/scenarios/console-door.yaml", "recorded: DIR", "live: OpenNI2 <uri>".
  virtual std::string describe() const = 0;
  // Nominal frame rate (the console paces next() at this rate).
  virtual double rate_hz() const = 0;
  // Produces the next frame into `out`. False with `why` set when no frame can be had (sensor
  // unplugged, file unreadable); the console shows `why` and keeps trying.
  virtual bool next(const BasePose& pose, Frame& out, std::string& why) = 0;
};

}  // namespace ajar::console
