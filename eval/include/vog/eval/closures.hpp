#pragma once
// A loop closure judged against ground truth: how far it is from the true relative pose of its
// submaps, in the directions it constrains.

#include "vog/geometry/pose.hpp"
#include "vog/slam/loop_closer.hpp"

namespace vog::eval {

// The bounds of a right closure (the thesis's figures and the project's: 0.2 m, 2 deg).
inline constexpr double kClosureMaxTranslation_m = 0.2;
inline constexpr double kClosureMaxRotation_rad = 2.0 * 3.14159265358979323846 / 180.0;

// A partial closure asserts only V_u x = V_u x_icp, and its rows mix metres and radians, so the error
// is the smallest pose error that explains the constraint's discrepancy r = V_u (x_icp - x_true): the
// minimum-norm e with V_u e = r under the metric that scales translations by 1 / max_translation_m
// and rotations by 1 / max_rotation_rad. For a full-rank closure this is simply x_icp - x_true. The
// closure is wrong when that e exceeds either bound.
struct ClosureError {
  double translation_m = 0.0;
  double rotation_rad = 0.0;
  bool wrong = false;
};
ClosureError closureError(const slam::LoopClosure& closure, const geometry::Pose3& T_from_to_true,
                          double max_translation_m = kClosureMaxTranslation_m,
                          double max_rotation_rad = kClosureMaxRotation_rad);

}  // namespace vog::eval
