#include "vog/plan/sonar_gain.hpp"

#include "plan_fixtures.hpp"

#include <gtest/gtest.h>

#include <numbers>
#include <set>
#include <tuple>

namespace vog::plan {
namespace {

using Key3 = std::tuple<int, int, int>;

PlannerConfig pierConfig() {
  PlannerConfig c;
  c.box_min_world_m = {-8.0, -8.0, -4.5};
  c.box_max_world_m = {8.0, 8.0, 0.5};
  return c;
}

// Reference 1: the same voxel walk, with a std::set for the per-segment dedupe.
double referenceGain(const map::MergedMap& map, const SonarGain& g, const Waypoint& a, const Waypoint& b) {
  std::set<Key3> seen;
  double gain = 0.0;
  for (const Waypoint& w : g.interpolate(a, b)) {
    const geometry::Pose3 T = g.sensorPose(w);
    for (const Eigen::Vector3d& d : g.beamDirections()) {
      map.traverse(T.translation(), T.translation() + g.rangeM() * (T.linear() * d),
                   [&](const map::VoxelKey& k, const map::VoxelValue& v) {
                     if (g.counts(k) && seen.insert({k.x(), k.y(), k.z()}).second) gain += g.weight(v.status);
                     return v.status != map::Occupancy::kOccupied;
                   });
    }
  }
  return gain;
}

// Reference 2: brute force, independent of the voxel walk: points every res / 16 along every beam,
// looked up one by one with MergedMap::query, stopping at the first occupied one.
double bruteForceGain(const map::MergedMap& map, const SonarGain& g, const Waypoint& a, const Waypoint& b) {
  std::set<Key3> seen;
  double gain = 0.0;
  const double step = map.resolution() / 16.0;
  const double inv = 1.0 / map.resolution();
  for (const Waypoint& w : g.interpolate(a, b)) {
    const geometry::Pose3 T = g.sensorPose(w);
    for (const Eigen::Vector3d& d : g.beamDirections()) {
      const Eigen::Vector3d dir = T.linear() * d;
      for (double s = 0.0; s <= g.rangeM(); s += step) {
        const Eigen::Vector3d p = T.translation() + s * dir;
        const map::VoxelKey k = map::pointToKey(p, inv);
        const map::VoxelValue v = map.query(p);
        if (g.counts(k) && seen.insert({k.x(), k.y(), k.z()}).second) gain += g.weight(v.status);
        if (v.status == map::Occupancy::kOccupied) break;
      }
    }
  }
  return gain;
}

TEST(SonarGain, MatchesReferencesOnASonarMap) {
  const map::GridConfig grid_config;
  auto map = map::MergedMap::create(grid_config).value();
  for (const auto& e : test_fixtures::pierSubmaps(grid_config, 3, 60, 4)) ASSERT_TRUE(map->add(e).ok());
  PlannerConfig config = pierConfig();
  // Weights on every status, so the sums check the classification of every visited voxel.
  config.gain_unknown = 1.0;
  config.gain_free = 0.25;
  config.gain_occupied = 3.0;
  auto gain = SonarGain::create(config, grid_config.resolution_m).value();
  const auto cache =
      TraversabilityGrid::build(*map, Eigen::AlignedBox3d(config.box_min_world_m, config.box_max_world_m),
                                Footprint::box(config.collision_box_m))
          .value();
  // Segments from the orbit looking inward (pilings, occupied) and sweeping the heading.
  const std::vector<std::pair<Waypoint, Waypoint>> segments = {
      {{{5.5, 0.0, -2.0}, std::numbers::pi}, {{5.0, 1.0, -2.0}, std::numbers::pi}},
      {{{5.5, 0.0, -2.0}, std::numbers::pi}, {{5.5, 0.0, -2.0}, std::numbers::pi / 2}},
      {{{4.5, 2.0, -1.5}, -2.5}, {{4.5, 2.0, -3.0}, -2.0}},
      {{{0.0, 5.0, -2.0}, -1.6}, {{1.5, 4.8, -2.0}, -0.9}},
  };
  for (const auto& [a, b] : segments) {
    const double fast = gain.segmentGain(*map, a, b);
    const double ref = referenceGain(*map, gain, a, b);
    EXPECT_DOUBLE_EQ(fast, ref);
    // The dense status copy of the traversability grid walks the same voxels with the same values.
    EXPECT_DOUBLE_EQ(gain.segmentGain(*map, a, b, &cache), ref);
    const double brute = bruteForceGain(*map, gain, a, b);
    // Fine sampling can miss a voxel a beam clips at a corner (and see one past a clipped occupied
    // corner): a small relative difference only.
    EXPECT_NEAR(fast, brute, 0.03 * brute) << a.p_world.transpose() << " -> " << b.p_world.transpose();
    EXPECT_GT(fast, 100.0);
  }
}

TEST(SonarGain, OcclusionStopsBeamsAtTheFirstOccupiedVoxel) {
  const map::GridConfig grid_config;
  const double res = grid_config.resolution_m;
  // A known free corridor ending in a wall 2 m ahead of the vehicle; unknown beyond.
  const Eigen::AlignedBox3d corridor(Eigen::Vector3d(-1.0, -2.0, -4.0), Eigen::Vector3d(2.0, 2.0, 0.0));
  auto east_wall = [&](const map::VoxelKey& k) { return map::keyToCentre(k, res).x() > 2.0; };
  auto map = test_fixtures::mergedOf(grid_config, {test_fixtures::carvedGrid(grid_config, corridor, east_wall)});
  PlannerConfig config;
  config.box_min_world_m = {-10.0, -10.0, -10.0};
  config.box_max_world_m = {10.0, 10.0, 10.0};
  config.gain_unknown = 1.0;
  auto gain = SonarGain::create(config, res).value();
  const Waypoint w{{0.0, 0.0, -2.0}, 0.0};                  // facing +x, the fan in the x-z plane
  EXPECT_DOUBLE_EQ(gain.segmentGain(*map, w, w), 0.0);      // free up to the wall, nothing beyond is seen
  const Waypoint back{{0.0, 0.0, -2.0}, std::numbers::pi};  // facing -x: free 1 m, then unknown
  EXPECT_GT(gain.segmentGain(*map, back, back), 100.0);
}

TEST(SonarGain, YawSweepIsCountedAndAFrustumTestWouldSeeAlmostNothing) {
  const map::GridConfig grid_config;
  const double res = grid_config.resolution_m;
  auto map = map::MergedMap::create(grid_config).value();  // everything unknown
  PlannerConfig config;
  config.box_min_world_m = {-10.0, -10.0, -10.0};
  config.box_max_world_m = {10.0, 10.0, 10.0};
  auto gain = SonarGain::create(config, res).value();
  const Waypoint a{{0.0, 0.0, 0.0}, 0.0};
  const Waypoint b{{0.0, 0.0, 0.0}, std::numbers::pi / 2};
  const double single = gain.segmentGain(*map, a, a);
  const double sweep = gain.segmentGain(*map, a, b);
  // One vertical fan: a 29 deg x 5 m sector, about 0.5 * 5^2 * 0.506 m^2 / res^2 = 700 voxels of
  // its plane (more: the walk counts every voxel a beam touches).
  EXPECT_GT(single, 500.0);
  // Turning 90 deg sweeps a quarter of a thick disc: many times one fan.
  EXPECT_GT(sweep, 20.0 * single);
  // A camera-style frustum test: voxel centres inside the 1 deg thick fan volume at the end pose.
  const geometry::Pose3 T_sensor_world = gain.sensorPose(b).inverse();
  const double half_fov = 0.5 * config.fan.fov_rad;
  const double half_spread = 0.5 * config.fan.spread_rad;
  int frustum = 0;
  const int n = static_cast<int>(config.planner_range_m / res) + 1;
  for (int z = -n; z <= n; ++z)
    for (int y = -n; y <= n; ++y)
      for (int x = -n; x <= n; ++x) {
        const Eigen::Vector3d p = T_sensor_world * map::keyToCentre(map::VoxelKey(x, y, z), res);
        const double range = p.norm();
        if (range > config.planner_range_m || range < 1e-9) continue;
        if (std::abs(std::atan2(p.y(), p.x())) <= half_fov && std::abs(std::asin(p.z() / range)) <= half_spread &&
            p.x() > 0.0)
          ++frustum;
      }
  EXPECT_LT(frustum, 0.5 * single);  // the frustum misses most of what the beams see
  // A zero-length segment: deterministic and independent of call history (per-segment dedupe).
  EXPECT_DOUBLE_EQ(gain.segmentGain(*map, a, a), single);
}

TEST(SonarGain, InterpolatesAtResolutionAndFanThickness) {
  PlannerConfig config;
  auto gain = SonarGain::create(config, 0.1).value();
  const auto straight = gain.interpolate({{0, 0, 0}, 0.0}, {{2.0, 0, 0}, 0.0});
  EXPECT_EQ(straight.size(), 21u);
  for (std::size_t i = 1; i < straight.size(); ++i)
    EXPECT_NEAR((straight[i].p_world - straight[i - 1].p_world).norm(), 0.1, 1e-12);
  // 90 deg at 1 deg steps; yaw turns the short way across +-pi.
  const auto turn = gain.interpolate({{0, 0, 0}, 3.0}, {{0, 0, 0}, 3.0 + std::numbers::pi / 2 - 2 * std::numbers::pi});
  EXPECT_EQ(turn.size(), 91u);
  for (std::size_t i = 1; i < turn.size(); ++i)
    EXPECT_NEAR(std::abs(geometry::wrapAngle(turn[i].yaw_rad - turn[i - 1].yaw_rad)), std::numbers::pi / 180, 1e-9);
  // NaN never counts.
  auto map = map::MergedMap::create(map::GridConfig{}).value();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(gain.segmentGain(*map, {{nan, 0, 0}, 0.0}, {{0, 0, 0}, 0.0}), 0.0);
}

TEST(SonarGain, BadConfigIsAnError) {
  PlannerConfig config;
  config.gain_unknown = -1.0;
  const auto r = SonarGain::create(config, 0.1);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("plan.gain_unknown"), std::string::npos);
  config = PlannerConfig{};
  config.box_min_world_m = {-1e4, -1e4, -1e4};
  config.box_max_world_m = {1e4, 1e4, 1e4};
  EXPECT_FALSE(SonarGain::create(config, 0.1).ok());
}

}  // namespace
}  // namespace vog::plan
