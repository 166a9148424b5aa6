#include "vog/geometry/pose.hpp"

#include <numbers>

namespace vog::geometry {

double wrapAngle(double angle_rad) {
  double a = std::remainder(angle_rad, 2.0 * std::numbers::pi);
  if (a <= -std::numbers::pi) a += 2.0 * std::numbers::pi;
  return a;
}

Pose3 poseFromXyzRpy(double x, double y, double z, double roll_rad, double pitch_rad, double yaw_rad) {
  Pose3 T = Pose3::Identity();
  T.linear() =
      (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

Eigen::Vector3d rpyFromRotation(const Eigen::Matrix3d& R) {
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  return {roll, pitch, yaw};
}

double yawOf(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

Pose3 planarPart(const Pose3& T) {
  return poseFromXyzRpy(T.translation().x(), T.translation().y(), 0.0, 0.0, 0.0, yawOf(T.linear()));
}

bool isFinite(const Eigen::Vector3d& p) { return p.allFinite(); }

bool isValidPose(const Pose3& T, double tolerance) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), tolerance)) return false;
  if (std::abs(R.determinant() - 1.0) > tolerance) return false;
  const Eigen::RowVector4d last = T.matrix().row(3);
  return last.isApprox(Eigen::RowVector4d(0, 0, 0, 1));
}

double translationDistance(const Pose3& a, const Pose3& b) { return (a.translation() - b.translation()).norm(); }

double rotationAngle(const Pose3& a, const Pose3& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

}  // namespace vog::geometry
