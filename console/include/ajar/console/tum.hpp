// Recorded frames in the TUM RGB-D layout (https://cvg.cit.tum.de/data/datasets/rgbd-dataset,
// "file formats"), plus the intrinsics the TUM layout leaves implicit:
//
//   DIR/rgb.txt       "# comment" lines, then "TIMESTAMP rgb/TIMESTAMP.png" per colour image
//   DIR/depth.txt     the same for depth/TIMESTAMP.png
//   DIR/rgb/*.png     8-bit colour
//   DIR/depth/*.png   16-bit single channel, value = depth_m * depth_scale, 0 = no measurement
//   DIR/camera.yaml   fx_px, fy_px, cx_px, cy_px, width_px, height_px, depth_scale (TUM: 5000
//                     per metre), optional rate_hz (default 30)
//
// Depth must be registered to colour (same size, same intrinsics). Each colour image is paired with
// the depth image nearest in time, within max_time_difference_s (TUM's associate.py: 0.02 s).
#pragma once

#include <string>
#include <vector>

#include "ajar/console/frame.hpp"

namespace ajar::console {

struct TumCamera {
  core::PinholeIntrinsics intrinsics;
  double depth_scale = 5000.0;  // 16-bit value per metre
  double rate_hz = 30.0;
};

struct TumEntry {
  double timestamp_s = 0;
  std::string rgb_path;    // relative to the folder
  std::string depth_path;  // relative to the folder
};

struct TumSequence {
  std::string folder;
  TumCamera camera;
  std::vector<TumEntry> frames;  // in time order
};

// Reads camera.yaml, rgb.txt and depth.txt and pairs them. False with `error` naming the file (and
// line) and the problem; a sequence without a single pair is an error.
bool load_tum_sequence(const std::string& folder, TumSequence& out, std::string& error,
                       double max_time_difference_s = 0.02);

// Loads one pair into a frame (depth converted to metres; 0 stays a hole). Checks both images
// have the intrinsics' size.
bool load_tum_frame(const TumSequence& sequence, std::size_t index, Frame& out, std::string& error);

// Writes a frame into a TUM folder (creating it and its subfolders), appending to rgb.txt and
// depth.txt, and (re)writing camera.yaml. Depth above 65535 / depth_scale becomes a hole.
bool write_tum_frame(const std::string& folder, const Frame& frame, const TumCamera& camera,
                     std::string& error);

// Plays a TUM folder in a loop at its rate.
class RecordedSource final : public FrameSource {
 public:
  explicit RecordedSource(TumSequence sequence) : sequence_(std::move(sequence)) {}
  std::string describe() const override { return "recorded: " + sequence_.folder; }
  double rate_hz() const override { return sequence_.camera.rate_hz; }
  bool next(const BasePose& pose, Frame& out, std::string& why) override;

 private:
  TumSequence sequence_;
  std::size_t index_ = 0;
  std::uint64_t sequence_number_ = 0;
};

}  // namespace ajar::console
