// The procedure state machine on its own (pure: no threads, no drivers).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "ajar/daemon/procedure.hpp"
#include "fake_door.hpp"

namespace ajar::daemon {
namespace {

using protocol::ProcedureState;
using namespace ajar::testing;

class ProcedureTest : public ::testing::Test {
 protected:
  Procedure make() {
    auto t = core::CameraToBase::from_matrix(forward_camera_to_base_m());
    EXPECT_TRUE(t.ok());
    return Procedure(*t, core::Limits{}, core::BaseGeometry{}, ProcedureLimits{0.005});
  }
  // Walks a procedure to kAligned (alignment finished).
  void to_aligned(Procedure& p, double yaw = 0.1) {
    ASSERT_TRUE(p.measure_width(good_width()).ok());
    ASSERT_TRUE(p.measure_handle(good_handle()).ok());
    ASSERT_TRUE(p.measure_plane(plane_at_yaw(yaw)).ok());
    ASSERT_TRUE(p.check_align().ok());
    p.alignment_started();
    p.alignment_finished();
    ASSERT_EQ(p.state(), ProcedureState::kAligned);
  }
};

template <typename T>
void expect_error(const Result<T>& r, ErrorCode code, const std::string& field = "") {
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, code) << to_string(r.error().code) << ": " << r.error().message;
  if (!field.empty()) {
    EXPECT_EQ(r.error().field, field);
  }
}

TEST_F(ProcedureTest, WalksThePaperProcedureInOrder) {
  Procedure p = make();
  EXPECT_EQ(p.state(), ProcedureState::kAwaitingWidth);
  auto width = p.measure_width(good_width());
  ASSERT_TRUE(width.ok());
  EXPECT_NEAR(width->length_m, 0.85, 1e-9);
  EXPECT_EQ(width->direction, core::RotationDirection::kCounterClockwise);
  EXPECT_EQ(p.state(), ProcedureState::kAwaitingHandle);
  auto handle = p.measure_handle(good_handle());
  ASSERT_TRUE(handle.ok());
  EXPECT_NEAR(handle->length_m, 0.12, 1e-9);
  EXPECT_EQ(p.state(), ProcedureState::kAwaitingPlane);
  auto plane = p.measure_plane(plane_at_yaw(0.1));
  ASSERT_TRUE(plane.ok());
  EXPECT_NEAR(std::abs(plane->yaw_deviation_rad), 0.1, 1e-6);
  EXPECT_NE(plane->left_counts, 0);
  EXPECT_EQ(plane->point_count, 3);
  EXPECT_EQ(p.state(), ProcedureState::kReadyToAlign);
  auto wheels = p.check_align();
  ASSERT_TRUE(wheels.ok());
  EXPECT_EQ(wheels->left_counts, plane->left_counts);
  EXPECT_EQ(wheels->right_counts, plane->right_counts);
  p.alignment_started();
  EXPECT_EQ(p.state(), ProcedureState::kAligning);
  p.alignment_finished();
  EXPECT_EQ(p.state(), ProcedureState::kAligned);
  auto contact = p.set_contact(good_contact());
  ASSERT_TRUE(contact.ok());
  EXPECT_GT(contact->reach_margin_m, 0);
  EXPECT_EQ(p.state(), ProcedureState::kReadyToEngage);
  auto task = p.check_engage();
  ASSERT_TRUE(task.ok());
  EXPECT_NEAR(task->door_width_m, 0.85, 1e-9);
  EXPECT_NEAR(task->handle_length_m, 0.12, 1e-9);
  EXPECT_EQ(task->door_direction, core::RotationDirection::kCounterClockwise);
  EXPECT_TRUE(task->contact_base_m.isApprox(contact->contact_base_m));
  p.engaging_started();
  EXPECT_EQ(p.state(), ProcedureState::kEngaging);
  p.engaging_finished();
  EXPECT_EQ(p.state(), ProcedureState::kEngaged);
}

TEST_F(ProcedureTest, OutOfOrderStepsNameWhatIsMissing) {
  Procedure p = make();
  expect_error(p.measure_handle(good_handle()), ErrorCode::kMissingDoorWidth);
  expect_error(p.measure_plane(plane_at_yaw(0.1)), ErrorCode::kMissingDoorWidth);
  expect_error(p.check_align(), ErrorCode::kMissingDoorWidth);
  expect_error(p.set_contact(good_contact()), ErrorCode::kMissingDoorWidth);
  expect_error(p.check_engage(), ErrorCode::kMissingDoorWidth);
  ASSERT_TRUE(p.measure_width(good_width()).ok());
  expect_error(p.measure_plane(plane_at_yaw(0.1)), ErrorCode::kMissingHandle);
  expect_error(p.check_align(), ErrorCode::kMissingHandle);
  ASSERT_TRUE(p.measure_handle(good_handle()).ok());
  expect_error(p.check_align(), ErrorCode::kMissingPlane);
  expect_error(p.set_contact(good_contact()), ErrorCode::kMissingPlane);
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.1)).ok());
  auto r = p.set_contact(good_contact());
  expect_error(r, ErrorCode::kNotAligned);
  EXPECT_EQ(r.error().message, "align the base first");
  expect_error(p.check_engage(), ErrorCode::kNotAligned);
  p.alignment_started();
  p.alignment_finished();
  auto e = p.check_engage();
  expect_error(e, ErrorCode::kMissingContactPoint);
  EXPECT_EQ(p.state(), ProcedureState::kAligned);
}

