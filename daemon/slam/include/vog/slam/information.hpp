#pragma once
// Square roots of information matrices for whitening residuals.
//
// A factor with error e and information Omega contributes e^T Omega e to the cost. Ceres minimises
// sum ||r||^2, so the residual must be r = U e with U^T U = Omega. With the Cholesky factor
// Omega = L L^T this is U = L^T (upper triangular): ||L^T e||^2 = e^T L L^T e = e^T Omega e.
// Using L itself (as the Ceres pose-graph example does with matrixL()) gives e^T L^T L e, which equals
// e^T Omega e only for diagonal Omega.

#include "vog/core/result.hpp"

#include <Eigen/Core>

#include <string_view>

namespace vog::slam {

// Returns U = L^T for a symmetric positive-definite information matrix, or an Error naming `what`
// when the matrix is empty, non-square, non-finite, not symmetric or not positive definite.
Result<Eigen::MatrixXd> sqrtInformation(const Eigen::MatrixXd& information, std::string_view what);

// Information of a covariance (its inverse), checked the same way; `what` names the matrix in errors.
Result<Eigen::MatrixXd> informationFromCovariance(const Eigen::MatrixXd& covariance, std::string_view what);

}  // namespace vog::slam
