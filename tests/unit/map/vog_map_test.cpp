#include "vog/map/vog_map.hpp"

#include "map_fixtures.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <fstream>

#include <limits>

namespace vog::map {
namespace {

using geometry::poseFromXyzRpy;

std::shared_ptr<const LocalGrid> singleHitGrid(const Eigen::Vector3d& hit, int repeats = 1) {
  auto grid = LocalGrid::create(GridConfig{}).value();
  const std::vector<BeamEnd> beams = {{hit, true}};
  for (int i = 0; i < repeats; ++i) EXPECT_TRUE(grid->insertRays(Eigen::Vector3d::Zero(), beams).ok());
  grid->finalize();
  return grid;
}

TEST(VogMap, EmptyMapKnowsNothing) {
  auto map = VogMap::create(GridConfig{}).value();
  EXPECT_EQ(map->query({0, 0, 0}).status, Occupancy::kUnknown);
  EXPECT_TRUE(map->lineQuery({0, 0, 0}, {1, 0, 0}).size() == 11);
  EXPECT_FALSE(map->castRay({0, 0, 0}, {1, 0, 0}).hit);
}

TEST(VogMap, QueryTransformsIntoRotatedAndTranslatedSubmaps) {
  auto map = VogMap::create(GridConfig{}).value();
  auto grid = singleHitGrid({1.0, 0.0, 0.0});
  const auto T = poseFromXyzRpy(3.0, -2.0, 1.0, 0.1, -0.2, 1.3);
  ASSERT_TRUE(map->addSubmap(7, grid, T).ok());
  const Eigen::Vector3d hit_world = T * Eigen::Vector3d(1.0, 0.0, 0.0);
  const VoxelValue v = map->query(hit_world);
  EXPECT_EQ(v.status, Occupancy::kOccupied);
  EXPECT_NEAR(v.log_odds, logOdds(0.7), 1e-6);
  EXPECT_EQ(map->query(T * Eigen::Vector3d(0.5, 0.0, 0.0)).status, Occupancy::kFree);
  // The same local point without the pose is unknown: the query really transforms.
  EXPECT_EQ(map->query({1.0, 0.0, 0.0}).status, Occupancy::kUnknown);
  EXPECT_EQ(map->query({100.0, 0.0, 0.0}).status, Occupancy::kUnknown);
  EXPECT_EQ(map->query({std::numeric_limits<double>::quiet_NaN(), 0, 0}).status, Occupancy::kUnknown);
}

TEST(VogMap, SumsOnlySubmapsThatKnowThePointAndClamps) {
  auto map = VogMap::create(GridConfig{}).value();
  ASSERT_TRUE(map->addSubmap(1, singleHitGrid({1.0, 0.0, 0.0}), geometry::Pose3::Identity()).ok());
  ASSERT_TRUE(map->addSubmap(2, singleHitGrid({1.0, 0.0, 0.0}), geometry::Pose3::Identity()).ok());
  // A third submap elsewhere must not contribute (it does not know the point).
  ASSERT_TRUE(map->addSubmap(3, singleHitGrid({1.0, 0.0, 0.0}), poseFromXyzRpy(0, 10, 0, 0, 0, 0)).ok());
  EXPECT_NEAR(map->query({1.0, 0.0, 0.0}).log_odds, 2 * logOdds(0.7), 1e-6);
  for (SubmapId id = 4; id < 10; ++id) {
    ASSERT_TRUE(map->addSubmap(id, singleHitGrid({1.0, 0.0, 0.0}, 5), geometry::Pose3::Identity()).ok());
  }
  EXPECT_NEAR(map->query({1.0, 0.0, 0.0}).log_odds, GridConfig{}.bounds().max, 1e-9);
}

TEST(VogMap, DeformMovesTheMapAndRejectsBadPoseLists) {
  auto map = VogMap::create(GridConfig{}).value();
  ASSERT_TRUE(map->addSubmap(1, singleHitGrid({1.0, 0.0, 0.0}), geometry::Pose3::Identity()).ok());
  ASSERT_TRUE(map->addSubmap(2, singleHitGrid({1.0, 0.0, 0.0}), poseFromXyzRpy(0, 5, 0, 0, 0, 0)).ok());
  const auto before = map->poses();

  EXPECT_FALSE(map->deform({geometry::Pose3::Identity()}).ok());  // wrong length
  geometry::Pose3 nan_pose = geometry::Pose3::Identity();
  nan_pose.linear()(1, 1) = std::numeric_limits<double>::quiet_NaN();
  const Status bad = map->deform({geometry::Pose3::Identity(), nan_pose});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("pose 1"), std::string::npos);
  EXPECT_TRUE(map->poses()[1].isApprox(before[1], 0.0));

