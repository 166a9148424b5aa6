// Loop-closure candidate gate (thesis Alg. 6 lines 4-8) and the Mahalanobis gate.
#include "vog/slam/loop_candidates.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <numbers>
#include <random>

namespace vog::slam {
namespace {

SubmapFootprint footprint(std::int64_t index, const geometry::Pose3& T_world_submap) {
  SubmapFootprint s;
  s.index = index;
  s.T_world_submap = T_world_submap;
  s.aabb_min_submap = Eigen::Vector3d(2, -3, -4);  // cloud ahead of the base pose
  s.aabb_max_submap = Eigen::Vector3d(8, 3, 0);
  s.centroid_submap = Eigen::Vector3d(5, 0, -2);
  s.n_points = 500;
  return s;
}

TEST(LoopCandidates, CentroidInsideOtherBoxUnderCurrentPoses) {
  std::vector<SubmapFootprint> maps;
  maps.push_back(footprint(0, geometry::poseFromXyzRpy(0, 0, 0, 0, 0, 0)));
  maps.push_back(footprint(1, geometry::poseFromXyzRpy(0.5, 0, 0, 0, 0, 0)));      // consecutive: skipped
  maps.push_back(footprint(2, geometry::poseFromXyzRpy(20, 0, 0, 0, 0, 0)));       // far away
  maps.push_back(footprint(3, geometry::poseFromXyzRpy(1.0, 1.0, 0, 0, 0, 0.2)));  // overlaps 0, 1
  // Seen from the far side, facing back, with its centroid near the far end of its box: the centroid
  // lands at world (1, 0), outside 0's box (x >= 2), while 0's centroid (5, 0) maps to (5, 0) in its
  // frame: inside. Either direction suffices.
  maps.push_back(footprint(5, geometry::poseFromXyzRpy(10, 0, 0, 0, 0, std::numbers::pi)));
  maps.back().centroid_submap = Eigen::Vector3d(9, 0, -2);
  auto pairs = findLoopCandidates(maps);
  ASSERT_TRUE(pairs.ok()) << pairs.error().message;
  const std::vector<std::pair<std::size_t, std::size_t>> expected{{0, 3}, {0, 4}, {1, 3}, {1, 4}, {3, 4}};
  EXPECT_EQ(*pairs, expected);
  EXPECT_FALSE(centroidInside(maps[0], maps[4]));
  EXPECT_TRUE(centroidInside(maps[4], maps[0]));

  // The same pair is not a candidate when its current pose estimate moves it away.
  maps[3].T_world_submap = geometry::poseFromXyzRpy(1.0, 9.0, 0, 0, 0, 0.2);
  auto moved = findLoopCandidates(maps);
  ASSERT_TRUE(moved.ok());
  EXPECT_EQ(std::count(moved->begin(), moved->end(), std::pair<std::size_t, std::size_t>{0, 3}), 0);

  // Too few points (Alg. 6 line 4).
  maps[4].n_points = 3;
  auto sparse = findLoopCandidates(maps);
  ASSERT_TRUE(sparse.ok());
  for (const auto& p : *sparse) EXPECT_NE(p.second, 4u);
}

TEST(LoopCandidates, BadInputNamed) {
  std::vector<SubmapFootprint> maps{footprint(0, geometry::Pose3::Identity()),
                                    footprint(7, geometry::Pose3::Identity())};
  maps[1].aabb_min_submap.x() = 9.0;  // min > max
  auto r = findLoopCandidates(maps);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("submap 7"), std::string::npos) << r.error().message;
  maps[1] = footprint(7, geometry::Pose3::Identity());
  maps[1].centroid_submap.z() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(findLoopCandidates(maps).ok());
  CandidateConfig bad;
  bad.min_index_gap = 0;
  EXPECT_FALSE(findLoopCandidates({}, bad).ok());
}

// The search for one new submap lists exactly the pairs of the all-pairs definition that involve it, in
// the same order, on random footprints (index gaps, sparse clouds, general poses), for every position.
TEST(LoopCandidates, SearchForOneSubmapEqualsAllPairsDefinition) {
  for (std::uint64_t seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::uniform_int_distribution<int> step(1, 3);
    std::uniform_int_distribution<std::size_t> points(0, 60);
    std::vector<SubmapFootprint> maps(80);
    std::int64_t index = 0;
    for (SubmapFootprint& f : maps) {
      f.index = index;
      index += step(rng);  // gaps as after a restore or a skipped submap
      f.T_world_submap = geometry::poseFromXyzRpy(12.0 * u(rng), 12.0 * u(rng), u(rng), 0.1 * u(rng), 0.1 * u(rng),
                                                  std::numbers::pi * u(rng));
      const Eigen::Vector3d lo(-1.0 + 3.0 * u(rng), -4.0 + u(rng), -3.0 + u(rng));
      f.aabb_min_submap = lo;
      f.aabb_max_submap = lo + Eigen::Vector3d(3.0 + 3.0 * std::abs(u(rng)), 4.0 + 4.0 * std::abs(u(rng)), 2.0);
      f.centroid_submap = 0.5 * (f.aabb_min_submap + f.aabb_max_submap) + Eigen::Vector3d(u(rng), u(rng), 0.0);
      f.n_points = points(rng);
    }
    CandidateConfig config;
    config.min_index_gap = 1 + static_cast<std::int64_t>(seed % 4);
    config.min_points = 20;
    const auto all = findLoopCandidates(maps, config);
    ASSERT_TRUE(all.ok());
    std::size_t found = 0;
    for (std::size_t newest = 0; newest < maps.size(); ++newest) {
      std::vector<std::size_t> expected;
      for (const auto& [i, j] : *all) {
        if (i == newest) expected.push_back(j);
        if (j == newest) expected.push_back(i);
      }
      const auto mine = findLoopCandidatesOf(maps, newest, config);
      ASSERT_TRUE(mine.ok());
      EXPECT_EQ(*mine, expected) << "seed " << seed << ", newest " << newest;
      found += mine->size();
    }
    EXPECT_EQ(found, 2 * all->size());
    EXPECT_GT(all->size(), 20u) << "seed " << seed;  // the gate passes and rejects pairs
    EXPECT_LT(all->size(), maps.size() * (maps.size() - 1) / 4) << "seed " << seed;
  }
}

TEST(LoopCandidates, SearchForOneSubmapErrorsLikeAllPairs) {
  std::vector<SubmapFootprint> maps{footprint(0, geometry::Pose3::Identity()),
                                    footprint(7, geometry::Pose3::Identity())};
  EXPECT_FALSE(findLoopCandidatesOf(maps, 2).ok());
  maps[0].aabb_min_submap.x() = 9.0;  // min > max on a submap that is not the newest
  auto r = findLoopCandidatesOf(maps, 1);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("submap 0"), std::string::npos) << r.error().message;
}

