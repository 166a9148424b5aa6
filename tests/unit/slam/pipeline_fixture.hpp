#pragma once
// Shared inputs of the mapping tests: the synthetic pier, an orbit trajectory (truth) and odometry
// corrupted by seeded noise (random walk on the planar increments plus a heading-rate bias, the
// dominant drift of a DVL/INS dead-reckoning, thesis 4.5.3).
#include "synthetic_scene.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/slam/pose_graph.hpp"
#include "vog/slam/submap_builder.hpp"

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace vog::slam::testing {

constexpr std::int64_t kScanPeriodNs = 200'000'000;  // 5 scans/s (thesis Table 4.2)

// Distance from a world point to the nearest surface of the pier scene.
inline double distanceToPier(const test::SyntheticScene& scene, const Eigen::Vector3d& p) {
  double d = 1e9;
  for (const auto& pl : scene.planes) d = std::min(d, std::abs(p.z() - pl.z));
  for (const auto& c : scene.cylinders) {
    if (p.z() < c.z_min - 0.3 || p.z() > c.z_max + 0.3) continue;
    d = std::min(d, std::abs((p.head<2>() - c.centre_xy).norm() - c.radius));
  }
  return d;
}

struct Run {
  std::vector<geometry::Pose3> truth;  // T_world_vehicle per scan
  std::vector<ScanInput> inputs;       // odometry pose, absolute z/roll/pitch, scan
};

// `stride` keeps every stride-th pose of the orbit (fewer scans per metre, same geometry).
inline Run makeRun(int n_scans, int stride, double cov_xy_m2_per_s, double yaw_bias_rad_per_s, std::uint64_t seed) {
  const test::SyntheticScene scene = test::SyntheticScene::pier();
  const geometry::SonarFan fan;
  const auto orbit = test::orbitTrajectory(n_scans * stride, 5.5, -2.0);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Run run;
  const double dt_s = 1e-9 * static_cast<double>(kScanPeriodNs);
  geometry::Pose3 T_odom = orbit[0];
  for (int k = 0; k < n_scans; ++k) {
    const geometry::Pose3& T_true = orbit[static_cast<std::size_t>(k * stride)];
    if (k > 0) {
      const geometry::Pose3& T_prev = orbit[static_cast<std::size_t>((k - 1) * stride)];
      Eigen::Vector3d d = planarOdometry(T_prev, T_true);
      d.x() += std::sqrt(cov_xy_m2_per_s * dt_s) * g(rng);
      d.y() += std::sqrt(cov_xy_m2_per_s * dt_s) * g(rng);
      d.z() += yaw_bias_rad_per_s * dt_s;
      const Eigen::Vector3d rpy_odom = geometry::rpyFromRotation(T_odom.linear());
      const Eigen::Vector3d rpy_true = geometry::rpyFromRotation(T_true.linear());
      const double yaw = rpy_odom.z();
      const Eigen::Vector3d t = T_odom.translation();
      T_odom = geometry::poseFromXyzRpy(t.x() + std::cos(yaw) * d.x() - std::sin(yaw) * d.y(),
                                        t.y() + std::sin(yaw) * d.x() + std::cos(yaw) * d.y(), T_true.translation().z(),
                                        rpy_true.x(), rpy_true.y(), geometry::wrapAngle(yaw + d.z()));
    }
    ScanInput in;
    in.T_world_vehicle_odom = T_odom;
    const Eigen::Vector3d rpy = geometry::rpyFromRotation(T_true.linear());
    in.z_roll_pitch = Eigen::Vector3d(T_true.translation().z(), rpy.x(), rpy.y());
    in.scan = scene.scan(T_true, fan, 0.02, rng);
    in.scan.stamp_ns = (k + 1) * kScanPeriodNs;
    run.truth.push_back(T_true);
    run.inputs.push_back(std::move(in));
  }
  return run;
}

inline std::size_t scanIndexOf(std::int64_t stamp_ns) { return static_cast<std::size_t>(stamp_ns / kScanPeriodNs - 1); }

}  // namespace vog::slam::testing