TEST_F(ProcedureTest, RefusalsCarryCodeAndFieldAndChangeNothing) {
  Procedure p = make();
  expect_error(p.measure_width(too_wide()), ErrorCode::kWidthOutOfRange, "width_m");
  EXPECT_EQ(p.state(), ProcedureState::kAwaitingWidth);
  EXPECT_FALSE(p.record().width.has_value());

  ASSERT_TRUE(p.measure_width(good_width()).ok());
  auto nan_width = good_width();
  nan_width.p2_moving_edge.position_m.y() = std::numeric_limits<double>::quiet_NaN();
  auto r = p.measure_width(nan_width);
  expect_error(r, ErrorCode::kNonFinite);
  EXPECT_EQ(r.error().field.rfind("p2", 0), 0U) << r.error().field;
  EXPECT_NEAR(p.width()->length_m, 0.85, 1e-9);  // the accepted width survives the refusal

  ASSERT_TRUE(p.measure_handle(good_handle()).ok());
  expect_error(p.measure_plane(collinear_plane()), ErrorCode::kPointsCollinear);
  EXPECT_EQ(p.state(), ProcedureState::kAwaitingPlane);

  to_aligned(p);
  expect_error(p.set_contact(unreachable_contact()), ErrorCode::kOutOfReach, "contact");
  EXPECT_EQ(p.state(), ProcedureState::kAligned);
}

TEST_F(ProcedureTest, RemeasuringWidthAndHandleKeepsLaterSteps) {
  Procedure p = make();
  to_aligned(p);
  ASSERT_TRUE(p.set_contact(good_contact()).ok());
  auto wider = good_width();
  wider.p2_moving_edge.position_m.y() = -0.55;
  auto w = p.measure_width(wider);
  ASSERT_TRUE(w.ok());
  EXPECT_NEAR(w->length_m, 0.95, 1e-9);
  ASSERT_TRUE(p.measure_handle(good_handle()).ok());
  EXPECT_EQ(p.state(), ProcedureState::kReadyToEngage);
  EXPECT_NEAR(p.check_engage()->door_width_m, 0.95, 1e-9);
}

TEST_F(ProcedureTest, RemeasuredPlaneWithinToleranceKeepsAlignment) {
  Procedure p = make();
  to_aligned(p);
  ASSERT_TRUE(p.set_contact(good_contact()).ok());
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.002)).ok());
  EXPECT_EQ(p.state(), ProcedureState::kReadyToEngage);
  EXPECT_TRUE(p.contact().has_value());
}

TEST_F(ProcedureTest, RemeasuredPlaneBeyondToleranceNeedsAlignmentAndDropsContact) {
  Procedure p = make();
  to_aligned(p);
  ASSERT_TRUE(p.set_contact(good_contact()).ok());
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.05)).ok());
  EXPECT_EQ(p.state(), ProcedureState::kReadyToAlign);
  EXPECT_FALSE(p.contact().has_value());
  EXPECT_TRUE(p.check_align().ok());
}

TEST_F(ProcedureTest, AligningAnAlignedBaseIsRefused) {
  Procedure p = make();
  to_aligned(p);
  expect_error(p.check_align(), ErrorCode::kWrongState);
}

TEST_F(ProcedureTest, InterruptedAlignmentNeedsAFreshPlane) {
  Procedure p = make();
  ASSERT_TRUE(p.measure_width(good_width()).ok());
  ASSERT_TRUE(p.measure_handle(good_handle()).ok());
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.1)).ok());
  p.alignment_started();
  p.alignment_interrupted();
  EXPECT_EQ(p.state(), ProcedureState::kReadyToAlign);
  EXPECT_TRUE(p.plane().has_value());
  expect_error(p.check_align(), ErrorCode::kMissingPlane);
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.04)).ok());
  EXPECT_TRUE(p.check_align().ok());
}

