// PickBoard (ajar/console/pick_board.hpp): the picks' rules per step and what sending a step makes
// of them, without a socket, a thread or a daemon.
#include <gtest/gtest.h>

#include <variant>

#include "ajar/console/pick_board.hpp"

namespace ajar::console {
namespace {

core::CameraToBase identity() {
  return *core::CameraToBase::from_matrix(Eigen::Matrix4d::Identity());
}

Pick at(double x, double y, double z, core::PlanarPose pose = {}) {
  Pick p;
  p.camera_m = core::Vec3(x, y, z);
  p.pose = pose;
  return p;
}

struct BoardTest : ::testing::Test {
  core::CameraToBase calibration = identity();
  BoardView view() const {
    BoardView v;
    v.now = core::PlanarPose{};
    v.camera_to_base = &calibration;
    v.rule = StaleRule{0.05, 0.05};
    return v;
  }
  PickBoard board;
};

TEST_F(BoardTest, AWidthPickOnAFullStepStartsItOver) {
  EXPECT_TRUE(board.add(at(1, 0.5, 0)).empty());
  EXPECT_TRUE(board.add(at(1, -0.4, 0)).empty());
  EXPECT_TRUE(board.add(at(2, 0, 0)).empty());
  ASSERT_EQ(board.picks(kWidth).size(), 1U);
  EXPECT_EQ(board.picks(kWidth)[0].camera_m.x(), 2);
}

TEST_F(BoardTest, TheSeventeenthPlanePointIsRefusedAndTheSixteenStay) {
  ASSERT_TRUE(board.select("plane"));
  for (int i = 0; i < 16; ++i)
    ASSERT_TRUE(board.add(at(1, 0.01 * i, 0.02 * i)).empty());
  EXPECT_NE(board.add(at(1, 1, 1)), "");
  EXPECT_EQ(board.picks(kPlane).size(), 16U);
}

TEST_F(BoardTest, SelectKnowsOnlyTheFourSteps) {
  EXPECT_FALSE(board.select("door"));
  EXPECT_EQ(board.active(), kWidth);
  EXPECT_TRUE(board.select("contact"));
  EXPECT_EQ(board.active(), kContact);
}

TEST_F(BoardTest, TooFewPicksIsANoticeAndRecordsNothing) {
  board.add(at(1, 0.5, 0));
  const auto plan = board.send(view());
  ASSERT_TRUE(std::holds_alternative<PickBoard::Notice>(plan));
  EXPECT_TRUE(board.result(kWidth).empty());
}

TEST_F(BoardTest, NoPoseOrNoCalibrationIsRefusedAndRecordedAsTheStepsReply) {
  board.add(at(1, 0.5, 0));
  board.add(at(1, -0.4, 0));
  BoardView v = view();
  v.now.reset();
  v.why_no_pose = "no telemetry";
  auto plan = board.send(v);
  ASSERT_TRUE(std::holds_alternative<PickBoard::Refused>(plan));
  EXPECT_EQ(std::get<PickBoard::Refused>(plan).message, "no telemetry");
  EXPECT_NE(board.result(kWidth).str().find("\"NO_POSE\""), std::string::npos);
  v = view();
  v.camera_to_base = nullptr;
  plan = board.send(v);
  ASSERT_TRUE(std::holds_alternative<PickBoard::Refused>(plan));
}

TEST_F(BoardTest, APickBeyondTheStalenessRuleIsNamedToPickAgain) {
  board.add(at(1, 0.5, 0));
  board.add(at(1, -0.4, 0, core::PlanarPose{-0.2, 0, 0}));  // the base moved 0.2 m since
  const auto plan = board.send(view());
  ASSERT_TRUE(std::holds_alternative<PickBoard::Refused>(plan));
  EXPECT_EQ(std::get<PickBoard::Refused>(plan).field, "p2");
  EXPECT_NE(board.result(kWidth).str().find("\"PICK_AGAIN\""), std::string::npos);
}

TEST_F(BoardTest, PicksHereAreSentAsPickedAndPicksWithinTheRuleTransformed) {
  board.add(at(1, 0.5, 0));
  board.add(at(1, -0.4, 0));
  auto plan = board.send(view());
  ASSERT_TRUE(std::holds_alternative<PickBoard::Ready>(plan));
  auto ready = std::get<PickBoard::Ready>(plan);
  EXPECT_TRUE(ready.note.empty());
  const auto& width = std::get<protocol::MeasureDoorWidth>(ready.message);
  EXPECT_EQ(width.p1_hinge.position_m, core::Vec3(1, 0.5, 0));
  EXPECT_EQ(width.p2_moving_edge.position_m, core::Vec3(1, -0.4, 0));

  BoardView moved = view();
  moved.now = core::PlanarPose{0.02, 0, 0};  // 2 cm forward: within the rule
  plan = board.send(moved);
  ASSERT_TRUE(std::holds_alternative<PickBoard::Ready>(plan));
  ready = std::get<PickBoard::Ready>(plan);
  EXPECT_FALSE(ready.note.empty());
  const auto& seen = std::get<protocol::MeasureDoorWidth>(ready.message);
  EXPECT_NEAR(seen.p1_hinge.position_m.x(), 0.98, 1e-9);  // the door is 2 cm nearer now
}

TEST_F(BoardTest, OnlyAnAcceptedStepIsRememberedAndANewPickForgetsTheReply) {
  board.add(at(1, 0.5, 0));
  board.add(at(1, -0.4, 0));
  auto ready = std::get<PickBoard::Ready>(board.send(view()));
  board.answered(kWidth, client::JsonObject().add("ok", false), false, ready.what);
  EXPECT_FALSE(board.sent(kWidth));
  EXPECT_FALSE(board.result(kWidth).empty());
  board.answered(kWidth, client::JsonObject().add("ok", true), true, ready.what);
  ASSERT_TRUE(board.sent(kWidth));
  EXPECT_EQ(board.sent(kWidth)->camera_m.size(), 2U);
  board.add(at(1, 0.5, 0));
  EXPECT_TRUE(board.result(kWidth).empty());
}

TEST_F(BoardTest, AHandleNearerTheHingeThanTheMovingEdgeIsRefused) {
  board.add(at(1, 0.5, 0));   // P1, hinge side
  board.add(at(1, -0.4, 0));  // P2, moving edge
  const auto width = std::get<PickBoard::Ready>(board.send(view()));
  board.answered(kWidth, client::JsonObject().add("ok", true), true, width.what);
  ASSERT_TRUE(board.select("handle"));
  board.add(at(1, 0.45, 0));  // the axis next to P1
  board.add(at(1, 0.35, 0));
  const auto plan = board.send(view());
  ASSERT_TRUE(std::holds_alternative<PickBoard::Refused>(plan));
  EXPECT_EQ(std::get<PickBoard::Refused>(plan).field, "width.p1");
  EXPECT_NE(board.result(kHandle).str().find("\"HINGE_SIDE\""), std::string::npos);
}

TEST_F(BoardTest, ARectangleMakesThePlaneActiveAndClearAllForgetsEverything) {
  board.add(at(1, 0.5, 0));
  board.replace_plane({at(1, 0, 0), at(1, 0.1, 0), at(1, 0, 0.1)});
  EXPECT_EQ(board.active(), kPlane);
  EXPECT_EQ(board.picks(kPlane).size(), 3U);
  board.undo();
  EXPECT_EQ(board.picks(kPlane).size(), 2U);
  board.clear_all();
  EXPECT_EQ(board.active(), kWidth);
  EXPECT_TRUE(board.picks(kWidth).empty());
  EXPECT_TRUE(board.picks(kPlane).empty());
  EXPECT_FALSE(board.sent(kWidth));
}

}  // namespace
}  // namespace ajar::console
