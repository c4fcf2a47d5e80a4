#include "ajar/daemon/procedure.hpp"

#include <cmath>
#include <span>
#include <string>

#include <fmt/format.h>

#include "ajar/core/measurements.hpp"
#include "ajar/protocol/acks.hpp"
#include "ajar/protocol/message_table.hpp"

namespace ajar::daemon {
namespace {

using protocol::ProcedureState;

Error missing(ErrorCode code, const char* message) {
  return make_error(code, "", message);
}

}  // namespace

Procedure::Procedure(const core::CameraToBase& camera_to_base, const core::Limits& limits,
                     const core::BaseGeometry& base, ProcedureLimits procedure_limits)
    : camera_to_base_(camera_to_base),
      limits_(limits),
      base_(base),
      procedure_limits_(procedure_limits) {}

ProcedureState Procedure::state() const noexcept {
  if (record_.fault != ErrorCode::kOk) return ProcedureState::kFault;
  switch (record_.phase) {
    case Phase::kAligning:
      return ProcedureState::kAligning;
    case Phase::kEngaging:
      return ProcedureState::kEngaging;
    case Phase::kEngaged:
      return ProcedureState::kEngaged;
    case Phase::kIdle:
      break;
  }
  if (!width_) return ProcedureState::kAwaitingWidth;
  if (!handle_) return ProcedureState::kAwaitingHandle;
  if (!plane_) return ProcedureState::kAwaitingPlane;
  if (!record_.aligned) return ProcedureState::kReadyToAlign;
  if (!contact_) return ProcedureState::kAligned;
  return ProcedureState::kReadyToEngage;
}

Outcome Procedure::check_measure_allowed() const {
  if (record_.fault != ErrorCode::kOk) {
    return make_error(
        ErrorCode::kFaultLatched, "",
        "a fault is latched (" + std::string(to_string(record_.fault)) + "): Reset first");
  }
  if (record_.phase == Phase::kAligning || record_.phase == Phase::kEngaging) {
    return make_error(ErrorCode::kMotionInProgress, "",
                      "the robot is moving: wait for the motion to finish or Stop it");
  }
  return Ok{};
}

Outcome Procedure::check_prerequisites(bool need_width, bool need_handle, bool need_plane,
                                       bool need_aligned) const {
  if (need_width && !width_)
    return missing(ErrorCode::kMissingDoorWidth, "measure the door width first");
  if (need_handle && !handle_)
    return missing(ErrorCode::kMissingHandle, "measure the handle first");
  if (need_plane && !plane_)
    return missing(ErrorCode::kMissingPlane, "measure the door plane first");
  if (need_aligned && !record_.aligned)
    return missing(ErrorCode::kNotAligned, "align the base first");
  return Ok{};
}

Outcome Procedure::check_fresh(bool plane, bool contact) const {
  const auto moved = [&](const core::PlanarPose& since) {
    return fmt::format("the base moved {:.3f} m and turned {:.3f} rad since it was ",
                       core::travel_m(since, pose_), std::abs(core::turn_rad(since, pose_)));
  };
  if (plane && plane_stale_) {
    return make_error(ErrorCode::kMeasurementStale, std::string(protocol::refusal_field::kPlane),
                      "re-measure the door plane: " + moved(plane_ref_) + "measured");
  }
  if (contact && contact_stale_) {
    return make_error(ErrorCode::kMeasurementStale, std::string(protocol::refusal_field::kContact),
                      "set the contact point again: " + moved(contact_pose_) + "set");
  }
  return Ok{};
}

bool Procedure::observe_pose(const core::PlanarPose& now) {
  pose_ = now;
  if (record_.phase == Phase::kAligning) return false;  // AlignBase's own turn
  const auto beyond = [&](const core::PlanarPose& since) {
    return core::travel_m(since, pose_) > procedure_limits_.stale_travel_m ||
           std::abs(core::turn_rad(since, pose_)) > procedure_limits_.stale_yaw_rad;
  };
  bool changed = false;
  if (contact_ && !contact_stale_ && beyond(contact_pose_)) contact_stale_ = true;
  if (plane_ && !plane_stale_ && beyond(plane_ref_)) {
    plane_stale_ = true;
    changed = record_.aligned || !record_.plane_consumed;
    record_.aligned = false;
    record_.plane_consumed = true;
  }
  return changed;
}

protocol::DoorRelation Procedure::door(const core::PlanarPose& now) const noexcept {
  protocol::DoorRelation d;
  std::optional<core::DoorView> view;
  if (plane_fit_) {
    view = core::door_from_plane(*plane_fit_, plane_pose_, now);
    view->yaw_rad = plane_->yaw_deviation_rad - (now.yaw_rad - plane_pose_.yaw_rad);  // as measured
  } else if (width_) {
    view = core::door_from_width(width_->p1_base_m, width_->p2_base_m, width_pose_, now);
  }
  if (view) {
    d.has_distance = d.has_yaw = true;
    d.distance_m = view->distance_m;
    d.yaw_rad = view->yaw_rad;
  }
  return d;
}

std::optional<core::DoorLine> Procedure::door_line() const noexcept {
  if (plane_fit_) return core::door_line_from_plane(*plane_fit_, plane_pose_);
  if (width_) return core::door_line_from_width(width_->p1_base_m, width_->p2_base_m, width_pose_);
  return std::nullopt;
}

protocol::Staleness Procedure::staleness(const core::PlanarPose& now) const noexcept {
  protocol::Staleness st;
  st.plane = plane_stale_;
  st.contact = contact_stale_;
  if (plane_) st.travel_since_plane_m = core::travel_m(plane_ref_, now);
  return st;
}

Result<protocol::SpanAck> Procedure::measure_width(const protocol::MeasureDoorWidth& m) {
  if (auto s = check_measure_allowed(); !s) return std::move(s).error();
  auto r = core::measure_door_width(m.p1_hinge, m.p2_moving_edge, camera_to_base_, limits_);
  if (!r) return std::move(r).error();
  width_ = protocol::span_ack_from(*r);
  width_pose_ = pose_;
  record_.width = m;
  if (record_.phase == Phase::kEngaged) record_.phase = Phase::kIdle;
  return *width_;
}

Result<protocol::SpanAck> Procedure::measure_handle(const protocol::MeasureHandle& m) {
  if (auto s = check_measure_allowed(); !s) return std::move(s).error();
  if (auto s = check_prerequisites(true, false, false, false); !s) return std::move(s).error();
  auto r = core::measure_handle(m.p1_axis, m.p2_free_end, camera_to_base_, limits_);
  if (!r) return std::move(r).error();
  handle_ = protocol::span_ack_from(*r);
  record_.handle = m;
  if (record_.phase == Phase::kEngaged) record_.phase = Phase::kIdle;
  return *handle_;
}

Result<protocol::PlaneAck> Procedure::measure_plane(const protocol::MeasureDoorPlane& m) {
  if (auto s = check_measure_allowed(); !s) return std::move(s).error();
  if (auto s = check_prerequisites(true, true, false, false); !s) return std::move(s).error();
  if (m.count < protocol::kMinPlanePoints || m.count > protocol::kMaxPlanePoints) {
    return make_error(ErrorCode::kBadCount, "count",
                      "a door plane needs 3 to 16 points, got " + std::to_string(m.count));
  }
  auto r = core::measure_door_plane(std::span<const core::FramedPoint>(m.points.data(), m.count),
                                    camera_to_base_, limits_, base_);
  if (!r) return std::move(r).error();
  const bool keeps_alignment =
      record_.aligned && std::abs(r->yaw_deviation_rad) <= procedure_limits_.aligned_tolerance_rad;
  plane_ = protocol::plane_ack_from(*r);
  wheels_ = r->wheels;
  plane_fit_ = r->plane;
  plane_pose_ = plane_ref_ = pose_;
  plane_stale_ = false;
  record_.plane = m;
  record_.plane_consumed = false;
  if (!keeps_alignment) {
    record_.aligned = false;
    contact_.reset();
    record_.contact.reset();
    contact_stale_ = false;
  }
  if (record_.phase == Phase::kEngaged) record_.phase = Phase::kIdle;
  return *plane_;
}

Result<protocol::ContactAck> Procedure::set_contact(const protocol::SetContactPoint& m) {
  if (auto s = check_measure_allowed(); !s) return std::move(s).error();
  if (auto s = check_fresh(true, false); !s) return std::move(s).error();
  if (auto s = check_prerequisites(true, true, true, true); !s) return std::move(s).error();
  auto r = core::measure_contact_point(m.contact, camera_to_base_, limits_);
  if (!r) return std::move(r).error();
  protocol::ContactAck ack;
  ack.contact_base_m = r->contact_base_m;
  ack.reach_margin_m = r->reach_margin_m;
  contact_ = ack;
  contact_pose_ = pose_;
  contact_stale_ = false;
  record_.contact = m;
  if (record_.phase == Phase::kEngaged) record_.phase = Phase::kIdle;
  return *contact_;
}

Result<core::WheelCommand> Procedure::check_align() const {
  if (auto s = check_measure_allowed(); !s) return std::move(s).error();
  if (auto s = check_fresh(true, false); !s) return std::move(s).error();
  if (auto s = check_prerequisites(true, true, true, false); !s) return std::move(s).error();
  if (record_.plane_consumed) {
    return make_error(ErrorCode::kMissingPlane, "",
                      "the last alignment was interrupted: measure the door plane again first");
  }
  if (record_.aligned) {
    return make_error(ErrorCode::kWrongState, "",
                      "the base is already aligned: measure the door plane again to re-align");
  }
  // The plane's yaw seen from where the base is now (the same as measured unless it moved).
  const double turned = pose_.yaw_rad - plane_pose_.yaw_rad;
  if (turned == 0) return *wheels_;
  const double yaw_now = plane_->yaw_deviation_rad - turned;
  if (auto s = core::check_yaw(yaw_now, limits_); !s) return std::move(s).error();
  return core::wheel_command(yaw_now, base_);
}

void Procedure::alignment_started() {
  record_.phase = Phase::kAligning;
  record_.plane_consumed = true;  // until it finishes, the plane no longer describes the base
}

void Procedure::alignment_finished() {
  if (record_.phase == Phase::kAligning) record_.phase = Phase::kIdle;
  record_.aligned = true;
  record_.plane_consumed = false;
  plane_ref_ = pose_;  // the turn AlignBase made does not make the plane stale
}

void Procedure::alignment_interrupted() {
  if (record_.phase == Phase::kAligning) record_.phase = Phase::kIdle;
  record_.aligned = false;
  record_.plane_consumed = true;
}

void Procedure::alignment_not_started() {
  if (record_.phase == Phase::kAligning) record_.phase = Phase::kIdle;
  record_.plane_consumed = false;
}

Result<drivers::DoorTask> Procedure::check_engage() const {
  if (auto s = check_measure_allowed(); !s) return std::move(s).error();
  if (auto s = check_fresh(true, true); !s) return std::move(s).error();
  if (auto s = check_prerequisites(true, true, true, true); !s) return std::move(s).error();
  if (!contact_) return missing(ErrorCode::kMissingContactPoint, "set the contact point first");
  if (record_.phase == Phase::kEngaged) {
    return make_error(ErrorCode::kWrongState, "",
                      "already engaged: re-measure or Reset to run the task again");
  }
  drivers::DoorTask task;
  task.contact_base_m = contact_->contact_base_m;
  task.door_width_m = width_->length_m;
  task.handle_length_m = handle_->length_m;
  task.door_direction = width_->direction;
  task.handle_direction = handle_->direction;
  return task;
}

void Procedure::engaging_started() {
  record_.phase = Phase::kEngaging;
}

void Procedure::engaging_finished() {
  if (record_.phase == Phase::kEngaging) record_.phase = Phase::kEngaged;
}

void Procedure::engaging_interrupted() {
  if (record_.phase == Phase::kEngaging) record_.phase = Phase::kIdle;
}

void Procedure::latch_fault(ErrorCode code) {
  if (record_.phase == Phase::kAligning) alignment_interrupted();
  if (record_.phase == Phase::kEngaging) engaging_interrupted();
  if (record_.fault == ErrorCode::kOk) record_.fault = code;
}

void Procedure::clear_fault() {
  record_.fault = ErrorCode::kOk;
}

void Procedure::clear_parameters() {
  const ErrorCode fault = record_.fault;
  record_ = ProcedureRecord{};
  record_.fault = fault;
  width_.reset();
  handle_.reset();
  plane_.reset();
  wheels_.reset();
  contact_.reset();
  plane_fit_.reset();
  plane_stale_ = contact_stale_ = false;
}

Outcome Procedure::restore(const ProcedureRecord& record) {
  Procedure replay(camera_to_base_, limits_, base_, procedure_limits_);
  replay.pose_ = pose_;  // restored measurements count as taken where the base is now
  if (record.width) {
    if (auto r = replay.measure_width(*record.width); !r) return std::move(r).error();
  }
  if (record.handle) {
    if (auto r = replay.measure_handle(*record.handle); !r) return std::move(r).error();
  }
  if (record.plane) {
    if (auto r = replay.measure_plane(*record.plane); !r) return std::move(r).error();
  }
  if (record.aligned || record.phase == Phase::kEngaging || record.phase == Phase::kEngaged) {
    if (!record.plane) return missing(ErrorCode::kMissingPlane, "aligned without a plane");
    replay.record_.aligned = true;
  }
  if (record.contact) {
    if (auto r = replay.set_contact(*record.contact); !r) return std::move(r).error();
  }
  replay.record_.plane_consumed = record.plane_consumed;
  switch (record.phase) {
    case Phase::kAligning:  // turned by an unknown amount before the restart
      replay.record_.aligned = false;
      replay.record_.plane_consumed = true;
      break;
    case Phase::kEngaged:
      if (replay.contact_) replay.record_.phase = Phase::kEngaged;
      break;
    case Phase::kEngaging:  // the arm's outcome is unknown: engage again
    case Phase::kIdle:
      break;
  }
  replay.record_.fault = record.fault;
  *this = std::move(replay);
  return Ok{};
}

}  // namespace ajar::daemon