TEST_F(ProcedureTest, RefusedMoveLeavesThePlaneUsable) {
  Procedure p = make();
  ASSERT_TRUE(p.measure_width(good_width()).ok());
  ASSERT_TRUE(p.measure_handle(good_handle()).ok());
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.1)).ok());
  p.alignment_started();
  p.alignment_not_started();
  EXPECT_EQ(p.state(), ProcedureState::kReadyToAlign);
  EXPECT_TRUE(p.check_align().ok());
}

TEST_F(ProcedureTest, NothingButStopsWhileMoving) {
  Procedure p = make();
  ASSERT_TRUE(p.measure_width(good_width()).ok());
  ASSERT_TRUE(p.measure_handle(good_handle()).ok());
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.1)).ok());
  p.alignment_started();
  expect_error(p.check_align(), ErrorCode::kMotionInProgress);
  expect_error(p.check_engage(), ErrorCode::kMotionInProgress);
  expect_error(p.measure_width(good_width()), ErrorCode::kMotionInProgress);
  expect_error(p.measure_plane(plane_at_yaw(0.1)), ErrorCode::kMotionInProgress);
}

TEST_F(ProcedureTest, LatchedFaultRefusesUntilClearedAndKeepsParameters) {
  Procedure p = make();
  to_aligned(p);
  p.latch_fault(ErrorCode::kAxisAlarm);
  p.latch_fault(ErrorCode::kDeadman);  // the first fault stays
  EXPECT_EQ(p.state(), ProcedureState::kFault);
  EXPECT_EQ(p.fault(), ErrorCode::kAxisAlarm);
  expect_error(p.measure_width(good_width()), ErrorCode::kFaultLatched);
  expect_error(p.set_contact(good_contact()), ErrorCode::kFaultLatched);
  expect_error(p.check_engage(), ErrorCode::kFaultLatched);
  p.clear_fault();
  EXPECT_EQ(p.state(), ProcedureState::kAligned);
  p.clear_parameters();
  EXPECT_EQ(p.state(), ProcedureState::kAwaitingWidth);
  EXPECT_FALSE(p.width().has_value());
}

TEST_F(ProcedureTest, FaultDuringAlignmentInterruptsIt) {
  Procedure p = make();
  ASSERT_TRUE(p.measure_width(good_width()).ok());
  ASSERT_TRUE(p.measure_handle(good_handle()).ok());
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.1)).ok());
  p.alignment_started();
  p.latch_fault(ErrorCode::kAxisAlarm);
  p.clear_fault();
  EXPECT_EQ(p.state(), ProcedureState::kReadyToAlign);
  expect_error(p.check_align(), ErrorCode::kMissingPlane);
}

TEST_F(ProcedureTest, RestoreReplaysTheRecord) {
  Procedure p = make();
  to_aligned(p);
  ASSERT_TRUE(p.set_contact(good_contact()).ok());
  Procedure q = make();
  ASSERT_TRUE(q.restore(p.record()).ok());
  EXPECT_EQ(q.state(), ProcedureState::kReadyToEngage);
  EXPECT_EQ(q.width()->length_m, p.width()->length_m);
  EXPECT_EQ(q.plane()->left_counts, p.plane()->left_counts);
  EXPECT_TRUE(q.contact()->contact_base_m == p.contact()->contact_base_m);
}

TEST_F(ProcedureTest, RestoreOfMotionPhasesNeverResumesMotion) {
  Procedure p = make();
  ASSERT_TRUE(p.measure_width(good_width()).ok());
  ASSERT_TRUE(p.measure_handle(good_handle()).ok());
  ASSERT_TRUE(p.measure_plane(plane_at_yaw(0.1)).ok());
  p.alignment_started();
  Procedure q = make();
  ASSERT_TRUE(q.restore(p.record()).ok());
  EXPECT_EQ(q.state(), ProcedureState::kReadyToAlign);
  expect_error(q.check_align(), ErrorCode::kMissingPlane);

  Procedure e = make();
  to_aligned(e);
  ASSERT_TRUE(e.set_contact(good_contact()).ok());
  e.engaging_started();
  Procedure r = make();
  ASSERT_TRUE(r.restore(e.record()).ok());
  EXPECT_EQ(r.state(), ProcedureState::kReadyToEngage);
}

TEST_F(ProcedureTest, RestoreRefusesARecordThatNoLongerValidates) {
  ProcedureRecord record;
  record.width = too_wide();
  Procedure p = make();
  auto s = p.restore(record);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kWidthOutOfRange);
  EXPECT_EQ(p.state(), ProcedureState::kAwaitingWidth);
}

}  // namespace
}  // namespace ajar::daemon
