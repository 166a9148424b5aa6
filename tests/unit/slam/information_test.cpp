// Whitening by the upper-triangular square root of the information matrix.
#include "vog/slam/information.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include <cmath>
#include <limits>
#include <random>

namespace vog::slam {
namespace {

TEST(SqrtInformation, WhitenedNormEqualsMahalanobisForNonDiagonalInformation) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd B(6, 6);
  for (int i = 0; i < 36; ++i) B(i / 6, i % 6) = n(rng);
  const Eigen::MatrixXd omega = B * B.transpose() + 0.5 * Eigen::MatrixXd::Identity(6, 6);
  auto U = sqrtInformation(omega, "test");
  ASSERT_TRUE(U.ok()) << U.error().message;
  EXPECT_TRUE(U->isUpperTriangular(1e-12));
  EXPECT_TRUE((U->transpose() * *U).isApprox(omega, 1e-12));
  const Eigen::MatrixXd L = omega.llt().matrixL();
  double worst_L = 0.0;
  for (int k = 0; k < 20; ++k) {
    Eigen::VectorXd e(6);
    for (int i = 0; i < 6; ++i) e(i) = n(rng);
    const double mahalanobis = e.dot(omega * e);
    EXPECT_NEAR((*U * e).squaredNorm(), mahalanobis, 1e-9 * mahalanobis);
    worst_L = std::max(worst_L, std::abs((L * e).squaredNorm() - mahalanobis) / mahalanobis);
  }
  // Whitening with L (the Ceres example's matrixL()) is wrong for this information.
  EXPECT_GT(worst_L, 0.05);
}

TEST(SqrtInformation, RejectsSingularNanAsymmetricAndEmpty) {
  Eigen::MatrixXd singular = Eigen::MatrixXd::Identity(3, 3);
  singular(2, 2) = 0.0;
  auto a = sqrtInformation(singular, "odometry information");
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().message.find("odometry information"), std::string::npos);
  EXPECT_NE(a.error().message.find("positive definite"), std::string::npos);

  Eigen::MatrixXd nan = Eigen::MatrixXd::Identity(3, 3);
  nan(1, 1) = std::numeric_limits<double>::quiet_NaN();
  auto b = sqrtInformation(nan, "x");
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("NaN"), std::string::npos);

  Eigen::MatrixXd asym = Eigen::MatrixXd::Identity(3, 3);
  asym(0, 1) = 0.5;
  EXPECT_FALSE(sqrtInformation(asym, "x").ok());
  EXPECT_FALSE(sqrtInformation(Eigen::MatrixXd(0, 0), "x").ok());
  EXPECT_FALSE(sqrtInformation(Eigen::MatrixXd::Identity(2, 3), "x").ok());
  Eigen::MatrixXd negative = -Eigen::MatrixXd::Identity(2, 2);
  EXPECT_FALSE(sqrtInformation(negative, "x").ok());
}

TEST(InformationFromCovariance, InvertsAndRejectsSingular) {
  Eigen::MatrixXd cov(2, 2);
  cov << 0.04, 0.01, 0.01, 0.09;
  auto info = informationFromCovariance(cov, "cov");
  ASSERT_TRUE(info.ok());
  EXPECT_TRUE((*info * cov).isApprox(Eigen::MatrixXd::Identity(2, 2), 1e-12));
  Eigen::MatrixXd rank1(2, 2);
  rank1 << 1, 1, 1, 1;
  EXPECT_FALSE(informationFromCovariance(rank1, "cov").ok());
}

}  // namespace
}  // namespace vog::slam
