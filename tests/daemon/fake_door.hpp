// A door in front of the robot for engine/procedure tests: a camera looking straight ahead from
// 1 m height, and valid (and invalid) picks, all given in the base frame (x forward, y left, z up).
#pragma once

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <Eigen/Core>

#include "ajar/daemon/config.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::testing {

// base = R * camera + t with camera z forward, x right, y down.
inline Eigen::Matrix4d forward_camera_to_base_m() {
  Eigen::Matrix4d m;
  m << 0, 0, 1, 0,    //
      -1, 0, 0, 0,    //
      0, -1, 0, 1.0,  //
      0, 0, 0, 1;
  return m;
}

inline core::FramedPoint base_point(double x, double y, double z) {
  return core::FramedPoint{core::Frame::kBase, core::Vec3(x, y, z)};
}

inline protocol::MeasureDoorWidth good_width() {
  return {base_point(1.5, 0.40, 1.0), base_point(1.5, -0.45, 1.0)};  // 0.85 m
}
inline protocol::MeasureDoorWidth too_wide() {
  return {base_point(1.5, 1.2, 1.0), base_point(1.5, -1.3, 1.0)};  // 2.5 m
}
inline protocol::MeasureHandle good_handle() {
  return {base_point(1.45, -0.30, 1.0), base_point(1.45, -0.42, 1.0)};  // 0.12 m
}
// Three points on a vertical door plane turned by `yaw_rad` about z, 1.5 m ahead.
inline protocol::MeasureDoorPlane plane_at_yaw(double yaw_rad) {
  protocol::MeasureDoorPlane p;
  p.count = 3;
  const double t = std::tan(yaw_rad);
  p.points[0] = base_point(1.5 + 0.3 * t, 0.3, 0.8);
  p.points[1] = base_point(1.5 - 0.3 * t, -0.3, 0.8);
  p.points[2] = base_point(1.5, 0.0, 1.4);
  return p;
}
inline protocol::MeasureDoorPlane collinear_plane() {
  protocol::MeasureDoorPlane p;
  p.count = 3;
  p.points[0] = base_point(1.5, 0.3, 1.0);
  p.points[1] = base_point(1.5, 0.0, 1.0);
  p.points[2] = base_point(1.5, -0.3, 1.0);
  return p;
}
inline protocol::SetContactPoint good_contact() {
  return {base_point(0.7, -0.2, 0.8)};
}
inline protocol::SetContactPoint unreachable_contact() {
  return {base_point(2.5, 0.0, 1.0)};
}

// A fresh directory under the system temp dir, removed by the destructor.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "ajar-engine-XXXXXX").string();
    path_ = ::mkdtemp(pattern.data()) != nullptr ? pattern : std::string();
  }
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

inline daemon::Config test_config(const std::string& state_directory) {
  daemon::Config c;
  c.camera_to_base_m = forward_camera_to_base_m();
  c.state.directory = state_directory + "/state";
  c.recorder.directory = state_directory + "/recordings";
  c.control.rate_hz = 500;
  c.safety.deadman_timeout_s = 30;  // tests that exercise the deadman shorten it
  c.drivers.kind = drivers::DriverKind::kMock;
  return c;
}

}  // namespace ajar::testing
