#include "vog/map/local_grid.hpp"

#include "synthetic_scene.hpp"
#include "small_tmpfs.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace vog::map {
namespace {

using geometry::poseFromXyzRpy;

std::unique_ptr<LocalGrid> makeGrid(GridConfig config = {}) {
  auto grid = LocalGrid::create(config);
  EXPECT_TRUE(grid.ok());
  return std::move(grid).value();
}

TEST(LocalGrid, RayMarksFreeUpToTheHitAndTheHitOccupied) {
  auto grid = makeGrid();
  const double res = grid->resolution();
  const std::vector<BeamEnd> beams = {{Eigen::Vector3d(2.0, 0.01, 0.01), true}};
  ASSERT_TRUE(grid->insertRays(Eigen::Vector3d(0.01, 0.01, 0.01), beams).ok());
  const double hit = logOdds(0.7);
  const double miss = logOdds(0.4);
  ASSERT_TRUE(grid->logOdds({2.0, 0.01, 0.01}).has_value());
  EXPECT_NEAR(*grid->logOdds({2.0, 0.01, 0.01}), hit, 1e-6);
  for (double x = 0.05; x < 2.0 - res; x += res) EXPECT_NEAR(*grid->logOdds({x, 0.01, 0.01}), miss, 1e-6) << x;
  EXPECT_FALSE(grid->logOdds({2.0 + 2 * res, 0.01, 0.01}).has_value());  // behind the hit: unknown
  EXPECT_FALSE(grid->logOdds({0.01, 1.0, 0.01}).has_value());
}

TEST(LocalGrid, NoReturnMarksFreeSpaceUpToMaxRange) {
  GridConfig config;
  config.max_range_m = 3.0;
  auto grid = makeGrid(config);
  geometry::SonarFan fan;
  fan.T_vehicle_sensor = geometry::Pose3::Identity();
  geometry::RangeScan scan;
  scan.range_m.assign(96, geometry::RangeScan::kNoReturn);
  ASSERT_TRUE(grid->insertScan(geometry::Pose3::Identity(), fan, scan).ok());
  const Eigen::Vector3d dir = fan.beamDirection(48);
  EXPECT_LT(*grid->logOdds(2.8 * dir), 0.0f);
  EXPECT_FALSE(grid->logOdds(3.3 * dir).has_value());
  // A return beyond max_range is treated as no return: nothing occupied.
  scan.range_m.assign(96, 5.0f);
  ASSERT_TRUE(grid->insertScan(geometry::Pose3::Identity(), fan, scan).ok());
  EXPECT_FALSE(grid->logOdds(5.0 * dir).has_value());
}

TEST(LocalGrid, RepeatedHitsClampAtTheUpperBound) {
  auto grid = makeGrid();
  const std::vector<BeamEnd> beams = {{Eigen::Vector3d(1.0, 0.0, 0.0), true}};
  for (int i = 0; i < 40; ++i) ASSERT_TRUE(grid->insertRays(Eigen::Vector3d::Zero(), beams).ok());
  EXPECT_NEAR(*grid->logOdds({1.0, 0.0, 0.0}), grid->config().bounds().max, 1e-5);
  EXPECT_NEAR(*grid->logOdds({0.5, 0.0, 0.0}), grid->config().bounds().min, 1e-5);
}

// Every reader of a voxel (merged map, sequential query, traversability, deltas) clamps through these
// bounds: values inside pass unchanged, values beyond stop at the bound, and NaN reads as the upper
// bound rather than travelling on.
TEST(LogOddsBounds, ClampKeepsInsideValuesStopsAtTheBoundsAndSendsNaNToTheUpperBound) {
  const LogOddsBounds b = GridConfig{}.bounds();
  ASSERT_LT(b.min, 0.0);
  ASSERT_GT(b.max, 0.0);
  EXPECT_EQ(b.clamp(0.25), 0.25);
  EXPECT_EQ(b.clamp(b.min), b.min);
  EXPECT_EQ(b.clamp(b.max), b.max);
  EXPECT_EQ(b.clamp(b.max + 1.0), b.max);
  EXPECT_EQ(b.clamp(b.min - 1.0), b.min);
  EXPECT_EQ(b.clamp(std::numeric_limits<double>::infinity()), b.max);
  EXPECT_EQ(b.clamp(-std::numeric_limits<double>::infinity()), b.min);
  EXPECT_EQ(b.clamp(std::numeric_limits<double>::quiet_NaN()), b.max);
  EXPECT_EQ(b.classify(b.clamp(std::numeric_limits<double>::quiet_NaN())), Occupancy::kOccupied);
  EXPECT_EQ(b.classify(b.occupied), Occupancy::kFree);  // occupied only above the threshold
}

TEST(LocalGrid, FinalizedGridIsImmutable) {
  auto grid = makeGrid();
  const std::vector<BeamEnd> beams = {{Eigen::Vector3d(1.0, 0.0, 0.0), true}};
  ASSERT_TRUE(grid->insertRays(Eigen::Vector3d::Zero(), beams).ok());
  grid->finalize();
  const auto size = grid->leafCount();
  const Status s = grid->insertRays(Eigen::Vector3d::Zero(), beams);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("finalized"), std::string::npos);
  EXPECT_EQ(grid->leafCount(), size);
}

