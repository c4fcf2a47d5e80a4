// Procedure: the paper's door procedure (Fig. 4) as a pure state machine — no threads, no I/O.
// The engine calls it from the I/O thread and carries out the motion it allows. docs/procedure.md
// has the full table; in short:
//
//   width -> handle -> plane -> align -> contact point -> engage
//
// The state is derived from what is stored (ProcedureRecord), never kept separately:
//   fault latched -> kFault; aligning -> kAligning; engaging -> kEngaging; engaged -> kEngaged;
//   else the first missing step: no width -> kAwaitingWidth, no handle -> kAwaitingHandle,
//   no plane -> kAwaitingPlane, base not aligned -> kReadyToAlign, no contact -> kAligned,
//   else kReadyToEngage.
//
// Refusal precedence for every command (the first that applies): kFaultLatched (Reset first),
// kMotionInProgress (aligning or engaging), the first missing earlier step (kMissingDoorWidth,
// kMissingHandle, kMissingPlane, kNotAligned, kMissingContactPoint), then core's validation.
// A refusal changes nothing.
//
// Re-measuring overwrites:
//   - width / handle: replaced; every later step is kept (plane, alignment and contact point do not
//     depend on them). After kEngaged the phase returns to idle (kReadyToEngage).
//   - plane, base not aligned: replaced.
//   - plane, base aligned: |yaw| <= aligned_tolerance_rad keeps the alignment and the contact
//     point; otherwise the base is no longer aligned (kReadyToAlign) and the contact point, taken
//     in the base frame before a turn that is now needed, is discarded.
//   - contact point: replaced (base must be aligned).
// An alignment that did not finish (Stop, fault, emergency stop, restart) leaves kReadyToAlign
// with the plane shown but consumed: the base turned by an unknown part of the correction, so
// AlignBase is refused with kMissingPlane until the plane is measured again.
// AlignBase on an aligned base: kWrongState (re-measure the plane to align again).
//
// Driving (docs/procedure.md "Driving and stale measurements"): the engine reports the odometry
// pose (observe_pose) before every command and report. Width, handle length and directions are
// scalars: never stale. The plane and the contact point are base-frame measurements: once the base
// origin has moved more than stale_travel_m (straight line) or turned more than stale_yaw_rad since
// they were taken (AlignBase's own turn does not count), they are stale, for good (moving back does
// not revive them): AlignBase, SetContactPoint and Engage refuse with kMeasurementStale (field
// "plane" / "contact") and say how far the base moved. A stale plane also ends the alignment (the
// base is no longer known to be square: kReadyToAlign, plane consumed). Below the thresholds,
// AlignBase turns by the plane's yaw seen from where the base is now. Restored measurements count
// as taken where the base is at start (odometry restarts with the daemon).
#pragma once

#include <cstdint>
#include <optional>

#include "ajar/core/driving.hpp"
#include "ajar/core/geometry.hpp"
#include "ajar/drivers/manipulator.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::daemon {

enum class Phase : std::uint8_t { kIdle = 0, kAligning = 1, kEngaging = 2, kEngaged = 3 };

// Everything that is persisted: the accepted requests (their derived values are recomputed with
// core on restore, so a state file never bypasses validation) and the procedure's flags.
struct ProcedureRecord {
  std::optional<protocol::MeasureDoorWidth> width;
  std::optional<protocol::MeasureHandle> handle;
  std::optional<protocol::MeasureDoorPlane> plane;
  std::optional<protocol::SetContactPoint> contact;
  bool aligned = false;
  bool plane_consumed = false;  // an alignment with this plane was interrupted
  Phase phase = Phase::kIdle;
  ErrorCode fault = ErrorCode::kOk;
};

struct ProcedureLimits {
  double aligned_tolerance_rad = 0.005;
  double stale_travel_m = 0.05;  // see "Driving" above
  double stale_yaw_rad = 0.05;
};

class Procedure {
 public:
  Procedure(const core::CameraToBase& camera_to_base, const core::Limits& limits,
            const core::BaseGeometry& base, ProcedureLimits procedure_limits);

