// The measurement Acks from core's measurements: one builder for the daemon (what it stores and
// replies) and for the golden vectors (from the sample robot).
#pragma once

#include "ajar/core/measurements.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::protocol {

// MeasureDoorWidth / MeasureHandle: the span's length and direction and both points in the base
// frame.
SpanAck span_ack_from(const core::SpanMeasurement& m) noexcept;
// MeasureDoorPlane: the plane's normal and RMS residual, the yaw and its wheel command, the point
// count (1..255 on the wire; core limits it to kMinPlanePoints..kMaxPlanePoints).
PlaneAck plane_ack_from(const core::PlaneMeasurement& m) noexcept;

}  // namespace ajar::protocol
