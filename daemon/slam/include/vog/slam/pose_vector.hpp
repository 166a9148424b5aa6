#pragma once
// The 6-vector pose parameterisation shared by the pose graph, ICP and the partial loop-closure
// factor: x = (x, y, z, roll, pitch, yaw) with R = Rz(yaw) Ry(pitch) Rx(roll) (geometry/pose.hpp).
// The vehicle cannot roll or pitch much (thesis 4.1), so the pitch singularity at +-90 deg is never
// approached. Thesis Alg. 7-8 and Eq. 4.2 work on exactly this vector (V_u x_icp).

#include "vog/geometry/pose.hpp"

#include <Eigen/Core>

namespace vog::slam {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Indices into the 6-vector.
enum PoseIndex : int { kX = 0, kY = 1, kZ = 2, kRoll = 3, kPitch = 4, kYaw = 5 };

Vector6d toXyzRpy(const geometry::Pose3& T);
geometry::Pose3 fromXyzRpy(const Vector6d& x);

// a - b with the three angle components wrapped to (-pi, pi].
Vector6d xyzRpyDifference(const Vector6d& a, const Vector6d& b);

}  // namespace vog::slam
