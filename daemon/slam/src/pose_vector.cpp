#include "vog/slam/pose_vector.hpp"

namespace vog::slam {

Vector6d toXyzRpy(const geometry::Pose3& T) {
  Vector6d x;
  x.head<3>() = T.translation();
  x.tail<3>() = geometry::rpyFromRotation(T.linear());
  return x;
}

geometry::Pose3 fromXyzRpy(const Vector6d& x) {
  return geometry::poseFromXyzRpy(x[kX], x[kY], x[kZ], x[kRoll], x[kPitch], x[kYaw]);
}

Vector6d xyzRpyDifference(const Vector6d& a, const Vector6d& b) {
  Vector6d d = a - b;
  for (int i = kRoll; i <= kYaw; ++i) d[i] = geometry::wrapAngle(d[i]);
  return d;
}

}  // namespace vog::slam
