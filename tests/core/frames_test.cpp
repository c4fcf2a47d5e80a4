// Camera -> base transform (paper eq. 1-2) and its rigidity checks.
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "ajar/core/geometry.hpp"
#include "test_support.hpp"

namespace ajar::core {
namespace {

using test::kInf;
using test::kNaN;

TEST(PaperTransform, IsEquationTwoInMetres) {
  Eigen::Matrix4d expected;
  expected << 0, 0, 1, 0.15, -1, 0, 0, 0.015, 0, -1, 0, -0.22, 0, 0, 0, 1;
  EXPECT_TRUE(paper_camera_to_base_m().isApprox(expected, 0.0)) << paper_camera_to_base_m();
}

TEST(PaperTransform, PointOneMetreInFrontOfTheCamera) {
  auto t = CameraToBase::from_matrix(paper_camera_to_base_m());
  ASSERT_TRUE(t.ok()) << t.error().message;
  const Vec3 b = t->to_base(Vec3(0, 0, 1));
  EXPECT_NEAR(b.x(), 1.15, 1e-12);
  EXPECT_NEAR(b.y(), 0.015, 1e-12);
  EXPECT_NEAR(b.z(), -0.22, 1e-12);
}

TEST(PaperTransform, CameraAxesMapToBaseAxes) {
  auto t = CameraToBase::from_matrix(paper_camera_to_base_m());
  ASSERT_TRUE(t.ok());
  const Vec3 origin = t->to_base(Vec3::Zero());
  // Camera +x (image right) is base -y (robot's right); camera +y (image down) is base -z.
  EXPECT_TRUE((t->to_base(Vec3::UnitX()) - origin).isApprox(-Vec3::UnitY(), 1e-15));
  EXPECT_TRUE((t->to_base(Vec3::UnitY()) - origin).isApprox(-Vec3::UnitZ(), 1e-15));
  EXPECT_TRUE((t->to_base(Vec3::UnitZ()) - origin).isApprox(Vec3::UnitX(), 1e-15));
}

TEST(FramedPointToBase, CameraPointsAreTransformedBasePointsPassThrough) {
  auto t = CameraToBase::from_matrix(paper_camera_to_base_m());
  ASSERT_TRUE(t.ok());
  const Vec3 p(0.3, -0.2, 1.1);
  EXPECT_TRUE(t->to_base(FramedPoint{Frame::kBase, p}) == p);
  EXPECT_TRUE(t->to_base(FramedPoint{Frame::kCamera, p}).isApprox(t->to_base(p), 0.0));
  // A frame value outside the enum gives NaN, which every later finite check refuses.
  EXPECT_FALSE(t->to_base(FramedPoint{static_cast<Frame>(7), p}).allFinite());
}

TEST(CameraToBaseProperty, RandomRigidTransformsRoundTrip) {
  std::mt19937_64 rng(20240611);
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Matrix4d m = test::random_rigid(rng);
    auto t = CameraToBase::from_matrix(m);
    ASSERT_TRUE(t.ok()) << "trial " << trial << ": " << t.error().message;
    const Vec3 c = test::uniform_vec3(rng, Vec3(-2, -2, 0), Vec3(2, 2, 4));
    const Vec3 b = t->to_base(c);
    EXPECT_TRUE(b.isApprox((m * c.homogeneous()).head<3>(), 1e-12));
    EXPECT_LT((t->to_camera(b) - c).norm(), 1e-12) << "trial " << trial;
    EXPECT_LT((t->to_base(t->to_camera(c)) - c).norm(), 1e-12) << "trial " << trial;
    // Rigid: distances are preserved.
    const Vec3 c2 = test::uniform_vec3(rng, Vec3(-2, -2, 0), Vec3(2, 2, 4));
    EXPECT_NEAR((t->to_base(c2) - b).norm(), (c2 - c).norm(), 1e-12);
  }
}

TEST(CameraToBaseRigidity, NonFiniteEntryInEveryPosition) {
  for (double bad : {kNaN, kInf, -kInf}) {
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) {
        Eigen::Matrix4d m = paper_camera_to_base_m();
        m(r, c) = bad;
        auto t = CameraToBase::from_matrix(m);
        ASSERT_FALSE(t.ok()) << r << "," << c;
        EXPECT_EQ(t.error().code, ErrorCode::kNonFinite);
        EXPECT_EQ(t.error().field, "matrix");
      }
    }
  }
}