// The index's candidates of each new submap are findLoopCandidatesOf's over all earlier footprints, in
// the same order, while the earlier submaps move: by centimetres (inside the margin, as after a solve),
// by metres and turns (out of their cells), and with a few boxes wider than the cells are worth.
TEST(CandidateIndex, CandidatesOfEachNewSubmapEqualTheLinearSearchWhileSubmapsMove) {
  for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::uniform_int_distribution<std::size_t> points(0, 60);
    const auto random_footprint = [&](std::int64_t index) {
      SubmapFootprint f;
      f.index = index;
      f.T_world_submap = geometry::poseFromXyzRpy(40.0 * u(rng), 25.0 * u(rng), u(rng), 0.1 * u(rng), 0.1 * u(rng),
                                                  std::numbers::pi * u(rng));
      const Eigen::Vector3d lo(-1.0 + 3.0 * u(rng), -4.0 + u(rng), -3.0 + u(rng));
      const double wide = index % 29 == 7 ? 400.0 : 0.0;  // spans more than kMaxCellsPerAxis cells
      f.aabb_min_submap = lo;
      f.aabb_max_submap = lo + Eigen::Vector3d(3.0 + 3.0 * std::abs(u(rng)) + wide, 4.0 + 4.0 * std::abs(u(rng)), 2.0);
      f.centroid_submap = 0.5 * (f.aabb_min_submap + f.aabb_max_submap) + Eigen::Vector3d(u(rng), u(rng), 0.0);
      f.n_points = points(rng);
      return f;
    };
    CandidateConfig config;
    config.min_index_gap = 1 + static_cast<std::int64_t>(seed % 3);
    config.min_points = 20;
    auto index = CandidateIndex::create(config, 3.0, 0.5);
    ASSERT_TRUE(index.ok()) << index.error().message;
    std::vector<SubmapFootprint> all;
    std::size_t found = 0, tested_pairs = 0;
    for (std::int64_t n = 0; n < 300; ++n) {
      const SubmapFootprint newest = random_footprint(n);
      std::vector<SubmapFootprint> with_newest = all;
      with_newest.push_back(newest);
      const auto expected = findLoopCandidatesOf(with_newest, all.size(), config);
      ASSERT_TRUE(expected.ok());
      const auto mine = index->candidatesOf(newest);
      ASSERT_TRUE(mine.ok()) << mine.error().message;
      ASSERT_EQ(*mine, *expected) << "seed " << seed << ", submap " << n;
      found += mine->size();
      tested_pairs += all.size();
      ASSERT_TRUE(index->add(newest).ok());
      all.push_back(newest);
      // Every pose moves a little (a solve); a few jump.
      for (std::size_t k = 0; k < all.size(); ++k) {
        const bool jump = std::uniform_int_distribution<int>(0, 40)(rng) == 0;
        const geometry::Pose3 delta =
            jump ? geometry::poseFromXyzRpy(8.0 * u(rng), 8.0 * u(rng), 0, 0, 0, u(rng))
                 : geometry::poseFromXyzRpy(0.02 * u(rng), 0.02 * u(rng), 0, 0, 0, 0.002 * u(rng));
        all[k].T_world_submap = delta * all[k].T_world_submap;
        ASSERT_TRUE(index->setPose(k, all[k].T_world_submap).ok());
      }
      ASSERT_EQ(index->footprints().size(), all.size());
    }
    EXPECT_GT(found, 50u) << "seed " << seed;                // the gate passes pairs ...
    EXPECT_LT(found, tested_pairs / 10) << "seed " << seed;  // ... and rejects most
  }
}

