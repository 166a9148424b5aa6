// The evaluation's judgement of loop closures and its figures.
#include "vog/eval/closures.hpp"
#include "vog/eval/figures.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

// closureError judges a closure only by what it asserts (V_u x = V_u x_icp), in metres and radians
// kept apart: a full-rank closure by its plain error, a partial one by the smallest error that
// explains its discrepancy.
namespace vog::eval {
namespace {

TEST(ClosureError, FullRankClosureIsJudgedByItsPlainError) {
  slam::LoopClosure lc;
  lc.factor.V_u = Eigen::MatrixXd::Zero(3, 6);
  lc.factor.V_u(0, 0) = lc.factor.V_u(1, 1) = lc.factor.V_u(2, 5) = 1.0;
  const geometry::Pose3 T_true = geometry::poseFromXyzRpy(2.0, 1.0, 0.0, 0.0, 0.0, 0.3);
  lc.T_from_to = geometry::poseFromXyzRpy(2.1, 1.0, 0.0, 0.0, 0.0, 0.3);
  ClosureError e = closureError(lc, T_true);
  EXPECT_NEAR(e.translation_m, 0.1, 1e-9);
  EXPECT_NEAR(e.rotation_rad, 0.0, 1e-9);
  EXPECT_FALSE(e.wrong);
  lc.T_from_to = geometry::poseFromXyzRpy(2.0, 1.0, 0.0, 0.0, 0.0, 0.3 + geometry::deg2rad(2.5));
  e = closureError(lc, T_true);
  EXPECT_NEAR(e.rotation_rad, geometry::deg2rad(2.5), 1e-9);
  EXPECT_TRUE(e.wrong);
  // A component the closure does not constrain (z here) does not count.
  lc.T_from_to = geometry::poseFromXyzRpy(2.0, 1.0, 5.0, 0.0, 0.0, 0.3);
  EXPECT_FALSE(closureError(lc, T_true).wrong);
}

TEST(ClosureError, PartialClosureMixingMetresAndRadiansIsNotBlamedForARotationItDidNotMake) {
  // One well-conditioned direction mixing lateral translation and yaw (unit vector in x-rpy space).
  slam::LoopClosure lc;
  lc.factor.V_u = Eigen::MatrixXd::Zero(1, 6);
  lc.factor.V_u(0, 1) = lc.factor.V_u(0, 5) = std::sqrt(0.5);
  const geometry::Pose3 T_true = geometry::poseFromXyzRpy(3.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  // 0.15 m lateral error only: projecting it on V_u would show 0.075 rad (4.3 deg) of yaw error.
  lc.T_from_to = geometry::poseFromXyzRpy(3.0, 0.15, 0.0, 0.0, 0.0, 0.0);
  ClosureError e = closureError(lc, T_true);
  EXPECT_FALSE(e.wrong) << e.translation_m << " m, " << e.rotation_rad << " rad";
  EXPECT_LE(e.translation_m, 0.15 + 1e-9);
  // 0.3 m lateral is more than any error within the bounds can explain.
  lc.T_from_to = geometry::poseFromXyzRpy(3.0, 0.3, 0.0, 0.0, 0.0, 0.0);
  e = closureError(lc, T_true);
  EXPECT_TRUE(e.wrong) << e.translation_m << " m, " << e.rotation_rad << " rad";
}

TEST(Figures, PercentilesInterpolateBetweenOrderStatistics) {
  EXPECT_DOUBLE_EQ(median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_DOUBLE_EQ(median({4.0, 1.0, 2.0, 3.0}), 2.5);
  EXPECT_DOUBLE_EQ(percentile({0.0, 10.0}, 0.95), 9.5);
  EXPECT_DOUBLE_EQ(percentile({5.0, 1.0}, 1.0), 5.0);
  EXPECT_TRUE(std::isnan(median({})));
}

TEST(Figures, JsonKeepsTheOrderQuotesStringsAndPrintsNonFiniteAsNull) {
  JsonObject j;
  j.add("scene", std::string("pier \"B\""));
  j.add("n", 3);
  j.add("rmse", std::nan(""));
  EXPECT_EQ(j.str(), "{\n  \"scene\": \"pier \\\"B\\\"\",\n  \"n\": 3,\n  \"rmse\": null\n}");
}

}  // namespace
}  // namespace vog::eval
