// core/camera: pinhole deprojection, projection, and the pick rule for clicks on depth holes.
#include "ajar/core/camera.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "ajar/core/geometry.hpp"

namespace ajar::core {
namespace {

PinholeIntrinsics small() {
  PinholeIntrinsics k;
  k.fx_px = 100;
  k.fy_px = 120;
  k.cx_px = 9.5;
  k.cy_px = 7.0;
  k.width_px = 20;
  k.height_px = 15;
  return k;
}

TEST(Deproject, PrincipalPointIsOnTheOpticalAxis) {
  const auto p = deproject(small(), 9.5, 7.0, 1.7);
  EXPECT_DOUBLE_EQ(p.x(), 0.0);
  EXPECT_DOUBLE_EQ(p.y(), 0.0);
  EXPECT_DOUBLE_EQ(p.z(), 1.7);
}

TEST(Deproject, OffsetPixelScalesWithDepthAndFocalLength) {
  // u right of the centre -> +x; v below -> +y (camera frame: x right, y down, z forward).
  const auto p = deproject(small(), 19.5, 1.0, 2.0);
  EXPECT_DOUBLE_EQ(p.x(), 10.0 * 2.0 / 100.0);
  EXPECT_DOUBLE_EQ(p.y(), -6.0 * 2.0 / 120.0);
  EXPECT_DOUBLE_EQ(p.z(), 2.0);
}

TEST(Deproject, ProjectIsItsInverse) {
  const auto k = PinholeIntrinsics{};
  for (double u : {0.0, 100.25, 639.0}) {
    for (double v : {0.0, 239.5, 477.75}) {
      const auto px = project(k, deproject(k, u, v, 1.234));
      ASSERT_TRUE(px.has_value());
      EXPECT_NEAR(px->u_px, u, 1e-9);
      EXPECT_NEAR(px->v_px, v, 1e-9);
    }
  }
  EXPECT_FALSE(project(k, Vec3(0, 0, 0)).has_value());
  EXPECT_FALSE(project(k, Vec3(0, 0, -1)).has_value());
  EXPECT_FALSE(project(k, Vec3(0, NAN, 1)).has_value());
}

TEST(Deproject, ThenEquationOneGivesThePaperBaseFrame) {
  // A point straight ahead of the camera at 1 m is 1 m + 15 cm ahead of the base origin, 1.5 cm
  // left and 22 cm below it (paper, eq. 2 in metres).
  const auto t = CameraToBase::from_matrix(paper_camera_to_base_m());
  ASSERT_TRUE(t.ok());
  const auto k = PinholeIntrinsics{};
  const auto b = t->to_base(deproject(k, k.cx_px, k.cy_px, 1.0));
  EXPECT_NEAR(b.x(), 1.15, 1e-12);
  EXPECT_NEAR(b.y(), 0.015, 1e-12);
  EXPECT_NEAR(b.z(), -0.22, 1e-12);
  // A pixel right of the centre is to the robot's right (-y); one above is up (+z).
  const auto right = t->to_base(deproject(k, k.cx_px + 57.03, k.cy_px - 57.03, 1.0));
  EXPECT_NEAR(right.y(), 0.015 - 0.1, 1e-12);
  EXPECT_NEAR(right.z(), -0.22 + 0.1, 1e-12);
}

TEST(Intrinsics, RefusesNonsenseNamingTheField) {
  auto k = small();
  EXPECT_TRUE(check_intrinsics(k).ok());
  k.fx_px = 0;
  EXPECT_EQ(check_intrinsics(k).error().field, "fx_px");
  k = small();
  k.cy_px = NAN;
  EXPECT_EQ(check_intrinsics(k).error().code, ErrorCode::kNonFinite);
  EXPECT_EQ(check_intrinsics(k).error().field, "cy_px");
  k = small();
  k.height_px = 0;
  EXPECT_EQ(check_intrinsics(k).error().field, "height_px");
}

struct DepthImage {
  PinholeIntrinsics k = small();
  std::vector<float> d = std::vector<float>(20 * 15, 1.5F);
  DepthView view() const { return {d, k.width_px, k.height_px}; }
  float& at(int u, int v) { return d[static_cast<std::size_t>(v * 20 + u)]; }
};

TEST(PickPoint, ValidPixelUsesItsOwnDepth) {
  DepthImage img;
  img.at(4, 5) = 2.0F;
  const auto p = pick_point(img.k, img.view(), 4.2, 4.9);
  ASSERT_TRUE(p.ok());
  EXPECT_FALSE(p->from_window);
  EXPECT_DOUBLE_EQ(p->depth_m, 2.0);
  EXPECT_DOUBLE_EQ(p->camera_m.x(), (4.2 - 9.5) * 2.0 / 100.0);  // the sub-pixel ray is kept
}

TEST(PickPoint, HoleTakesTheMedianOfTheValidNeighbours) {
  DepthImage img;
  // A 7x7 window (radius 3) around (10, 7): make the pixel a hole and a few neighbours differ, so
  // that the mean and the median disagree.
  img.at(10, 7) = 0.0F;
  img.at(9, 7) = NAN;
  img.at(11, 7) = 9.0F;  // an outlier the median ignores
  img.at(12, 7) = 9.0F;
  const auto p = pick_point(img.k, img.view(), 10, 7);
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_TRUE(p->from_window);
  EXPECT_EQ(p->valid_in_window, 47);
  EXPECT_FLOAT_EQ(static_cast<float>(p->depth_m), 1.5F);
}

TEST(PickPoint, MedianOfAnEvenCountIsTheMeanOfTheMiddleTwo) {
  DepthImage img;
  std::fill(img.d.begin(), img.d.end(), 0.0F);
  img.at(3, 3) = 1.0F;
  img.at(5, 5) = 2.0F;
  const auto p = pick_point(img.k, img.view(), 3.6, 3.6, PickRule{1, 0.1});  // rounds to (4, 4)
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_DOUBLE_EQ(p->depth_m, 1.5);
}

TEST(PickPoint, MostlyHoleWindowIsRefusedNamingDepth) {
  DepthImage img;
  std::fill(img.d.begin(), img.d.end(), 0.0F);
  img.at(10, 7) = 0.0F;
  img.at(11, 8) = 1.0F;  // one valid sample of 49 is not enough
  const auto p = pick_point(img.k, img.view(), 10, 7);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kPointOutOfDepthRange);
  EXPECT_EQ(p.error().field, "depth");
  EXPECT_NE(p.error().message.find("(10, 7)"), std::string::npos) << p.error().message;
  EXPECT_NE(p.error().message.find("1 of 49"), std::string::npos) << p.error().message;
  EXPECT_NE(p.error().message.find("measurable"), std::string::npos);
}

TEST(PickPoint, WindowIsClippedAtTheImageBorder) {
  DepthImage img;
  img.at(0, 0) = 0.0F;
  const auto p = pick_point(img.k, img.view(), 0, 0);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->valid_in_window, 15);  // a 4x4 corner of the 7x7 window, less the hole
}

TEST(PickPoint, OutsideTheImageOrNonFiniteIsRefused) {
  DepthImage img;
  EXPECT_EQ(pick_point(img.k, img.view(), -0.6, 3).error().field, "pixel");
  EXPECT_EQ(pick_point(img.k, img.view(), 3, 14.6).error().code, ErrorCode::kBadCount);
  EXPECT_EQ(pick_point(img.k, img.view(), NAN, 3).error().code, ErrorCode::kNonFinite);
  auto k = img.k;
  k.width_px = 21;  // depth image does not match the intrinsics
  EXPECT_EQ(pick_point(k, img.view(), 3, 3).error().code, ErrorCode::kBadCount);
}

}  // namespace
}  // namespace ajar::core
