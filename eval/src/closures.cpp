#include "vog/eval/closures.hpp"

#include "vog/slam/pose_vector.hpp"

#include <Eigen/QR>

namespace vog::eval {

ClosureError closureError(const slam::LoopClosure& closure, const geometry::Pose3& T_from_to_true,
                          double max_translation_m, double max_rotation_rad) {
  using slam::Vector6d;
  const Eigen::MatrixXd& V_u = closure.factor.V_u;
  const Vector6d e_full = slam::xyzRpyDifference(slam::toXyzRpy(closure.T_from_to), slam::toXyzRpy(T_from_to_true));
  Vector6d scale;
  scale << Eigen::Vector3d::Constant(max_translation_m), Eigen::Vector3d::Constant(max_rotation_rad);
  // e = S y with S = diag(scale): minimise |y| subject to V_u S y = V_u e_full.
  const Eigen::MatrixXd A = V_u * scale.asDiagonal();
  const Eigen::VectorXd r = V_u * e_full;
  const Eigen::VectorXd y = A.completeOrthogonalDecomposition().solve(r);
  const Vector6d e = scale.asDiagonal() * Vector6d(y);
  ClosureError out;
  out.translation_m = e.head<3>().norm();
  out.rotation_rad = e.tail<3>().norm();
  out.wrong = out.translation_m > max_translation_m || out.rotation_rad > max_rotation_rad;
  return out;
}

}  // namespace vog::eval
