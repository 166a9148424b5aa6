#pragma once
// Builds small VOG-Maps from the synthetic pier for the map tests.

#include "vog/map/vog_map.hpp"

#include "synthetic_scene.hpp"

#include <random>

namespace vog::map::test_fixtures {

struct BuiltSubmap {
  std::shared_ptr<const LocalGrid> grid;
  geometry::Pose3 T_world_submap;  // true base pose
};

// Scans along an orbit split into submaps of `scans_per_submap`, inserted at their true poses.
inline std::vector<BuiltSubmap> buildSubmaps(const GridConfig& config, int n_submaps, int scans_per_submap,
                                             std::uint64_t seed, double max_range_m = 5.0) {
  const auto scene = vog::test::SyntheticScene::pier();
  geometry::SonarFan fan;
  fan.max_range_m = max_range_m;
  std::mt19937_64 rng(seed);
  const auto poses = vog::test::orbitTrajectory(n_submaps * scans_per_submap, 5.5, -2.0);
  std::vector<BuiltSubmap> out;
  for (int s = 0; s < n_submaps; ++s) {
    auto grid = LocalGrid::create(config).value();
    const geometry::Pose3 T_world_base = poses[static_cast<std::size_t>(s * scans_per_submap)];
    for (int k = 0; k < scans_per_submap; ++k) {
      const geometry::Pose3& T = poses[static_cast<std::size_t>(s * scans_per_submap + k)];
      (void)grid->insertScan(T_world_base.inverse() * T * fan.T_vehicle_sensor, fan, scene.scan(T, fan, 0.01, rng));
    }
    grid->finalize();
    out.push_back({std::shared_ptr<const LocalGrid>(std::move(grid)), T_world_base});
  }
  return out;
}

// A pose perturbed by up to `t_m` and `r_rad` on every axis (general rotations, not just yaw).
inline geometry::Pose3 perturb(const geometry::Pose3& T, double t_m, double r_rad, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return T * geometry::poseFromXyzRpy(t_m * u(rng), t_m * u(rng), t_m * u(rng), r_rad * u(rng), r_rad * u(rng),
                                      r_rad * u(rng));
}

}  // namespace vog::map::test_fixtures