TEST(CandidateIndex, BadInputNamedAndNothingChanged) {
  EXPECT_FALSE(CandidateIndex::create(CandidateConfig{}, 0.0, 1.0).ok());
  EXPECT_FALSE(CandidateIndex::create(CandidateConfig{}, 4.0, 0.0).ok());
  auto index = CandidateIndex::create(CandidateConfig{});
  ASSERT_TRUE(index.ok());
  SubmapFootprint bad = footprint(3, geometry::Pose3::Identity());
  bad.aabb_min_submap.x() = 9.0;  // min > max
  const Status s = index->add(bad);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("submap 3"), std::string::npos) << s.error().message;
  EXPECT_EQ(index->size(), 0u);
  ASSERT_TRUE(index->add(footprint(0, geometry::Pose3::Identity())).ok());
  geometry::Pose3 nan = geometry::Pose3::Identity();
  nan.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(index->setPose(0, nan).ok());
  EXPECT_TRUE(index->footprints()[0].T_world_submap.isApprox(geometry::Pose3::Identity()));
  EXPECT_FALSE(index->setPose(1, geometry::Pose3::Identity()).ok());
  EXPECT_FALSE(index->candidatesOf(bad).ok());
  const auto near = index->candidatesOf(footprint(2, geometry::poseFromXyzRpy(0.5, 0, 0, 0, 0, 0)));
  ASSERT_TRUE(near.ok());
  EXPECT_EQ(*near, std::vector<std::size_t>{0});
}

TEST(MahalanobisGate, DistanceUnderCovariance) {
  const geometry::Pose3 pred = geometry::poseFromXyzRpy(1, 2, 0, 0, 0, 3.1);
  const geometry::Pose3 reg = geometry::poseFromXyzRpy(1.2, 2, 0.5, 0, 0, -3.1);  // yaw wraps: 0.083 rad apart
  const Eigen::Matrix3d cov = Eigen::Vector3d(0.01, 0.04, 0.0025).asDiagonal();
  auto d2 = planarMahalanobisSquared(reg, pred, cov);
  ASSERT_TRUE(d2.ok());
  const double dyaw = 2 * std::numbers::pi - 6.2;
  EXPECT_NEAR(*d2, 0.04 / 0.01 + dyaw * dyaw / 0.0025, 1e-9);
  EXPECT_FALSE(planarMahalanobisSquared(reg, pred, Eigen::Matrix3d::Zero()).ok());
}

}  // namespace
}  // namespace vog::slam
