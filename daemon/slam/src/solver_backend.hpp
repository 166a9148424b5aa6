#pragma once
// Internal: Ceres linear-solver selection of the pose graph.

#include "vog/slam/pose_graph.hpp"

#include <ceres/ceres.h>

#include <string>

namespace vog::slam::detail {

// Sparse normal Cholesky on the preferred backend when it is compiled into Ceres; otherwise on the
// other one, otherwise dense QR. `name` gets the choice, `note` explains a fallback (empty when the
// preferred backend is used). Library code cannot print, so callers report `note`.
inline void selectLinearSolver(ceres::Solver::Options& options, SparseBackend preferred, std::string& name,
                               std::string& note) {
  note.clear();
  const auto library = [](SparseBackend b) {
    return b == SparseBackend::kSuiteSparse ? ceres::SUITE_SPARSE : ceres::EIGEN_SPARSE;
  };
  const auto label = [](SparseBackend b) { return b == SparseBackend::kSuiteSparse ? "SUITE_SPARSE" : "EIGEN_SPARSE"; };
  const SparseBackend other =
      preferred == SparseBackend::kSuiteSparse ? SparseBackend::kEigen : SparseBackend::kSuiteSparse;
  for (const SparseBackend b : {preferred, other}) {
    if (!ceres::IsSparseLinearAlgebraLibraryTypeAvailable(library(b))) continue;
    options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options.sparse_linear_algebra_library_type = library(b);
    name = std::string("SPARSE_NORMAL_CHOLESKY/") + label(b);
    if (b != preferred)
      note = std::string(label(preferred)) + " is not available in this Ceres build; fell back to " + label(b) + ". ";
    return;
  }
  options.linear_solver_type = ceres::DENSE_QR;
  name = "DENSE_QR";
  note = "No sparse backend in this Ceres build; fell back to dense QR (slow on large graphs). ";
}

}  // namespace vog::slam::detail
