#pragma once
// Poses and frames. A pose named T_a_b maps coordinates in frame b to frame a (p_a = T_a_b * p_b).
// The world frame is z up; vehicle frame x forward, y left, z up.

#include <Eigen/Geometry>

#include <cmath>

namespace vog::geometry {

using Pose3 = Eigen::Isometry3d;

// Wraps an angle to (-pi, pi].
double wrapAngle(double angle_rad);

// Pose from x, y, z and roll, pitch, yaw (Z-Y-X intrinsic: R = Rz(yaw) Ry(pitch) Rx(roll)).
Pose3 poseFromXyzRpy(double x, double y, double z, double roll_rad, double pitch_rad, double yaw_rad);

// Roll, pitch, yaw of a rotation, inverse of poseFromXyzRpy for |pitch| < pi/2.
Eigen::Vector3d rpyFromRotation(const Eigen::Matrix3d& R);

// Yaw of a rotation (heading of its x axis projected on the horizontal plane).
double yawOf(const Eigen::Matrix3d& R);

// The planar part of T: its x, y translation and yaw (z, roll and pitch dropped). Depth, roll and
// pitch are measured absolutely, so two odometry or navigation frames differ by a planar motion.
Pose3 planarPart(const Pose3& T);

// True when every entry of the pose is finite and its rotation is orthonormal with det +1
// (to a tolerance that admits accumulated rounding, not corrupted data).
bool isValidPose(const Pose3& T, double tolerance = 1e-6);

bool isFinite(const Eigen::Vector3d& p);

// Translation distance and rotation angle between two poses.
double translationDistance(const Pose3& a, const Pose3& b);
double rotationAngle(const Pose3& a, const Pose3& b);

}  // namespace vog::geometry