  protocol::ProcedureState state() const noexcept;
  const ProcedureRecord& record() const noexcept { return record_; }
  ErrorCode fault() const noexcept { return record_.fault; }
  Phase phase() const noexcept { return record_.phase; }

  // Measurements: validated with core; on success stored and acknowledged with derived values.
  Result<protocol::SpanAck> measure_width(const protocol::MeasureDoorWidth& m);
  Result<protocol::SpanAck> measure_handle(const protocol::MeasureHandle& m);
  Result<protocol::PlaneAck> measure_plane(const protocol::MeasureDoorPlane& m);
  Result<protocol::ContactAck> set_contact(const protocol::SetContactPoint& m);

  // AlignBase: the wheel command to run (checks only; nothing changes).
  Result<core::WheelCommand> check_align() const;
  void alignment_started();      // -> kAligning
  void alignment_finished();     // -> aligned (kAligned / kReadyToEngage)
  void alignment_interrupted();  // -> kReadyToAlign, plane consumed
  void alignment_not_started();  // the move was refused before the wheels turned: as before

  // Engage: the task for the arm (checks only).
  Result<drivers::DoorTask> check_engage() const;
  void engaging_started();      // -> kEngaging
  void engaging_finished();     // -> kEngaged
  void engaging_interrupted();  // -> kReadyToEngage

  // A fault latches (the first one stays: it is the root cause); motion phases end.
  void latch_fault(ErrorCode code);
  void clear_fault();
  void clear_parameters();  // everything measured is discarded: kAwaitingWidth

  // Derived values of what is stored (for Status).
  const std::optional<protocol::SpanAck>& width() const noexcept { return width_; }
  const std::optional<protocol::SpanAck>& handle() const noexcept { return handle_; }
  const std::optional<protocol::PlaneAck>& plane() const noexcept { return plane_; }
  const std::optional<protocol::ContactAck>& contact() const noexcept { return contact_; }

  // The odometry pose now. Returns true when it made a measurement stale (the record changed:
  // persist it).
  bool observe_pose(const core::PlanarPose& now);
  // Where the door is seen from the base at pose `now`: from the plane, else from the width points.
  protocol::DoorRelation door(const core::PlanarPose& now) const noexcept;
  // The same door as a line in the odometry frame (the forward jog's guard in the control loop);
  // nullopt when no distance is known.
  std::optional<core::DoorLine> door_line() const noexcept;
  // The stale flags as of the last observe_pose; the travel since the plane as of `now`.
  protocol::Staleness staleness(const core::PlanarPose& now) const noexcept;
  // kMeasurementStale (field "plane", saying how far the base moved) when the plane is stale.
  Outcome plane_fresh() const { return check_fresh(true, false); }

  // Replays a persisted record through core's validation. Aligning at the time of the record ->
  // kReadyToAlign with the plane consumed; engaging -> kReadyToEngage; engaged and faults are kept.
  // On an error nothing is restored (the procedure stays clean) and the error says what failed.
  Outcome restore(const ProcedureRecord& record);

 private:
  Outcome check_measure_allowed() const;
  Outcome check_fresh(bool plane, bool contact) const;
  Outcome check_prerequisites(bool need_width, bool need_handle, bool need_plane,
                              bool need_aligned) const;

  core::CameraToBase camera_to_base_;
  core::Limits limits_;
  core::BaseGeometry base_;
  ProcedureLimits procedure_limits_;
  ProcedureRecord record_;
  std::optional<protocol::SpanAck> width_, handle_;
  std::optional<protocol::PlaneAck> plane_;
  std::optional<core::WheelCommand> wheels_;
  std::optional<protocol::ContactAck> contact_;
  // Driving: where each base-frame measurement was taken, and whether it is stale.
  core::PlanarPose pose_;        // now
  core::PlanarPose width_pose_;  // where the width points were taken
  std::optional<core::Plane> plane_fit_;
  core::PlanarPose plane_pose_;  // where the plane was measured (its geometry)
  core::PlanarPose plane_ref_;   // staleness reference: plane_pose_, then the end of AlignBase
  core::PlanarPose contact_pose_;
  bool plane_stale_ = false, contact_stale_ = false;
};

}  // namespace ajar::daemon
