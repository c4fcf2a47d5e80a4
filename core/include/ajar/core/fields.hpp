// The fields the measurements' errors name (core's validation, geometry.hpp / measurements.hpp).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace ajar::core {

// The fields the measurements' errors name, in the request's terms (ajar::Error::field): typed
// once here; the validation (geometry.cpp, measurements.cpp) and the message table's refusal column
// (protocol/message_table.hpp, docs/protocol.md 4.3) read them. A point's coordinate is the point's
// name + ".x" / ".y" / ".z" (check_finite); one plane point is kPoints + "[i]" (point_field).
namespace fields {
inline constexpr std::string_view kP1 = "p1";
inline constexpr std::string_view kP2 = "p2";
inline constexpr std::string_view kPoints = "points";  // the plane's points as a whole
inline constexpr std::string_view kContact = "contact";
inline constexpr std::string_view kWidth = "width_m";
inline constexpr std::string_view kHandleLength = "handle_length_m";
inline constexpr std::string_view kRmsResidual = "rms_residual_m";
inline constexpr std::string_view kYawDeviation = "yaw_deviation_rad";
}  // namespace fields
// "points[i]": plane point i.
std::string point_field(std::size_t i);

}  // namespace ajar::core
