// LoopCloser on two submaps of the same stretch of the pier (independent sonar noise), the second with
// a perturbed estimate: both modes recover the true relative pose (identity) and accept it; bad input
// is an error.
#include "synthetic_scene.hpp"
#include "vog/slam/loop_closer.hpp"
#include "vog/slam/pose_vector.hpp"

#include <gtest/gtest.h>

#include <random>
#include <tuple>

namespace vog::slam {
namespace {

using geometry::deg2rad;

std::shared_ptr<const map::LocalGrid> gridOf(const std::vector<geometry::Pose3>& poses, std::uint64_t seed) {
  const test::SyntheticScene scene = test::SyntheticScene::pier();
  const geometry::SonarFan fan;
  map::GridConfig gc;
  gc.resolution_m = 0.1;
  auto grid = map::LocalGrid::create(gc);
  EXPECT_TRUE(grid.ok());
  std::mt19937_64 rng(seed);
  for (const geometry::Pose3& T : poses) {
    const auto scan = scene.scan(T, fan, 0.02, rng);
    EXPECT_TRUE((*grid)->insertScan(poses.front().inverse() * T * fan.T_vehicle_sensor, fan, scan).ok());
  }
  (*grid)->finalize();
  return std::shared_ptr<const map::LocalGrid>(std::move(grid.value()));
}

class LoopCloserTest : public ::testing::TestWithParam<LoopClosureMode> {};

TEST_P(LoopCloserTest, RecoversTheRelativePoseOfARevisit) {
  const auto orbit = test::orbitTrajectory(80, 5.5, -2.0);
  const std::vector<geometry::Pose3> stretch(orbit.begin(), orbit.begin() + 80);
  const geometry::Pose3 T_err = geometry::poseFromXyzRpy(0.25, -0.2, 0.0, 0.0, 0.0, deg2rad(2.0));
  std::vector<LoopSubmap> submaps = {
      {0, gridOf(stretch, 1), stretch.front(), 0},
      {5, gridOf(stretch, 2), stretch.front() * T_err, 200'000'000'000},  // 200 s later
  };
  LoopCloserConfig c;
  c.mode = GetParam();
  c.p2p.max_correspondence_distance_m = 0.5;
  c.point_to_plane.max_correspondence_distance_m = 0.5;
  auto closer = LoopCloser::create(c);
  ASSERT_TRUE(closer.ok());
  auto out = closer->closeLoops(submaps, 1);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->stats.tried, 1);
  ASSERT_EQ(out->stats.accepted, 1);
  ASSERT_EQ(out->closures.size(), 1U);
  const LoopClosure& lc = out->closures.front();
  EXPECT_EQ(lc.from, 0);
  EXPECT_EQ(lc.to, 5);
  EXPECT_TRUE(lc.T_from_to_prior.isApprox(T_err, 1e-9));
  // Truth is the identity; compare within the constrained subspace (all of x, y, yaw for p2p).
  const Vector6d e = toXyzRpy(lc.T_from_to);
  const Vector6d e_u = lc.factor.V_u.transpose() * (lc.factor.V_u * e);
  EXPECT_LT(e_u.head<3>().norm(), 0.05);
  // The degeneracy-aware ICP stops stepping along directions that become ill-conditioned near the
  // optimum, which leaves a slightly larger residual rotation than the 2D point-to-point baseline.
  const double max_rot_deg = GetParam() == LoopClosureMode::kPointToPoint2d ? 0.5 : 1.0;
  EXPECT_LT(e_u.tail<3>().norm(), deg2rad(max_rot_deg));
  if (GetParam() == LoopClosureMode::kPointToPoint2d) {
    EXPECT_EQ(lc.factor.rank(), 3);
    EXPECT_LT(lc.T_from_to.translation().head<2>().norm(), 0.05);
  }
}

INSTANTIATE_TEST_SUITE_P(Modes, LoopCloserTest,
                         ::testing::Values(LoopClosureMode::kPointToPoint2d, LoopClosureMode::kDegenerate));

// A registration may turn the prior by at most max_yaw_disagreement_rad: the same revisit, its prior
// 1 deg off in yaw, is accepted with a 1.5 deg bound and refused with 0.5 deg, the reason counted.
TEST(LoopCloser, ARegistrationThatTurnsThePriorTooMuchIsRefused) {
  const auto orbit = test::orbitTrajectory(80, 5.5, -2.0);
  const geometry::Pose3 T_err = geometry::poseFromXyzRpy(0.1, -0.1, 0.0, 0.0, 0.0, deg2rad(1.0));
  const std::vector<LoopSubmap> submaps = {
      {0, gridOf(orbit, 1), orbit.front(), 0},
      {5, gridOf(orbit, 2), orbit.front() * T_err, 200'000'000'000},
  };
  for (const double bound_deg : {1.5, 0.5}) {
    LoopCloserConfig c;
    c.point_to_plane.max_correspondence_distance_m = 0.5;
    c.max_yaw_disagreement_rad = deg2rad(bound_deg);
    auto closer = LoopCloser::create(c);
    ASSERT_TRUE(closer.ok());
    auto out = closer->closeLoops(submaps, 1);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_EQ(out->stats.tried, 1);
    const bool accepted = bound_deg > 1.0;
    EXPECT_EQ(out->stats.accepted, accepted ? 1 : 0) << bound_deg << " deg";
    EXPECT_EQ(out->stats.rejected_by_reason.count("yaw_disagreement"), accepted ? 0U : 1U) << bound_deg << " deg";
  }
}

// The heading against the odometry: the same revisit (its estimate right), with the odometry's base
// poses turned apart by 1 deg and by 3 deg. At 3 sigma of the heading's drift over 200 s and the
// registration's 0.5 deg (1.7 deg) the first is accepted and the second refused, the reason counted;
// the check is off by default and skipped for submaps without odometry poses.
TEST(LoopCloser, ARegistrationThatDisagreesWithTheOdometrysHeadingIsRefused) {
  const auto orbit = test::orbitTrajectory(80, 5.5, -2.0);
  const auto submapsWithOdometryTurn = [&](double turn_deg) {
    std::vector<LoopSubmap> submaps = {
        {0, gridOf(orbit, 1), orbit.front(), 0},
        {5, gridOf(orbit, 2), orbit.front(), 200'000'000'000},
    };
    submaps[0].T_world_submap_odometry = orbit.front();
    submaps[1].T_world_submap_odometry =
        orbit.front() * geometry::poseFromXyzRpy(0.3, 0.2, 0.0, 0.0, 0.0, deg2rad(turn_deg));
    return submaps;
  };
  LoopCloserConfig c;
  c.point_to_plane.max_correspondence_distance_m = 0.5;
  const auto run = [](const LoopCloserConfig& config, const std::vector<LoopSubmap>& submaps) {
    auto closer = LoopCloser::create(config);
    EXPECT_TRUE(closer.ok());
    auto out = closer->closeLoops(submaps, 1);
    EXPECT_TRUE(out.ok()) << out.error().message;
    return out.value().stats;
  };
  EXPECT_EQ(run(c, submapsWithOdometryTurn(3.0)).accepted, 1) << "off by default";
  c.odometry_yaw_sigmas = 3.0;
  EXPECT_EQ(run(c, submapsWithOdometryTurn(1.0)).accepted, 1);
  const LoopCloseStats refused = run(c, submapsWithOdometryTurn(3.0));
  EXPECT_EQ(refused.accepted, 0);
  EXPECT_EQ(refused.rejected_by_reason.count("odometry_yaw"), 1U);
  std::vector<LoopSubmap> without = submapsWithOdometryTurn(3.0);
  without[0].T_world_submap_odometry.reset();
  EXPECT_EQ(run(c, without).accepted, 1) << "no odometry pose: not checked";
  c.odometry_yaw_sigmas = -1.0;
  auto bad = LoopCloser::create(c);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("odometry_yaw_sigmas"), std::string::npos) << bad.error().message;
}

// max_registrations: only the candidates whose centroids are nearest the new submap's are registered,
// the others counted as skipped. Three earlier views of the stretch, starting 0, 10 and 20 poses on.
TEST(LoopCloser, TheRegistrationBudgetTriesTheNearestCandidates) {
  const auto orbit = test::orbitTrajectory(120, 5.5, -2.0);
  const auto stretch = [&](int first) {
    return std::vector<geometry::Pose3>(orbit.begin() + first, orbit.begin() + first + 80);
  };
  std::vector<LoopSubmap> submaps;
  for (const int first : {20, 0, 10}) {
    const auto poses = stretch(first);
    submaps.push_back({static_cast<std::int64_t>(3 * submaps.size()), gridOf(poses, submaps.size() + 1), poses.front(),
                       static_cast<std::int64_t>(submaps.size()) * 1'000'000'000});
  }
  submaps.push_back({9, gridOf(stretch(0), 7), orbit.front(), 200'000'000'000});
  for (const int budget : {0, 1, 2}) {
    LoopCloserConfig c;
    c.point_to_plane.max_correspondence_distance_m = 0.5;
    c.max_registrations = budget;
    auto closer = LoopCloser::create(c);
    ASSERT_TRUE(closer.ok());
    auto out = closer->closeLoops(submaps, 3);
    ASSERT_TRUE(out.ok()) << out.error().message;
    const int tried = budget == 0 ? 3 : budget;
    EXPECT_EQ(out->stats.tried, tried) << "budget " << budget;
    EXPECT_EQ(out->stats.skipped_budget, 3 - tried) << "budget " << budget;
    std::vector<std::int64_t> from;
    for (const LoopClosure& lc : out->closures) from.push_back(lc.from);
    const std::vector<std::vector<std::int64_t>> nearest = {{0, 3, 6}, {3}, {3, 6}};  // ids of 20, 0, 10 on
    EXPECT_EQ(from, nearest[static_cast<std::size_t>(budget)]) << "budget " << budget;
  }
  LoopCloserConfig bad;
  bad.max_registrations = -1;
  auto refused = LoopCloser::create(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("max_registrations"), std::string::npos) << refused.error().message;
}

// max_revisits: of the runs of candidates with consecutive indices (one pass over the place each),
// only the oldest and the newest are registered, the others counted as skipped. Earlier views of the
// same stretch as submaps 0 and 1, 10, 20 and 30; the new one is 40.
TEST(LoopCloser, TheRevisitLimitTriesTheOldestAndTheNewestRuns) {
  const auto orbit = test::orbitTrajectory(80, 5.5, -2.0);
  const std::vector<geometry::Pose3> stretch(orbit.begin(), orbit.begin() + 80);
  const auto earlier = gridOf(stretch, 1);
  std::vector<LoopSubmap> submaps;
  for (const std::int64_t index : {0, 1, 10, 20, 30})
    submaps.push_back({index, earlier, stretch.front(), index * 20'000'000'000});
  submaps.push_back({40, gridOf(stretch, 2), stretch.front(), 800'000'000'000});
  const auto run = [&](int max_revisits, int gap) {
    LoopCloserConfig c;
    c.point_to_plane.max_correspondence_distance_m = 0.5;
    c.max_revisits = max_revisits;
    c.revisit_gap = gap;
    auto closer = LoopCloser::create(c);
    EXPECT_TRUE(closer.ok()) << closer.error().message;
    auto out = closer->closeLoops(submaps, submaps.size() - 1);
    EXPECT_TRUE(out.ok()) << out.error().message;
    std::vector<std::int64_t> from;
    for (const LoopClosure& lc : out->closures) from.push_back(lc.from);
    return std::make_pair(from, *out);
  };
  const std::vector<std::int64_t> all = {0, 1, 10, 20, 30};
  EXPECT_EQ(run(0, 3).first, all);
  const auto [three, three_out] = run(3, 3);
  EXPECT_EQ(three, (std::vector<std::int64_t>{0, 1, 20, 30}));
  EXPECT_EQ(three_out.stats.tried, 4);
  EXPECT_EQ(three_out.stats.skipped_revisits, 1);
  const auto [two, two_out] = run(2, 3);
  EXPECT_EQ(two, (std::vector<std::int64_t>{0, 1, 30}));
  EXPECT_EQ(two_out.stats.skipped_revisits, 2);
  EXPECT_EQ(run(2, 10).first, all) << "gaps of 10 make one run";
  EXPECT_EQ(run(6, 3).first, all) << "fewer runs than the limit";
  // The error names the key that is wrong.
  for (const auto& [revisits, gap, key] : {std::tuple<int, int, const char*>{1, 3, "max_revisits = 1"},
                                           {-1, 3, "max_revisits = -1"},
                                           {2, 0, "revisit_gap = 0"}}) {
    LoopCloserConfig bad;
    bad.max_revisits = revisits;
    bad.revisit_gap = gap;
    auto refused = LoopCloser::create(bad);
    ASSERT_FALSE(refused.ok()) << revisits << " " << gap;
    EXPECT_NE(refused.error().message.find(key), std::string::npos) << refused.error().message;
    if (gap >= 1) {
      EXPECT_EQ(refused.error().message.find("revisit_gap"), std::string::npos) << refused.error().message;
    }
  }
}

TEST(LoopCloser, ConsecutiveAndOppositeViewsAreNotTried) {
  const auto orbit = test::orbitTrajectory(40, 5.5, -2.0);
  const auto grid = gridOf(orbit, 1);
  // Index gap 1: consecutive (odometry already links them).
  std::vector<LoopSubmap> consecutive = {{0, grid, orbit.front(), 0}, {1, grid, orbit.front(), 1'000'000'000}};
  auto closer = LoopCloser::create({});
  ASSERT_TRUE(closer.ok());
  auto a = closer->closeLoops(consecutive, 1);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->stats.tried, 0);
  // Same place, heading 180 deg apart: skipped by the viewing-direction gate.
  const geometry::Pose3 turned = orbit.front() * geometry::poseFromXyzRpy(0, 0, 0, 0, 0, deg2rad(180.0));
  std::vector<LoopSubmap> opposite = {{0, grid, orbit.front(), 0}, {4, grid, turned, 1'000'000'000}};
  auto b = closer->closeLoops(opposite, 1);
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(b->stats.tried, 0);
}

TEST(LoopCloser, BadInputIsAnError) {
  auto closer = LoopCloser::create({});
  ASSERT_TRUE(closer.ok());
  std::vector<LoopSubmap> none;
  auto r = closer->closeLoops(none, 0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("out of range"), std::string::npos);
  std::vector<LoopSubmap> no_grid = {{0, nullptr, geometry::Pose3::Identity(), 0}};
  auto r2 = closer->closeLoops(no_grid, 0);
  ASSERT_FALSE(r2.ok());
  EXPECT_NE(r2.error().message.find("submap 0"), std::string::npos);
  LoopCloserConfig bad;
  bad.min_overlap_fraction = 1.5;
  auto c = LoopCloser::create(bad);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("min_overlap_fraction"), std::string::npos);
  LoopCloserConfig bad_p2p;
  bad_p2p.p2p_min_overlap_fraction = -0.1;
  auto c2 = LoopCloser::create(bad_p2p);
  ASSERT_FALSE(c2.ok());
  EXPECT_NE(c2.error().message.find("p2p_min_overlap_fraction"), std::string::npos);
}

}  // namespace
}  // namespace vog::slam
