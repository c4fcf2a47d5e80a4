// Validation predicates: finite, depth range, width / handle ranges, yaw, arm reach.
#include <limits>

#include <gtest/gtest.h>

#include "ajar/core/geometry.hpp"
#include "test_support.hpp"

namespace ajar::core {
namespace {

const Limits kLimits{};  // depth 0.4..4, width 0.5..2, handle 0.05..0.3, yaw 0.7

using test::paper;

TEST(CheckFinite, NamesTheCoordinate) {
  EXPECT_TRUE(check_finite(Vec3(1, 2, 3), "p1").ok());
  auto nan = check_finite(Vec3(1, std::numeric_limits<double>::quiet_NaN(), 3), "contact");
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.error().code, ErrorCode::kNonFinite);
  EXPECT_EQ(nan.error().field, "contact.y");
  EXPECT_EQ(nan.error().message, "contact.y is NaN; every coordinate must be a finite number");
  auto inf = check_finite(Vec3(1, 2, -std::numeric_limits<double>::infinity()), "p2");
  ASSERT_FALSE(inf.ok());
  EXPECT_EQ(inf.error().field, "p2.z");
  EXPECT_NE(inf.error().message.find("infinite"), std::string::npos);
}

TEST(CheckDepth, CameraPointsUseCameraZInclusive) {
  const CameraToBase t = paper();
  for (double z : {0.4, 1.0, 4.0}) {
    EXPECT_TRUE(check_depth({Frame::kCamera, Vec3(0.5, -0.3, z)}, t, kLimits, "p1").ok()) << z;
  }
  for (double z : {0.39, -1.0, 0.0, 4.01}) {
    auto s = check_depth({Frame::kCamera, Vec3(0.0, 0.0, z)}, t, kLimits, "p1");
    ASSERT_FALSE(s.ok()) << z;
    EXPECT_EQ(s.error().code, ErrorCode::kPointOutOfDepthRange);
    EXPECT_EQ(s.error().field, "p1");
    EXPECT_NE(s.error().message.find("0.400..4.000 m"), std::string::npos) << s.error().message;
  }
}

TEST(CheckDepth, BasePointsAreTakenBackToTheCamera) {
  const CameraToBase t = paper();
  // Base x = camera z + 0.15: base x 0.5 is depth 0.35 (too near), base x 0.6 is depth 0.45.
  auto near = check_depth({Frame::kBase, Vec3(0.5, 0, 0)}, t, kLimits, "points[2]");
  ASSERT_FALSE(near.ok());
  EXPECT_EQ(near.error().code, ErrorCode::kPointOutOfDepthRange);
  EXPECT_EQ(near.error().field, "points[2]");
  EXPECT_NE(near.error().message.find("0.350 m"), std::string::npos) << near.error().message;
  EXPECT_TRUE(check_depth({Frame::kBase, Vec3(0.6, 0, 0)}, t, kLimits, "p1").ok());
  // Depth 0.5 in camera is fine; the same numbers read as a base point are depth 0.35.
  EXPECT_TRUE(check_depth({Frame::kCamera, Vec3(0, 0, 0.5)}, t, kLimits, "p").ok());
  EXPECT_FALSE(check_depth({Frame::kBase, Vec3(0.5, 0, 0.5)}, t, kLimits, "p").ok());
}

TEST(CheckDepth, UnknownFrame) {
  auto s = check_depth({static_cast<Frame>(2), Vec3(0, 0, 1)}, paper(), kLimits, "p1");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kUnknownFrame);
  EXPECT_EQ(s.error().field, "p1.frame");
}

TEST(CheckRanges, DoorWidth) {
  EXPECT_TRUE(check_door_width(0.5, kLimits).ok());
  EXPECT_TRUE(check_door_width(2.0, kLimits).ok());
  auto wide = check_door_width(40.0, kLimits);
  ASSERT_FALSE(wide.ok());
  EXPECT_EQ(wide.error().code, ErrorCode::kWidthOutOfRange);
  EXPECT_EQ(wide.error().field, "width_m");
  EXPECT_EQ(wide.error().message,
            "door width 40.000 m is outside the allowed range 0.500..2.000 m");
  EXPECT_EQ(check_door_width(0.49, kLimits).error().code, ErrorCode::kWidthOutOfRange);
  EXPECT_EQ(check_door_width(std::numeric_limits<double>::quiet_NaN(), kLimits).error().code,
            ErrorCode::kNonFinite);
}

