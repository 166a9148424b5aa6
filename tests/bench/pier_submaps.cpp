#include "pier_submaps.hpp"

#include "synthetic_scene.hpp"
#include "vog/map/local_grid.hpp"

#include <random>
#include <thread>

namespace vog::bench {

std::vector<map::SubmapEntry> buildPierSubmaps(const map::GridConfig& config, int submaps, int scans_per_submap,
                                               int threads, std::uint64_t seed) {
  const auto scene = test::SyntheticScene::pier();
  geometry::SonarFan fan;
  fan.max_range_m = 5.6;
  const auto poses = test::orbitTrajectory(submaps * scans_per_submap, 5.5, -2.0);
  std::vector<map::SubmapEntry> entries(static_cast<std::size_t>(submaps));
  // Building is embarrassingly parallel across submaps; each submap draws noise from its own seed.
  auto work = [&](int first, int step) {
    for (int s = first; s < submaps; s += step) {
      std::mt19937_64 rng(seed * 1000003u + static_cast<std::uint64_t>(s));
      auto grid = map::LocalGrid::create(config).value();
      const auto base = static_cast<std::size_t>(s * scans_per_submap);
      const geometry::Pose3 T_base_world = poses[base].inverse();
      for (int k = 0; k < scans_per_submap; ++k) {
        const geometry::Pose3& T = poses[base + static_cast<std::size_t>(k)];
        (void)grid->insertScan(T_base_world * T * fan.T_vehicle_sensor, fan, scene.scan(T, fan, 0.01, rng));
      }
      grid->finalize();
      auto& e = entries[static_cast<std::size_t>(s)];
      e.id = static_cast<map::SubmapId>(s);
      e.grid = std::move(grid);
      e.T_world_submap = poses[base];
      e.T_submap_world = T_base_world;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work, t, threads);
  for (auto& t : pool) t.join();
  return entries;
}

}  // namespace vog::bench
