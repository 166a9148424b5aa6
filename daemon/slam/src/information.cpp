#include "vog/slam/information.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <cmath>
#include <sstream>
#include <string>

namespace vog::slam {
namespace {

Status checkSymmetricFinite(const Eigen::MatrixXd& m, std::string_view what) {
  if (m.rows() == 0 || m.rows() != m.cols()) {
    std::ostringstream os;
    os << what << ": expected a non-empty square matrix, got " << m.rows() << "x" << m.cols();
    return Error{os.str()};
  }
  if (!m.allFinite()) return Error{std::string(what) + ": matrix has NaN or infinite entries"};
  const double scale = m.cwiseAbs().maxCoeff();
  const double asym = (m - m.transpose()).cwiseAbs().maxCoeff();
  if (asym > 1e-9 * std::max(scale, 1.0)) {
    std::ostringstream os;
    os << what << ": matrix is not symmetric (max |M - M^T| = " << asym << ")";
    return Error{os.str()};
  }
  return Status::success();
}

}  // namespace

Result<Eigen::MatrixXd> sqrtInformation(const Eigen::MatrixXd& information, std::string_view what) {
  if (Status s = checkSymmetricFinite(information, what); !s) return s.error();
  // Positive definiteness by eigenvalues relative to the largest one: an LLT of a numerically
  // singular matrix can "succeed" and whiten a direction with a meaningless huge weight.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(information, Eigen::EigenvaluesOnly);
  const double lambda_max = eig.eigenvalues().maxCoeff();
  const double lambda_min = eig.eigenvalues().minCoeff();
  if (!(lambda_max > 0.0) || !(lambda_min > 1e-12 * lambda_max)) {
    std::ostringstream os;
    os << what << ": information matrix is not positive definite (eigenvalues in [" << lambda_min << ", " << lambda_max
       << "])";
    return Error{os.str()};
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(information);
  if (llt.info() != Eigen::Success) return Error{std::string(what) + ": Cholesky factorisation failed"};
  Eigen::MatrixXd upper = llt.matrixL().transpose();
  return upper;
}

Result<Eigen::MatrixXd> informationFromCovariance(const Eigen::MatrixXd& covariance, std::string_view what) {
  if (Status s = checkSymmetricFinite(covariance, what); !s) return s.error();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(covariance);
  const double lambda_max = eig.eigenvalues().maxCoeff();
  const double lambda_min = eig.eigenvalues().minCoeff();
  if (!(lambda_max > 0.0) || !(lambda_min > 1e-12 * lambda_max)) {
    std::ostringstream os;
    os << what << ": covariance is not positive definite (eigenvalues in [" << lambda_min << ", " << lambda_max << "])";
    return Error{os.str()};
  }
  Eigen::MatrixXd information =
      eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  information = 0.5 * (information + information.transpose());
  return information;
}

}  // namespace vog::slam
