#include "vog/geometry/pose.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <numbers>

namespace vog::geometry {
namespace {

TEST(WrapAngle, MapsIntoHalfOpenInterval) {
  EXPECT_NEAR(wrapAngle(3 * std::numbers::pi), std::numbers::pi, 1e-12);
  EXPECT_NEAR(wrapAngle(-std::numbers::pi), std::numbers::pi, 1e-12);
  EXPECT_NEAR(wrapAngle(0.5 + 4 * std::numbers::pi), 0.5, 1e-12);
  EXPECT_NEAR(wrapAngle(-0.5 - 2 * std::numbers::pi), -0.5, 1e-12);
}

TEST(PoseFromXyzRpy, RoundTripsThroughRpy) {
  const Pose3 T = poseFromXyzRpy(1, 2, 3, 0.1, -0.2, 2.5);
  const Eigen::Vector3d rpy = rpyFromRotation(T.linear());
  EXPECT_NEAR(rpy.x(), 0.1, 1e-12);
  EXPECT_NEAR(rpy.y(), -0.2, 1e-12);
  EXPECT_NEAR(rpy.z(), 2.5, 1e-12);
  EXPECT_NEAR(yawOf(T.linear()), 2.5, 1e-12);
  EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
}

TEST(PoseFromXyzRpy, YawRotatesXTowardsY) {
  const Pose3 T = poseFromXyzRpy(0, 0, 0, 0, 0, std::numbers::pi / 2);
  EXPECT_TRUE((T * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
}

TEST(IsValidPose, RejectsNonFiniteAndNonRigid) {
  Pose3 T = poseFromXyzRpy(1, 2, 3, 0.1, 0.2, 0.3);
  EXPECT_TRUE(isValidPose(T));
  Pose3 nan = T;
  nan.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(isValidPose(nan));
  Pose3 inf = T;
  inf.linear()(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(isValidPose(inf));
  Pose3 scaled = T;
  scaled.linear() *= 1.1;
  EXPECT_FALSE(isValidPose(scaled));
  Pose3 mirrored = T;
  mirrored.linear().col(0) *= -1.0;
  EXPECT_FALSE(isValidPose(mirrored));
}

TEST(PoseDistances, TranslationAndRotation) {
  const Pose3 a = poseFromXyzRpy(0, 0, 0, 0, 0, 0);
  const Pose3 b = poseFromXyzRpy(3, 4, 0, 0, 0, 0.25);
  EXPECT_NEAR(translationDistance(a, b), 5.0, 1e-12);
  EXPECT_NEAR(rotationAngle(a, b), 0.25, 1e-12);
}

}  // namespace
}  // namespace vog::geometry
