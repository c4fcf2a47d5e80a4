#include "ajar/core/types.hpp"

namespace ajar::core {

const char* to_string(Frame frame) noexcept {
  switch (frame) {
    case Frame::kCamera:
      return "camera";
    case Frame::kBase:
      return "base";
  }
  return "unknown";
}

const char* to_string(RotationDirection dir) noexcept {
  switch (dir) {
    case RotationDirection::kClockwise:
      return "CW";
    case RotationDirection::kCounterClockwise:
      return "CCW";
  }
  return "unknown";
}

}  // namespace ajar::core