  const auto moved = poseFromXyzRpy(2, 0, 0, 0, 0, std::numbers::pi / 2);
  ASSERT_TRUE(map->deform({moved, before[1]}).ok());
  EXPECT_EQ(map->query({1.0, 0.0, 0.0}).status, Occupancy::kUnknown);
  EXPECT_EQ(map->query(moved * Eigen::Vector3d(1.0, 0.0, 0.0)).status, Occupancy::kOccupied);
}

TEST(VogMap, AddRejectsMismatchedDuplicateUnfinalizedAndInvalid) {
  auto map = VogMap::create(GridConfig{}).value();
  ASSERT_TRUE(map->addSubmap(1, singleHitGrid({1, 0, 0}), geometry::Pose3::Identity()).ok());
  EXPECT_FALSE(map->addSubmap(1, singleHitGrid({1, 0, 0}), geometry::Pose3::Identity()).ok());
  GridConfig coarse;
  coarse.resolution_m = 0.2;
  coarse.cloud_voxel_m = 0.4;
  auto other = LocalGrid::create(coarse).value();
  other->finalize();
  const Status mismatch = map->addSubmap(2, std::move(other), geometry::Pose3::Identity());
  ASSERT_FALSE(mismatch.ok());
  EXPECT_NE(mismatch.error().message.find("resolution"), std::string::npos);
  auto open = LocalGrid::create(GridConfig{}).value();
  EXPECT_FALSE(map->addSubmap(3, std::move(open), geometry::Pose3::Identity()).ok());
  geometry::Pose3 inf_pose = geometry::Pose3::Identity();
  inf_pose.translation().z() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(map->addSubmap(4, singleHitGrid({1, 0, 0}), inf_pose).ok());
  EXPECT_FALSE(map->addSubmap(5, nullptr, geometry::Pose3::Identity()).ok());
  EXPECT_EQ(map->size(), 1u);
  GridConfig zero;
  zero.resolution_m = 0.0;
  EXPECT_FALSE(VogMap::create(zero).ok());
}

class VogMapOnPier : public ::testing::Test {
 protected:
  void SetUp() override {
    map_ = VogMap::create(GridConfig{}).value();
    std::mt19937_64 rng(11);
    int id = 0;
    for (const auto& s : test_fixtures::buildSubmaps(GridConfig{}, 6, 25, 5)) {
      ASSERT_TRUE(map_->addSubmap(static_cast<SubmapId>(id++), s.grid,
                                  test_fixtures::perturb(s.T_world_submap, 0.05, 0.02, rng))
                      .ok());
    }
  }
  std::unique_ptr<VogMap> map_;
};

// Alg. 5's pre-selection is an optimisation only: every sample equals the point query there.
TEST_F(VogMapOnPier, LineQueryEqualsPointQueriesAlongTheLine) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-7.0, 7.0);
  std::uniform_real_distribution<double> uz(-4.5, 0.5);
  int known = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d a(u(rng), u(rng), uz(rng));
    const Eigen::Vector3d b(u(rng), u(rng), uz(rng));
    const auto samples = map_->lineQuery(a, b);
    ASSERT_EQ(samples.size(), static_cast<std::size_t>(std::floor((b - a).norm() / 0.095)) + 1);
    for (const auto& s : samples) {
      const VoxelValue v = map_->query(s.point_world);
      ASSERT_EQ(v.status, s.value.status);
      ASSERT_DOUBLE_EQ(v.log_odds, s.value.log_odds);
      known += v.status != Occupancy::kUnknown;
    }
  }
  EXPECT_GT(known, 1000);
}