TEST(LocalGrid, BadInputIsRejectedAndChangesNothing) {
  auto grid = makeGrid();
  geometry::SonarFan fan;
  geometry::RangeScan scan;
  scan.range_m.assign(96, 2.0f);
  ASSERT_TRUE(grid->insertScan(geometry::Pose3::Identity(), fan, scan).ok());
  const auto size = grid->tree().size();
  const auto scans = grid->scanCount();

  geometry::RangeScan nan_scan = scan;
  nan_scan.range_m[10] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(grid->insertScan(geometry::Pose3::Identity(), fan, nan_scan).ok());
  geometry::RangeScan negative = scan;
  negative.range_m[3] = -1.0f;
  EXPECT_FALSE(grid->insertScan(geometry::Pose3::Identity(), fan, negative).ok());
  geometry::RangeScan short_scan = scan;
  short_scan.range_m.resize(95);
  const Status wrong = grid->insertScan(geometry::Pose3::Identity(), fan, short_scan);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("95"), std::string::npos);
  geometry::Pose3 nan_pose = geometry::Pose3::Identity();
  nan_pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(grid->insertScan(nan_pose, fan, scan).ok());
  const std::vector<BeamEnd> inf_end = {{Eigen::Vector3d(1.0, std::numeric_limits<double>::infinity(), 0.0), true}};
  EXPECT_FALSE(grid->insertRays(Eigen::Vector3d::Zero(), inf_end).ok());

  EXPECT_EQ(grid->tree().size(), size);
  EXPECT_EQ(grid->scanCount(), scans);
}

TEST(LocalGrid, BadConfigIsRejectedWithTheKey) {
  GridConfig config;
  config.resolution_m = 0.0;
  auto zero = LocalGrid::create(config);
  ASSERT_FALSE(zero.ok());
  EXPECT_NE(zero.error().message.find("resolution_m"), std::string::npos);
  config.resolution_m = -0.1;
  EXPECT_FALSE(LocalGrid::create(config).ok());
  config = GridConfig{};
  config.prob_hit = 0.4;
  auto hit = LocalGrid::create(config);
  ASSERT_FALSE(hit.ok());
  EXPECT_NE(hit.error().message.find("prob_hit"), std::string::npos);
}

// Leaves partition the known space exactly: expanding every leaf reproduces the tree's lookups.
TEST(LocalGrid, LeavesCoverExactlyTheKnownVoxels) {
  auto grid = makeGrid();
  const auto scene = test::SyntheticScene::pier();
  geometry::SonarFan fan;
  fan.max_range_m = 5.0;
  std::mt19937_64 rng(3);
  const auto poses = test::orbitTrajectory(60, 5.0, -2.0);
  for (const auto& T : poses) {
    ASSERT_TRUE(
        grid->insertScan(poses.front().inverse() * T * fan.T_vehicle_sensor, fan, scene.scan(T, fan, 0.0, rng)).ok());
  }
  grid->finalize();
  std::size_t voxels = 0;
  for (const auto& leaf : grid->leaves()) {
    for (int x = leaf.min.x(); x <= leaf.max.x(); ++x)
      for (int y = leaf.min.y(); y <= leaf.max.y(); ++y)
        for (int z = leaf.min.z(); z <= leaf.max.z(); ++z) {
          const auto l = grid->logOddsAt({x, y, z});
          ASSERT_TRUE(l.has_value());
          ASSERT_EQ(*l, leaf.log_odds);
          EXPECT_TRUE(grid->knownKeys().contains({x, y, z}));
          ++voxels;
        }
  }
  EXPECT_GT(voxels, 1000u);
  // And one voxel outside the known box is unknown.
  EXPECT_FALSE(grid->logOddsAt(grid->knownKeys().max + VoxelKey(1, 0, 0)).has_value());
}