TEST(CheckRanges, HandleLength) {
  EXPECT_TRUE(check_handle_length(0.12, kLimits).ok());
  auto s = check_handle_length(0.031, kLimits);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kHandleLengthOutOfRange);
  EXPECT_EQ(s.error().field, "handle_length_m");
  EXPECT_EQ(s.error().message, "handle length 0.031 m is outside the allowed range 0.050..0.300 m");
  EXPECT_EQ(check_handle_length(0.31, kLimits).error().code, ErrorCode::kHandleLengthOutOfRange);
}

TEST(CheckRanges, Yaw) {
  EXPECT_TRUE(check_yaw(0.7, kLimits).ok());
  EXPECT_TRUE(check_yaw(-0.7, kLimits).ok());
  for (double yaw : {0.71, -0.71, 3.0}) {
    auto s = check_yaw(yaw, kLimits);
    ASSERT_FALSE(s.ok()) << yaw;
    EXPECT_EQ(s.error().code, ErrorCode::kYawOutOfRange);
    EXPECT_EQ(s.error().field, "yaw_deviation_rad");
    EXPECT_NE(s.error().message.find("maximum 0.700 rad"), std::string::npos) << s.error().message;
  }
  EXPECT_EQ(check_yaw(std::numeric_limits<double>::infinity(), kLimits).error().code,
            ErrorCode::kNonFinite);
}

TEST(Reach, MarginIsTheDistanceToTheNearestBoundary) {
  ArmWorkspace arm;
  arm.shoulder_m = Vec3(0, 0, 0);
  arm.min_reach_m = 0.2;
  arm.max_reach_m = 1.0;
  arm.min_z_m = -0.5;
  arm.max_z_m = 0.5;
  EXPECT_DOUBLE_EQ(reach_margin_m(Vec3(0.7, 0, 0), arm), 0.3);    // outer sphere
  EXPECT_DOUBLE_EQ(reach_margin_m(Vec3(0.3, 0, 0), arm), 0.1);    // inner sphere
  EXPECT_DOUBLE_EQ(reach_margin_m(Vec3(0.6, 0, 0.4), arm), 0.1);  // ceiling of the band
  EXPECT_DOUBLE_EQ(reach_margin_m(Vec3(0.6, 0, -0.45), arm), 0.05);
  EXPECT_DOUBLE_EQ(reach_margin_m(Vec3(0, 1.2, 0), arm), -0.2);  // negative outside
  EXPECT_DOUBLE_EQ(reach_margin_m(Vec3(0, 0.1, 0), arm), -0.1);
  EXPECT_DOUBLE_EQ(reach_margin_m(Vec3(0.3, 0, 0.6), arm), -0.1);

  EXPECT_TRUE(check_reach(Vec3(0.7, 0, 0), arm, "contact").ok());
  EXPECT_TRUE(check_reach(Vec3(1.0, 0, 0), arm, "contact").ok());  // boundary is inside
  for (const Vec3& p : {Vec3(1.01, 0, 0), Vec3(0.1, 0, 0), Vec3(0.3, 0, 0.6), Vec3(0.3, 0, -0.6)}) {
    auto s = check_reach(p, arm, "contact");
    ASSERT_FALSE(s.ok()) << p.transpose();
    EXPECT_EQ(s.error().code, ErrorCode::kOutOfReach);
    EXPECT_EQ(s.error().field, "contact");
    EXPECT_NE(s.error().message.find("reach 0.200..1.000 m"), std::string::npos)
        << s.error().message;
  }
  auto nan = check_reach(Vec3(0.5, std::numeric_limits<double>::quiet_NaN(), 0), arm, "contact");
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.error().code, ErrorCode::kNonFinite);
}

}  // namespace
}  // namespace ajar::core
