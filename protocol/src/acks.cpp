#include "ajar/protocol/acks.hpp"

namespace ajar::protocol {

SpanAck span_ack_from(const core::SpanMeasurement& m) noexcept {
  return {m.span.length_m, m.span.direction, m.p1_base_m, m.p2_base_m};
}

PlaneAck plane_ack_from(const core::PlaneMeasurement& m) noexcept {
  PlaneAck ack;
  ack.normal = m.plane.normal;
  ack.yaw_deviation_rad = m.yaw_deviation_rad;
  ack.left_wheel_rad = m.wheels.left_wheel_rad;
  ack.right_wheel_rad = m.wheels.right_wheel_rad;
  ack.left_counts = m.wheels.left_counts;
  ack.right_counts = m.wheels.right_counts;
  ack.residual_yaw_rad = m.wheels.residual_yaw_rad;
  ack.rms_residual_m = m.plane.rms_residual_m;
  ack.point_count = static_cast<std::uint8_t>(m.point_count);
  return ack;
}

}  // namespace ajar::protocol
