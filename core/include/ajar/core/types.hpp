// Basic robot-domain types shared by every layer. SI units everywhere (metres, radians, seconds).
//
// Frames (paper, Fig. 2 and eq. 1-2):
//   camera frame C: optical frame of the RGBD sensor, +z along the optical axis (depth), +x right,
//                   +y down in the image.
//   base frame B:   mobile base, +x forward, +y left, +z up; origin at the turning centre O.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "ajar/core/words.hpp"

namespace ajar::core {

using Vec3 = Eigen::Vector3d;

// Wire values are stable (protocol).
enum class Frame : std::uint8_t { kCamera = 0, kBase = 1 };

// A point as picked by the operator, with the frame it is expressed in.
struct FramedPoint {
  Frame frame = Frame::kCamera;
  Vec3 position_m = Vec3::Zero();
};

// Direction of rotation of a door or handle (paper, Algorithm 1 and Fig. 5b). Wire values stable.
enum class RotationDirection : std::uint8_t { kClockwise = 0, kCounterClockwise = 1 };

inline constexpr std::array<Word<Frame>, 2> kFrameWords{
    {{Frame::kCamera, "camera"}, {Frame::kBase, "base"}}};
inline constexpr std::array<Word<RotationDirection>, 2> kRotationDirectionWords{
    {{RotationDirection::kClockwise, "CW"}, {RotationDirection::kCounterClockwise, "CCW"}}};

const char* to_string(Frame frame) noexcept;            // "camera" | "base"
const char* to_string(RotationDirection dir) noexcept;  // "CW" | "CCW"

}  // namespace ajar::core
