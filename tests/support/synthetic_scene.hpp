#pragma once
// Analytic scenes for map tests and benchmarks: horizontal planes and vertical cylinders, intersected
// exactly, and a profiling-sonar scan generator over them. Deterministic for a given seed.

#include "vog/geometry/pose.hpp"
#include "vog/geometry/sonar.hpp"

#include <random>
#include <vector>

namespace vog::test {

struct HorizontalPlane {
  double z;
};

struct VerticalCylinder {
  Eigen::Vector2d centre_xy;
  double radius;
  double z_min;
  double z_max;
};

class SyntheticScene {
 public:
  std::vector<HorizontalPlane> planes;
  std::vector<VerticalCylinder> cylinders;

  // Distance along the unit direction to the first surface, or +inf.
  double raycast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;

  // One sonar ping from the vehicle pose: ranges beyond fan.max_range_m are kNoReturn; gaussian range
  // noise of sigma_m (0 = exact) drawn from rng.
  geometry::RangeScan scan(const geometry::Pose3& T_world_vehicle, const geometry::SonarFan& fan, double sigma_m,
                           std::mt19937_64& rng) const;

  // A pier: seabed at z = -4 m and a few rows of pilings.
  static SyntheticScene pier();
};

// Vehicle poses on circles around the origin, sonar looking at the centre, 5 scans/s at 0.25 m/s
// (thesis Table 4.2), radius and depth changing per lap.
std::vector<geometry::Pose3> orbitTrajectory(int n_scans, double radius_m, double depth_m);

}  // namespace vog::test
