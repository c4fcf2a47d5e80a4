#include "ajar/core/types.hpp"

namespace ajar::core {

static_assert(values_are_indices(kFrameWords) && values_are_indices(kRotationDirectionWords));

const char* to_string(Frame frame) noexcept {
  return word_of(kFrameWords, frame).data();
}

const char* to_string(RotationDirection dir) noexcept {
  return word_of(kRotationDirectionWords, dir).data();
}

}  // namespace ajar::core
