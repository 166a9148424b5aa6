// Thesis Fig. 3.3: scans inserted into one global OcTree at true poses and into a VogMap of submaps at
// their true base poses classify space almost identically; the differences come from the rotated
// submap grids sampling surfaces at other voxel boundaries.
#include "vog/map/merged_map.hpp"

#include "map_fixtures.hpp"

#include <gtest/gtest.h>

namespace vog::map {
namespace {

TEST(Fidelity, VogMapAgreesWithAGlobalGridOnAlmostEveryKnownVoxel) {
  const GridConfig config;
  const int n_submaps = 8;
  const int scans = 100;  // thesis Table 4.2: 100 scans per submap
  const auto scene = vog::test::SyntheticScene::pier();
  geometry::SonarFan fan;
  fan.max_range_m = 5.0;
  const auto poses = vog::test::orbitTrajectory(n_submaps * scans, 5.5, -2.0);

  auto global = LocalGrid::create(config).value();
  auto vog = VogMap::create(config).value();
  std::mt19937_64 rng(17);
  for (int s = 0; s < n_submaps; ++s) {
    auto grid = LocalGrid::create(config).value();
    const geometry::Pose3 T_world_base = poses[static_cast<std::size_t>(s * scans)];
    for (int k = 0; k < scans; ++k) {
      const geometry::Pose3& T = poses[static_cast<std::size_t>(s * scans + k)];
      const auto scan = scene.scan(T, fan, 0.01, rng);
      ASSERT_TRUE(global->insertScan(T * fan.T_vehicle_sensor, fan, scan).ok());
      ASSERT_TRUE(grid->insertScan(T_world_base.inverse() * T * fan.T_vehicle_sensor, fan, scan).ok());
    }
    grid->finalize();
    ASSERT_TRUE(vog->addSubmap(static_cast<SubmapId>(s), std::move(grid), T_world_base).ok());
  }
  global->finalize();
  auto merged = MergedMap::create(config).value();
  ASSERT_TRUE(merged->sync(vog->entries(), MergeConfig{}).ok());

  std::size_t known = 0;
  std::size_t differ_sequential = 0;
  std::size_t differ_merged = 0;
  std::size_t confusion[3][3] = {};
  for (const auto& leaf : global->leaves()) {
    const Occupancy truth = config.bounds().classify(leaf.log_odds);
    for (int x = leaf.min.x(); x <= leaf.max.x(); ++x)
      for (int y = leaf.min.y(); y <= leaf.max.y(); ++y)
        for (int z = leaf.min.z(); z <= leaf.max.z(); ++z) {
          const VoxelKey k(x, y, z);
          ++known;
          const auto got = vog->query(keyToCentre(k, config.resolution_m)).status;
          differ_sequential += got != truth;
          if (got != truth) ++confusion[static_cast<int>(truth)][static_cast<int>(got)];
          differ_merged += merged->at(k).status != truth;
        }
  }
  const double share_seq = static_cast<double>(differ_sequential) / static_cast<double>(known);
  const double share_merged = static_cast<double>(differ_merged) / static_cast<double>(known);
  RecordProperty("known_voxels", static_cast<int>(known));
  RecordProperty("misclassified_sequential_ppm", static_cast<int>(share_seq * 1e6));
  EXPECT_GT(known, 50000u);
  // Almost all differences are free voxels at the fringe of known space that a ray only clipped in
  // the global grid, whose centre no rotated submap voxel covers (free -> unknown).
  EXPECT_LT(share_seq, 0.02) << differ_sequential << " of " << known << "; free->unknown " << confusion[1][0]
                             << ", free->occupied " << confusion[1][2] << ", occupied->unknown " << confusion[2][0]
                             << ", occupied->free " << confusion[2][1];
  EXPECT_LT(share_merged, 0.02) << differ_merged << " of " << known;
  // At voxel centres merged and sequential are the same query.
  EXPECT_EQ(differ_merged, differ_sequential);
}

}  // namespace
}  // namespace vog::map