TEST(LocalGrid, EveryNormalFacesTheNearestOfManySensorOrigins) {
  // Two parallel walls 1 m apart, each hit by single rays from its own side (x = -2.5 and x = +2.5,
  // 400 origins): every normal faces the origin nearest its point, found here by brute force.
  auto grid = makeGrid();
  std::vector<Eigen::Vector3d> origins;
  for (int side = -1; side <= 1; side += 2)
    for (int i = 0; i < 200; ++i) {
      const double y = -2.0 + 0.2 * (i % 20);
      const double z = -2.0 + 0.2 * (i / 20) + 0.013 * side;
      const Eigen::Vector3d origin(2.5 * side, y + 0.007 * i, z);
      const BeamEnd beam{Eigen::Vector3d(0.5 * side, y, z), true};
      ASSERT_TRUE(grid->insertRays(origin, {&beam, 1}).ok());
      origins.push_back(origin);
    }
  grid->finalize();
  const auto& cloud = grid->cloud();
  ASSERT_GT(cloud.size(), 50u);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    const Eigen::Vector3d nearest =
        *std::min_element(origins.begin(), origins.end(),
                          [&](const auto& a, const auto& b) { return (a - p).squaredNorm() < (b - p).squaredNorm(); });
    EXPECT_GT(cloud.normals[i].dot(nearest - p), 0.0) << p.transpose();
    EXPECT_GT(std::abs(cloud.normals[i].x()), 0.9) << p.transpose();  // the walls' normal is along x
  }
}

TEST(LocalGrid, CloudLiesOnTheSurfaceWithNormalsTowardsTheSensor) {
  // A flat seabed 3 m below a sonar looking down: the cloud is the plane z = -3, normals +z.
  auto grid = makeGrid();
  test::SyntheticScene scene;
  scene.planes.push_back({-3.0});
  geometry::SonarFan fan;
  fan.T_vehicle_sensor = poseFromXyzRpy(0, 0, 0, 0, geometry::deg2rad(90), 0);  // looking down, fan across x
  std::mt19937_64 rng(1);
  for (int k = 0; k < 40; ++k) {
    const auto T = poseFromXyzRpy(0.05 * k, 0.0, 0.0, 0, 0, 0);
    ASSERT_TRUE(grid->insertScan(T * fan.T_vehicle_sensor, fan, scene.scan(T, fan, 0.0, rng)).ok());
  }
  grid->finalize();
  const auto& cloud = grid->cloud();
  ASSERT_GT(cloud.size(), 20u);
  ASSERT_TRUE(cloud.hasNormals());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_NEAR(cloud.points[i].z(), -3.0, grid->resolution());
    EXPECT_GT(cloud.normals[i].z(), 0.9) << i;
  }
  const auto box = grid->knownBox();
  EXPECT_LE(box.min().z(), -3.0);
  EXPECT_GE(box.max().z(), 0.0);
}

TEST(LocalGrid, SaveAndLoadKeepEveryLeaf) {
  auto grid = makeGrid();
  const std::vector<BeamEnd> beams = {{Eigen::Vector3d(1.0, 0.5, 0.2), true}, {Eigen::Vector3d(-1.0, 2.0, 0.0), false}};
  ASSERT_TRUE(grid->insertRays(Eigen::Vector3d::Zero(), beams).ok());
  grid->finalize();
  test::TempDir dir;
  ASSERT_TRUE(grid->save(dir.path() / "g.ot").ok());
  auto loaded = LocalGrid::load(GridConfig{}, dir.path() / "g.ot");
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  const auto a = grid->leaves();
  const auto b = (*loaded)->leaves();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].min, b[i].min);
    EXPECT_EQ(a[i].log_odds, b[i].log_odds);
  }
  GridConfig other;
  other.resolution_m = 0.2;
  EXPECT_FALSE(LocalGrid::load(other, dir.path() / "g.ot").ok());
  EXPECT_FALSE(LocalGrid::load(GridConfig{}, dir.path() / "missing.ot").ok());
}

// OctoMap's own writer reports success on a full disk; save() must not: an error naming the cause,
// and no file under the name.
TEST(LocalGrid, SaveOnAFullDiskIsAnErrorAndLeavesNoFile) {
  test::SmallTmpfs disk(256 * 1024);
  if (!disk.mounted()) GTEST_SKIP() << "needs a tmpfs to fill: " << disk.error();
  auto grid = makeGrid();
  const std::vector<BeamEnd> beams = {{Eigen::Vector3d(1.0, 0.5, 0.2), true}, {Eigen::Vector3d(-1.0, 2.0, 0.0), false}};
  ASSERT_TRUE(grid->insertRays(Eigen::Vector3d::Zero(), beams).ok());
  grid->finalize();
  ASSERT_TRUE(disk.fill());
  const Status saved = grid->save(disk.path() / "g.ot");
  ASSERT_FALSE(saved.ok()) << "a save on a full disk reported success";
  EXPECT_NE(saved.error().message.find("No space left on device"), std::string::npos) << saved.error().message;
  EXPECT_FALSE(std::filesystem::exists(disk.path() / "g.ot"));
  disk.release();
  ASSERT_TRUE(grid->save(disk.path() / "g.ot").ok());
  auto loaded = LocalGrid::load(GridConfig{}, disk.path() / "g.ot");
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ((*loaded)->leaves().size(), grid->leaves().size());
}

}  // namespace
}  // namespace vog::map