// Rays from each submap's origin through points of its occupied cloud, a little past them.
std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> raysTowardsSurfaces(const std::vector<SubmapEntry>& entries) {
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rays;
  for (const auto& e : entries) {
    const auto& pts = e.grid->cloud().points;
    for (std::size_t i = 0; i < pts.size(); i += std::max<std::size_t>(1, pts.size() / 10)) {
      const Eigen::Vector3d o = e.T_world_submap.translation();
      const Eigen::Vector3d p = e.T_world_submap * pts[i];
      rays.emplace_back(o, p + 0.5 * (p - o).normalized());
    }
  }
  return rays;
}

TEST_F(VogMapOnPier, CastRayStopsAtTheFirstOccupiedSample) {
  int hits = 0;
  for (const auto& [origin, end] : raysTowardsSurfaces(map_->entries())) {
    const CastResult r = map_->castRay(origin, end);
    const auto samples = map_->lineQuery(origin, end);
    int first = -1;
    for (std::size_t k = 0; k < samples.size(); ++k) {
      if (samples[k].value.status == Occupancy::kOccupied) {
        first = static_cast<int>(k);
        break;
      }
    }
    EXPECT_EQ(r.hit, first >= 0);
    if (first >= 0) {
      ++hits;
      EXPECT_TRUE(r.hit_world.isApprox(samples[static_cast<std::size_t>(first)].point_world));
      EXPECT_EQ(r.n_free + r.n_unknown, first);
    }
  }
  EXPECT_GT(hits, 30);
}

TEST_F(VogMapOnPier, SaveAndLoadRoundTrip) {
  test::TempDir dir;
  ASSERT_TRUE(map_->save(dir.path()).ok());
  auto loaded = VogMap::load(dir.path());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  ASSERT_EQ((*loaded)->size(), map_->size());
  const auto a = map_->entries();
  const auto b = (*loaded)->entries();
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].id, b[i].id);
    EXPECT_TRUE(a[i].T_world_submap.isApprox(b[i].T_world_submap, 1e-12));
    EXPECT_EQ(a[i].grid->leafCount(), b[i].grid->leafCount());
  }
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-7.0, 7.0);
  int agree = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), -2.0 + 0.3 * u(rng));
    agree += map_->query(p).status == (*loaded)->query(p).status;
  }
  EXPECT_GE(agree, 1995);  // poses round-trip through quaternions (1e-16 rounding)
}

TEST(VogMapLoad, ReportsMissingAndMalformedFiles) {
  test::TempDir dir;
  auto missing = VogMap::load(dir.path());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("grid.txt"), std::string::npos);
  auto map = VogMap::create(GridConfig{}).value();
  ASSERT_TRUE(map->save(dir.path()).ok());
  {
    std::ofstream poses(dir.path() / "poses.txt", std::ios::app);
    poses << "3 1 2 3 0 0 0\n";
  }
  auto malformed = VogMap::load(dir.path());
  ASSERT_FALSE(malformed.ok());
  EXPECT_NE(malformed.error().message.find("poses.txt:2"), std::string::npos);
}

TEST(SegmentIntersectsBox, SlabTest) {
  const Eigen::AlignedBox3d box(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1));
  EXPECT_TRUE(segmentIntersectsBox({-1, 0.5, 0.5}, {2, 0.5, 0.5}, box));
  EXPECT_TRUE(segmentIntersectsBox({0.5, 0.5, 0.5}, {0.6, 0.6, 0.6}, box));
  EXPECT_FALSE(segmentIntersectsBox({-1, 0.5, 0.5}, {-0.1, 0.5, 0.5}, box));
  EXPECT_FALSE(segmentIntersectsBox({-1, 2, 0.5}, {2, 2, 0.5}, box));
  EXPECT_FALSE(segmentIntersectsBox({-1, -1, 0}, {-0.1, 3, 0}, box));
  EXPECT_TRUE(segmentIntersectsBox({-1, -1, 0.5}, {2, 2, 0.5}, box));
}

}  // namespace
}  // namespace vog::map