TEST(CameraToBaseRigidity, BottomRowMustBeExactlyZeroZeroZeroOne) {
  for (int c = 0; c < 4; ++c) {
    for (double delta : {1e-12, -0.5, 1.0}) {
      Eigen::Matrix4d m = paper_camera_to_base_m();
      m(3, c) += delta;
      auto t = CameraToBase::from_matrix(m);
      ASSERT_FALSE(t.ok()) << "column " << c << " delta " << delta;
      EXPECT_EQ(t.error().code, ErrorCode::kTransformNotRigid);
      EXPECT_EQ(t.error().field, "bottom_row");
      EXPECT_NE(t.error().message.find("0 0 0 1"), std::string::npos) << t.error().message;
    }
  }
}

TEST(CameraToBaseRigidity, ScaledShearedOrPerturbedRotationIsNotOrthonormal) {
  Eigen::Matrix4d scaled = paper_camera_to_base_m();
  scaled.topLeftCorner<3, 3>() *= 1.01;  // e.g. a centimetre/metre mix-up in one calibration step
  Eigen::Matrix4d sheared = paper_camera_to_base_m();
  sheared(0, 0) = 0.2;
  Eigen::Matrix4d perturbed = paper_camera_to_base_m();
  perturbed(1, 2) = 1e-4;
  Eigen::Matrix4d translation_in_rotation = paper_camera_to_base_m();
  translation_in_rotation.topLeftCorner<3, 3>().setZero();
  for (const Eigen::Matrix4d& m : {scaled, sheared, perturbed, translation_in_rotation}) {
    auto t = CameraToBase::from_matrix(m);
    ASSERT_FALSE(t.ok()) << m;
    EXPECT_EQ(t.error().code, ErrorCode::kTransformNotRigid);
    EXPECT_EQ(t.error().field, "rotation");
  }
}

TEST(CameraToBaseRigidity, MirrorImageHasDeterminantMinusOne) {
  Eigen::Matrix4d m = paper_camera_to_base_m();
  m.row(1).head<3>() *= -1.0;  // orthonormal, but a reflection
  auto t = CameraToBase::from_matrix(m);
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, ErrorCode::kTransformNotRigid);
  EXPECT_EQ(t.error().field, "determinant");
  EXPECT_NE(t.error().message.find("-1.000000"), std::string::npos) << t.error().message;
}

TEST(CameraToBaseRigidity, ToleranceIsHonouredAndNearRigidIsSnapped) {
  Eigen::Matrix4d m = paper_camera_to_base_m();
  m(0, 2) = 1.0 + 1e-8;  // within the default 1e-6
  auto t = CameraToBase::from_matrix(m);
  ASSERT_TRUE(t.ok()) << t.error().message;
  const Eigen::Matrix3d r = t->isometry().linear();
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-14);
  const Vec3 c(0.1, 0.2, 1.3);
  EXPECT_LT((t->to_camera(t->to_base(c)) - c).norm(), 1e-14);
  // The same matrix with a tighter tolerance is refused.
  auto strict = CameraToBase::from_matrix(m, 1e-9);
  ASSERT_FALSE(strict.ok());
  EXPECT_EQ(strict.error().field, "rotation");
}

}  // namespace
}  // namespace ajar::core

namespace ajar {
namespace {

TEST(ErrorTable, TransformNotRigidHasAStableNameAndNumber) {
  EXPECT_EQ(to_string(ErrorCode::kTransformNotRigid), "TRANSFORM_NOT_RIGID");
  EXPECT_EQ(static_cast<int>(ErrorCode::kTransformNotRigid), 313);
}

}  // namespace
}  // namespace ajar
