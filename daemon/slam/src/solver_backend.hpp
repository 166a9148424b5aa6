#pragma once
// Internal: Ceres linear-solver selection of the pose graph.

#include <ceres/ceres.h>

#include <string>

namespace vog::slam::detail {

// Sparse normal Cholesky on SuiteSparse (CHOLMOD) when that backend is compiled into Ceres; otherwise
// Eigen's sparse Cholesky, otherwise dense QR. `name` gets the choice, `note` explains a fallback
// (empty when SuiteSparse is used). Library code cannot print, so callers report `note`.
inline void selectLinearSolver(ceres::Solver::Options& options, std::string& name, std::string& note) {
  note.clear();
  if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
    options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    name = "SPARSE_NORMAL_CHOLESKY/SUITE_SPARSE";
  } else if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)) {
    options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
    name = "SPARSE_NORMAL_CHOLESKY/EIGEN_SPARSE";
    note = "SuiteSparse is not available in this Ceres build; fell back to Eigen sparse Cholesky. ";
  } else {
    options.linear_solver_type = ceres::DENSE_QR;
    name = "DENSE_QR";
    note = "No sparse backend in this Ceres build; fell back to dense QR (slow on large graphs). ";
  }
}

}  // namespace vog::slam::detail
