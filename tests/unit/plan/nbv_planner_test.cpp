#include "vog/plan/nbv_planner.hpp"

#include "plan_fixtures.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <limits>
#include <map>
#include <tuple>
#include <mutex>
#include <numbers>
#include <thread>

namespace vog::plan {
namespace {

using test_fixtures::bruteForceEdgeFree;

constexpr double kPi = std::numbers::pi;
const Eigen::AlignedBox3d kRoom(Eigen::Vector3d(-5.0, -3.0, -3.0), Eigen::Vector3d(5.0, 3.0, -0.5));

PlannerConfig roomConfig(std::uint64_t seed = 1) {
  PlannerConfig c;
  c.box_min_world_m = kRoom.min();
  c.box_max_world_m = kRoom.max();
  c.seed = seed;
  c.assume_free_radius_m = 0.0;  // the maps carry all the free space the tests mean
  c.clearance_m = 0.1;           // the rooms, pockets and doors below are drawn for one voxel of it
  return c;
}

// Maps shared by the tests (building them is the slow part).
class PlannerMaps : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const map::GridConfig config;
    const double res = config.resolution_m;
    auto all = [](const map::VoxelKey&) { return true; };
    // The west half of the room is known (free, with its walls); the east half is unknown.
    const Eigen::AlignedBox3d west(kRoom.min(), Eigen::Vector3d(0.0, kRoom.max().y(), kRoom.max().z()));
    auto west_walls = [&](const map::VoxelKey& k) { return map::keyToCentre(k, res).x() < 0.0; };
    half_ = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, west, west_walls)}).release();
    full_ = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, kRoom, all)}).release();
  }
  static void TearDownTestSuite() {
    delete half_;
    delete full_;
  }
  static std::shared_ptr<const map::MergedMap> half() { return half_->snapshot(); }
  static std::shared_ptr<const map::MergedMap> full() { return full_->snapshot(); }

  // The properties every tree must have: constrained sampling (thesis 4.5.3), free edges.
  static void expectTreeValid(const NbvPlanner& planner, const map::MergedMap& map) {
    const auto& tree = planner.lastTree();
    const auto& c = planner.config();
    const Eigen::Vector3d root = tree[0].w.p_world;
    for (std::size_t i = 1; i < tree.size(); ++i) {
      const TreeNode& n = tree[i];
      const TreeNode& p = tree[static_cast<std::size_t>(n.parent)];
      ASSERT_LT(n.parent, static_cast<int>(i));
      EXPECT_LE(std::abs(geometry::wrapAngle(n.w.yaw_rad - p.w.yaw_rad)), c.max_heading_change_rad + 1e-9);
      EXPECT_LE((n.w.p_world - p.w.p_world).norm(), c.max_edge_m + 1e-9);
      ASSERT_TRUE(bruteForceEdgeFree(map, p.w.p_world, n.w.p_world, c.collision_box_m)) << "node " << i;
      EXPECT_GE(n.value, p.value);
      if (!n.seeded) {
        const bool horizontal = n.w.p_world.z() == root.z() && p.w.p_world.z() == root.z();
        const bool vertical = n.w.p_world.head<2>() == root.head<2>() && p.w.p_world.head<2>() == root.head<2>();
        EXPECT_TRUE(horizontal || vertical) << "node " << i << " " << n.w.p_world.transpose();
      }
    }
  }

  static inline std::vector<Waypoint> seeded_expected_;
  static map::MergedMap* half_;
  static map::MergedMap* full_;
};
map::MergedMap* PlannerMaps::half_ = nullptr;
map::MergedMap* PlannerMaps::full_ = nullptr;

TEST_F(PlannerMaps, HalfExploredRoomExploresTowardTheUnknownHalf) {
  const auto map = half();
  // Facing the known west wall 1.5 m away: nothing unknown in view at the start.
  const Waypoint start{{-3.5, 0.0, -1.75}, kPi};
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    auto planner = NbvPlanner::create(roomConfig(seed), start).value();
    auto probe = SonarGain::create(planner->config(), map->resolution()).value();
    ASSERT_EQ(probe.segmentGain(*map, start, start), 0.0);
    const PlanResult r = planner->plan(map, start).value();
    ASSERT_EQ(r.status, PlanStatus::kExplore) << r.reason;
    ASSERT_EQ(r.waypoints.size(), 1u);
    const Waypoint& next = r.waypoints[0];
    EXPECT_EQ(next.p_world, r.best_branch[1].p_world);
    EXPECT_TRUE(bruteForceEdgeFree(*map, start.p_world, next.p_world, planner->config().collision_box_m));
    EXPECT_LE(std::abs(geometry::wrapAngle(next.yaw_rad - start.yaw_rad)), kPi / 2 + 1e-9);
    // Toward the unknown (east) half: the first step moves east or turns the sonar toward the east,
    // and the branch's last edge sweeps the sonar over unknown space (the best node is the first of
    // the highest value, so its own edge has gain).
    EXPECT_TRUE(next.p_world.x() > start.p_world.x() || std::cos(next.yaw_rad) > std::cos(start.yaw_rad) + 0.1)
        << next.p_world.transpose() << " yaw " << next.yaw_rad;
    ASSERT_GE(r.best_branch.size(), 2u);
    EXPECT_GT(probe.segmentGain(*map, r.best_branch[r.best_branch.size() - 2], r.best_branch.back()), 0.0);
    EXPECT_GT(r.best_value, planner->config().gain_threshold);
    EXPECT_LE(r.tree_size, planner->config().n_tol + 1);
    expectTreeValid(*planner, *map);
  }
}

TEST_F(PlannerMaps, SameSeedSameResultAndTheBranchSeedsTheNextTree) {
  const auto map = half();
  const Waypoint start{{-3.0, 1.0, -1.5}, 0.3};
  auto a = NbvPlanner::create(roomConfig(7), start).value();
  auto b = NbvPlanner::create(roomConfig(7), start).value();
  Waypoint pa = start;
  Waypoint pb = start;
  for (int step = 0; step < 3; ++step) {
    const PlanResult ra = a->plan(map, pa).value();
    const PlanResult rb = b->plan(map, pb).value();
    ASSERT_EQ(ra.status, rb.status);
    ASSERT_EQ(ra.tree_size, rb.tree_size);
    ASSERT_EQ(ra.samples, rb.samples);
    EXPECT_EQ(ra.best_value, rb.best_value);
    ASSERT_EQ(ra.best_branch.size(), rb.best_branch.size());
    for (std::size_t i = 0; i < ra.best_branch.size(); ++i) {
      EXPECT_EQ(ra.best_branch[i].p_world, rb.best_branch[i].p_world);
      EXPECT_EQ(ra.best_branch[i].yaw_rad, rb.best_branch[i].yaw_rad);
    }
    if (ra.status != PlanStatus::kExplore) break;
    if (step > 0) {
      // The previous branch beyond its first edge was re-inserted first, unchanged.
      const auto& tree = a->lastTree();
      for (std::size_t i = 0; i < seeded_expected_.size(); ++i) {
        ASSERT_LT(i + 1, tree.size());
        EXPECT_TRUE(tree[i + 1].seeded);
        EXPECT_EQ(tree[i + 1].w.p_world, seeded_expected_[i].p_world);
      }
    }
    seeded_expected_.assign(ra.best_branch.begin() + 2, ra.best_branch.end());
    pa = ra.waypoints[0];  // the vehicle reaches the waypoint
    pb = rb.waypoints[0];
    expectTreeValid(*a, *map);
  }
  // Another seed grows another tree.
  auto c = NbvPlanner::create(roomConfig(8), start).value();
  auto d = NbvPlanner::create(roomConfig(7), start).value();
  const PlanResult rc = c->plan(map, start).value();
  const PlanResult rd = d->plan(map, start).value();
  EXPECT_NE(rc.best_branch.back().p_world, rd.best_branch.back().p_world);
}

TEST_F(PlannerMaps, FullyKnownRoomIsCompleteAndReturnsHome) {
  const auto map = full();
  const Waypoint home{{-3.0, -1.5, -1.75}, 0.0};
  auto planner = NbvPlanner::create(roomConfig(), home).value();
  const Waypoint current{{3.0, 1.5, -1.2}, 2.9};
  const PlanResult r = planner->plan(map, current).value();
  ASSERT_EQ(r.status, PlanStatus::kComplete) << r.reason;
  EXPECT_EQ(r.best_value, 0.0);
  EXPECT_EQ(r.tree_size, planner->config().n_tol + 1);  // grew to N_TOL before giving up
  ASSERT_FALSE(r.waypoints.empty());
  EXPECT_EQ(r.waypoints.back().p_world, home.p_world);
  EXPECT_EQ(r.waypoints.back().yaw_rad, home.yaw_rad);
  Waypoint prev = current;
  for (const Waypoint& w : r.waypoints) {
    EXPECT_TRUE(bruteForceEdgeFree(*map, prev.p_world, w.p_world, planner->config().collision_box_m));
    EXPECT_LE(std::abs(geometry::wrapAngle(w.yaw_rad - prev.yaw_rad)), kPi / 2 + 1e-9);
    prev = w;
  }
  expectTreeValid(*planner, *map);
}

TEST_F(PlannerMaps, ErrorsNameTheBadInput) {
  const auto map = half();
  const Waypoint start{{-3.0, 0.0, -1.75}, 0.0};
  auto expectError = [](const PlannerConfig& c, const Waypoint& home, const std::string& needle) {
    const auto r = NbvPlanner::create(c, home);
    ASSERT_FALSE(r.ok()) << needle;
    EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
  };
  PlannerConfig c = roomConfig();
  c.lambda = -0.5;
  expectError(c, start, "plan.lambda");
  c = roomConfig();
  c.box_max_world_m.z() = c.box_min_world_m.z();
  expectError(c, start, "zero volume");
  c = roomConfig();
  c.n_max = 0;
  expectError(c, start, "plan.n_max");
  c = roomConfig();
  c.collision_box_m.y() = 0.0;
  expectError(c, start, "plan.collision_box_m");
  c = roomConfig();
  c.clearance_m = -0.1;
  expectError(c, start, "plan.clearance_m");
  c = roomConfig();
  c.recovery_radius_m = -1.0;
  expectError(c, start, "plan.recovery_radius_m");
  c = roomConfig();
  c.max_heading_change_rad = 4.0;
  expectError(c, start, "plan.max_heading_change_rad");
  c = roomConfig();
  c.fan.n_beams = 0;
  expectError(c, start, "plan.sonar.n_beams");
  expectError(roomConfig(), {{9.0, 0.0, -1.0}, 0.0}, "outside the exploration box");
  expectError(roomConfig(), {{std::numeric_limits<double>::quiet_NaN(), 0.0, -1.0}, 0.0}, "not finite");

  auto planner = NbvPlanner::create(roomConfig(), start).value();
  auto err = planner->plan(nullptr, start);
  ASSERT_FALSE(err.ok());
  EXPECT_NE(err.error().message.find("snapshot"), std::string::npos);
  err = planner->plan(map, {{-3.0, 0.0, -1.75}, std::numeric_limits<double>::infinity()});
  ASSERT_FALSE(err.ok());
  EXPECT_NE(err.error().message.find("not finite"), std::string::npos);
  err = planner->plan(map, {{-3.0, 0.0, 2.0}, 0.0});
  ASSERT_FALSE(err.ok());
  EXPECT_NE(err.error().message.find("outside the exploration box"), std::string::npos);
  // Within root_tolerance_m of the box (a loop closure moved the estimate): not an error; here no
  // safe voxel is that close, so there is no path.
  const auto near_wall = planner->plan(map, {{5.1, 0.0, -1.75}, 0.0});
  ASSERT_TRUE(near_wall.ok()) << near_wall.error().message;
  EXPECT_EQ(near_wall->status, PlanStatus::kNoPath);
  // Inside the west wall (an occupied voxel).
  const double res = map->resolution();
  const Eigen::Vector3d wall =
      map::keyToCentre(map::pointToKey(Eigen::Vector3d(-5.0, 0.0, -1.75), 1.0 / res) - map::VoxelKey(1, 0, 0), res);
  ASSERT_EQ(map->query(wall).status, map::Occupancy::kOccupied);
  c = roomConfig();
  c.box_min_world_m.x() = -6.0;
  auto wide = NbvPlanner::create(c, start).value();
  err = wide->plan(map, {wall, 0.0});
  ASSERT_FALSE(err.ok());
  EXPECT_NE(err.error().message.find("obstacle"), std::string::npos);
}

TEST(NbvPlanner, BoxedInIsNoPathNotAHang) {
  const map::GridConfig config;
  const double res = config.resolution_m;
  auto all = [](const map::VoxelKey&) { return true; };
  PlannerConfig c = roomConfig();
  const Eigen::Vector3d centre = map::keyToCentre(map::VoxelKey(0, 0, -18), res);
  // (a) A pocket smaller than the collision box: the current pose itself is not safe.
  {
    const Eigen::AlignedBox3d pocket(centre - Eigen::Vector3d(0.4, 0.4, 0.2), centre + Eigen::Vector3d(0.4, 0.4, 0.2));
    auto map = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, pocket, all)});
    auto planner = NbvPlanner::create(c, {centre, 0.0}).value();
    const PlanResult r = planner->plan(map->snapshot(), {centre, 0.0}).value();
    EXPECT_EQ(r.status, PlanStatus::kNoPath);
    EXPECT_NE(r.reason.find("collision box"), std::string::npos) << r.reason;
  }
  // (b) A pocket 19 x 19 x 7 voxels walled in by occupied voxels: the box at any heading with its
  // clearance (1.61 m in x and y) fits in exactly one voxel, so no edge does.
  {
    const Eigen::Vector3d lo = map::keyToCentre(map::VoxelKey(-9, -9, -21), res);
    const Eigen::Vector3d hi = map::keyToCentre(map::VoxelKey(9, 9, -15), res);
    auto map = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, Eigen::AlignedBox3d(lo, hi), all)});
    auto planner = NbvPlanner::create(c, {centre, 0.0}).value();
    ASSERT_TRUE(planner->plan(map->snapshot(), {centre, 0.0}).ok());
    ASSERT_NE(planner->traversability(), nullptr);
    EXPECT_EQ(planner->traversability()->safeCount(), 1u);
    const PlanResult r = planner->plan(map->snapshot(), {centre, 0.0}).value();
    EXPECT_EQ(r.status, PlanStatus::kNoPath);
    EXPECT_EQ(r.tree_size, 1);
    EXPECT_EQ(r.samples, c.max_samples);
    EXPECT_NE(r.reason.find("no collision-free edge"), std::string::npos) << r.reason;
  }
  // (c) Known nothing at all.
  {
    auto map = map::MergedMap::create(config).value();
    auto planner = NbvPlanner::create(c, {centre, 0.0}).value();
    EXPECT_EQ(planner->plan(map->snapshot(), {centre, 0.0}).value().status, PlanStatus::kNoPath);
  }
}

TEST(NbvPlanner, CorridorTooNarrowForTheTreeWithNothingLeftGoesHome) {
  const map::GridConfig config;
  const double res = config.resolution_m;
  auto all = [](const map::VoxelKey&) { return true; };
  // The pocket of BoxedInIsNoPathNotAHang stretched by 4 voxels in x and walled in: its safe voxels are
  // a line 0.48 m long, too short for a sampled edge to stay on it, and everything is known (no gain).
  const Eigen::Vector3d lo = map::keyToCentre(map::VoxelKey(-9, -9, -21), res);
  const Eigen::Vector3d hi = map::keyToCentre(map::VoxelKey(13, 9, -15), res);
  auto map = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, Eigen::AlignedBox3d(lo, hi), all)});
  const Eigen::Vector3d home = map::keyToCentre(map::VoxelKey(0, 0, -18), res);
  const Eigen::Vector3d far_end = map::keyToCentre(map::VoxelKey(4, 0, -18), res);
  PlannerConfig c = roomConfig();
  c.n_max = 5;
  c.n_tol = 5;  // (a sample inside the line's 5 voxels would give an edge; 30 draws miss them)
  c.max_samples = 30;
  ASSERT_TRUE(c.global_search);
  auto planner = NbvPlanner::create(c, {home, 0.0}).value();
  const PlanResult r = planner->plan(map->snapshot(), {far_end, 0.0}).value();
  ASSERT_EQ(planner->traversability()->safeCount(), 5u);
  EXPECT_EQ(r.tree_size, 1);
  EXPECT_EQ(r.status, PlanStatus::kComplete) << r.reason;
  EXPECT_NE(r.reason.find("no collision-free edge"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("no reachable view left"), std::string::npos) << r.reason;
  ASSERT_FALSE(r.waypoints.empty());
  EXPECT_LT((r.waypoints.back().p_world - home).norm(), 1e-9);
  // Every waypoint on the corridor's line.
  for (const Waypoint& w : r.waypoints) {
    EXPECT_TRUE(planner->traversability()->isSafe(w.p_world)) << w.p_world.transpose();
    EXPECT_NEAR(w.p_world.y(), home.y(), 1e-9);
  }
  // Without the global search (Bircher's local rule) nothing says the exploration is over: no path.
  PlannerConfig local = c;
  local.global_search = false;
  auto local_planner = NbvPlanner::create(local, {home, 0.0}).value();
  EXPECT_EQ(local_planner->plan(map->snapshot(), {far_end, 0.0}).value().status, PlanStatus::kNoPath);
}

TEST(NbvPlanner, GlobalSearchFindsViewsInASafeRegionOffAnyFixedLattice) {
  const map::GridConfig config;
  const double res = config.resolution_m;
  // The corridor of CorridorTooNarrowForTheTreeWithNothingLeftGoesHome, stretched to 50 voxels and
  // open at its east end (unknown beyond): its safe voxels are one line at z key -18, so not one of
  // them lies on a lattice of global_spacing_m (5 voxels) anchored at key 0. Views east along it see
  // the unknown, and the global search must find one; not the vehicle's own view (it faces east).
  const Eigen::Vector3d lo = map::keyToCentre(map::VoxelKey(-9, -9, -21), res);
  const Eigen::Vector3d hi = map::keyToCentre(map::VoxelKey(40, 9, -15), res);
  auto walls_but_east = [](const map::VoxelKey& k) { return k.x() <= 40; };
  auto map =
      test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, Eigen::AlignedBox3d(lo, hi), walls_but_east)});
  const Eigen::Vector3d home = map::keyToCentre(map::VoxelKey(0, 0, -18), res);
  PlannerConfig c = roomConfig();
  c.n_max = 1;
  c.n_tol = 1;
  c.max_samples = 1;  // (one draw off the line: no tree edge, the global search decides)
  auto planner = NbvPlanner::create(c, {home, 0.0}).value();
  auto planned = planner->plan(map->snapshot(), {home, 0.0});
  ASSERT_TRUE(planned.ok()) << planned.error().message;
  const PlanResult r = planned.value();
  const TraversabilityGrid& grid = *planner->traversability();
  const std::vector<map::VoxelKey> line = grid.reachable(home, grid.statusArray().size());
  ASSERT_GT(line.size(), 20u);
  const long lattice = std::lround(c.global_spacing_m / res);
  for (const map::VoxelKey& k : line) ASSERT_NE(k.z() % lattice, 0) << k.transpose();
  ASSERT_EQ(r.tree_size, 1);
  ASSERT_EQ(r.status, PlanStatus::kExplore) << r.reason;
  EXPECT_TRUE(r.global_goal);
  EXPECT_GT(r.global_candidates, 0);
  ASSERT_FALSE(r.waypoints.empty());
  const Waypoint& goal = r.waypoints.back();
  EXPECT_TRUE(grid.isSafe(goal.p_world)) << goal.p_world.transpose();
  EXPECT_GT(goal.p_world.x(), home.x()) << r.reason;
  auto probe = SonarGain::create(c, res);
  ASSERT_TRUE(probe.ok()) << probe.error().message;
  EXPECT_GT(probe.value().segmentGain(*map->snapshot(), goal, goal), c.global_min_gain);
  for (const Waypoint& w : r.waypoints) EXPECT_TRUE(grid.isSafe(w.p_world)) << w.p_world.transpose();
}

TEST(NbvPlanner, PlansOnSnapshotsWhileTheMapGrows) {
  // The merge thread adds submaps and publishes snapshots; the planning thread plans on whichever
  // snapshot is newest (thesis 4.5.5). Neither waits for the other beyond swapping a pointer.
  const map::GridConfig config;
  const auto entries = test_fixtures::pierSubmaps(config, 5, 100, 2);
  auto writer = map::MergedMap::create(config).value();
  ASSERT_TRUE(writer->add(entries[0]).ok());
  ASSERT_TRUE(writer->add(entries[1]).ok());
  std::mutex published_mutex;
  std::shared_ptr<const map::MergedMap> published = writer->snapshot();  // guarded by published_mutex
  auto newest = [&] {
    std::lock_guard<std::mutex> lock(published_mutex);
    return published;
  };

  PlannerConfig c;
  c.box_min_world_m = {-8.0, -8.0, -4.5};
  c.box_max_world_m = {8.0, 8.0, 0.5};
  c.n_tol = 30;
  c.assume_free_radius_m = 0.0;
  const Eigen::AlignedBox3d box(c.box_min_world_m, c.box_max_world_m);
  // A start where the collision box is in known free space, inside the first lap.
  const auto grid0 = TraversabilityGrid::build(*newest(), box, Footprint::box(c.collision_box_m)).value();
  Waypoint start;
  bool found = false;
  for (int k = 0; k < 360 && !found; ++k)
    for (double r = 1.0; r < 5.5 && !found; r += 0.05)
      for (double z = -1.4; z > -2.6 && !found; z -= 0.05) {
        const Eigen::Vector3d p(r * std::cos(k * kPi / 180), r * std::sin(k * kPi / 180), z);
        if (grid0.isSafe(p)) {
          start = {p, geometry::wrapAngle(k * kPi / 180 + kPi)};
          found = true;
        }
      }
  ASSERT_TRUE(found);

  std::atomic<bool> done{false};
  std::thread merge_thread([&] {
    for (std::size_t i = 2; i < entries.size(); ++i) {
      EXPECT_TRUE(writer->add(entries[i]).ok());
      auto snap = writer->snapshot();
      std::lock_guard<std::mutex> lock(published_mutex);
      published = std::move(snap);
    }
    done = true;
  });
  auto planner = NbvPlanner::create(c, start).value();
  Waypoint current = start;
  std::uint64_t last_version = 0;
  int plans = 0;
  while (!done || plans < 3) {
    const auto snap = newest();
    const auto planned = planner->plan(snap, current);
    EXPECT_TRUE(planned.ok());
    if (!planned.ok()) break;  // (the merge thread is still joined below)
    const PlanResult& r = planned.value();
    EXPECT_EQ(r.map_version, snap->version());
    EXPECT_GE(r.map_version, last_version);
    last_version = r.map_version;
    if (r.status == PlanStatus::kExplore) {
      EXPECT_TRUE(bruteForceEdgeFree(*snap, current.p_world, r.waypoints[0].p_world, c.collision_box_m));
      current = r.waypoints[0];
    }
    ++plans;
  }
  merge_thread.join();
  // The planner's incrementally updated grid equals one built from the final snapshot.
  const auto final_snap = newest();
  ASSERT_TRUE(planner->plan(final_snap, current).ok());
  const auto scratch =
      TraversabilityGrid::build(*final_snap, box, anyHeadingFootprint(c.collision_box_m, c.clearance_m)).value();
  EXPECT_TRUE(planner->traversability()->sameFlags(scratch));
}

// Every consecutive pair of waypoints (from `from`) is a known-free edge for the box at any heading,
// and no waypoint turns more than the allowed heading change.
void expectPathValid(const map::MergedMap& map, const PlannerConfig& c, const Waypoint& from,
                     const std::vector<Waypoint>& waypoints) {
  Waypoint prev = from;
  for (const Waypoint& w : waypoints) {
    EXPECT_TRUE(bruteForceEdgeFree(map, prev.p_world, w.p_world, anyHeadingFootprint(c.collision_box_m)))
        << prev.p_world.transpose() << " -> " << w.p_world.transpose();
    EXPECT_LE(std::abs(geometry::wrapAngle(w.yaw_rad - prev.yaw_rad)), c.max_heading_change_rad + 1e-9);
    prev = w;
  }
}

// A receding horizon too short to reach the unknown half: the local tree finds no gain. Bircher's
// rule would call the room explored; the global search sends the vehicle on toward the unknown.
PlannerConfig shortHorizon(std::uint64_t seed) {
  PlannerConfig c = roomConfig(seed);
  c.planner_range_m = 1.8;  // the unknown begins at x = 0: out of sight from x < -1.8
  c.max_edge_m = 0.3;
  c.n_max = 4;
  c.n_tol = 7;  // at most 7 edges of 0.3 m: the tree stays within 2.1 m of the root (x <= -2.0)
  c.max_samples = 300;
  return c;
}

TEST_F(PlannerMaps, GlobalSearchLeavesALocalMinimumAlongAKnownFreePath) {
  const auto map = half();
  const Waypoint start{{-4.1, 0.0, -1.75}, kPi};
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    PlannerConfig local_only = shortHorizon(seed);
    local_only.global_search = false;
    auto a = NbvPlanner::create(local_only, start).value();
    const PlanResult ra = a->plan(map, start).value();
    EXPECT_EQ(ra.status, PlanStatus::kComplete) << ra.reason;  // the local minimum
    EXPECT_FALSE(ra.global_goal);

    auto b = NbvPlanner::create(shortHorizon(seed), start).value();
    const PlanResult rb = b->plan(map, start).value();
    ASSERT_EQ(rb.status, PlanStatus::kExplore) << rb.reason;
    EXPECT_TRUE(rb.global_goal);
    EXPECT_GT(rb.global_candidates, 0);
    EXPECT_LE(rb.global_candidates, b->config().global_max_candidates);
    ASSERT_FALSE(rb.waypoints.empty());
    expectPathValid(*map, b->config(), start, rb.waypoints);
    // The goal's fan sees unknown space (more than global_min_gain voxels of it), so it lies within
    // the planner range of the unknown half.
    auto probe = SonarGain::create(b->config(), map->resolution()).value();
    const Waypoint& goal = rb.waypoints.back();
    EXPECT_GT(probe.segmentGain(*map, goal, goal), b->config().global_min_gain);
    EXPECT_GT(goal.p_world.x(), -1.8 - 0.1);
    EXPECT_EQ(rb.best_gain, probe.segmentGain(*map, goal, goal));
  }
}

TEST_F(PlannerMaps, GlobalGoalIsNeverChosenTwice) {
  // The vehicle does not move and the map does not change (as if the fan could not resolve what it
  // was sent to see): every call picks a new goal. The lattice is finite, so the search runs out
  // instead of looping.
  const auto map = half();
  const Waypoint start{{-4.1, 0.0, -1.75}, kPi};
  PlannerConfig c = shortHorizon(1);
  auto planner = NbvPlanner::create(c, start).value();
  std::vector<Eigen::Vector3d> goals;
  for (int call = 0; call < 6; ++call) {
    const PlanResult r = planner->plan(map, start).value();
    ASSERT_TRUE(r.global_goal) << r.reason;
    const Eigen::Vector3d g = r.waypoints.back().p_world;
    for (const Eigen::Vector3d& earlier : goals) ASSERT_GE((g - earlier).norm(), c.global_spacing_m - 1e-9);
    goals.push_back(g);
  }
}

TEST_F(PlannerMaps, RevisitGoesToTheFirstReachableViewAndArrivesWithItsHeading) {
  const auto map = half();
  const Waypoint start{{-3.5, 0.0, -1.75}, kPi};
  const PlannerConfig c = roomConfig(3);
  auto planner = NbvPlanner::create(c, start).value();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Waypoint unknown_east{{3.0, 0.0, -1.75}, 0.5};  // unknown: no safe voxel near it
  const Waypoint known_west{{-1.0, 1.5, -1.75}, -2.0};
  planner->requestRevisit({Waypoint{{nan, 0.0, -1.75}, 0.0}, unknown_east, known_west});
  const PlanResult r = planner->plan(map, start).value();
  ASSERT_EQ(r.status, PlanStatus::kExplore) << r.reason;
  EXPECT_EQ(r.reason.rfind("revisit", 0), 0u) << r.reason;
  ASSERT_FALSE(r.waypoints.empty());
  EXPECT_LE((r.waypoints.back().p_world - known_west.p_world).norm(), c.root_tolerance_m);
  EXPECT_TRUE(planner->traversability()->isSafe(r.waypoints.back().p_world));
  EXPECT_DOUBLE_EQ(r.waypoints.back().yaw_rad, known_west.yaw_rad);
  expectPathValid(*map, c, start, r.waypoints);

  // One request serves one call; a request none of whose views is reachable changes nothing (the
  // random draws included): the same plan as a planner that was never asked.
  const PlanResult next = planner->plan(map, r.waypoints.back()).value();
  EXPECT_EQ(next.reason.rfind("revisit", 0), std::string::npos);
  auto asked = NbvPlanner::create(c, start).value();
  auto never = NbvPlanner::create(c, start).value();
  asked->requestRevisit({unknown_east});
  const PlanResult ra = asked->plan(map, start).value();
  const PlanResult rn = never->plan(map, start).value();
  ASSERT_EQ(ra.waypoints.size(), rn.waypoints.size());
  for (std::size_t i = 0; i < ra.waypoints.size(); ++i) {
    EXPECT_EQ(ra.waypoints[i].p_world, rn.waypoints[i].p_world);
    EXPECT_EQ(ra.waypoints[i].yaw_rad, rn.waypoints[i].yaw_rad);
  }
  EXPECT_EQ(ra.best_value, rn.best_value);
}

TEST_F(PlannerMaps, SnappedRootIsTheFirstWaypoint) {
  // 0.4 m from the west wall: the collision box at any heading is not safe there, the nearest safe
  // voxel is within root_tolerance_m. The vehicle must go there first: the edges the planner checked
  // start there, not at the estimate.
  const auto map = full();
  const Waypoint home{{-3.0, -1.5, -1.75}, 0.0};
  PlannerConfig c = roomConfig();
  c.global_max_candidates = 20;  // the room is fully known: nothing to find, keep the test fast
  auto planner = NbvPlanner::create(c, home).value();
  const Waypoint current{{-4.6, 0.0, -1.75}, 0.4};
  const PlanResult r = planner->plan(map, current).value();
  ASSERT_EQ(r.status, PlanStatus::kComplete) << r.reason;
  ASSERT_FALSE(planner->traversability()->isSafe(current.p_world));
  ASSERT_GE(r.waypoints.size(), 2u);
  const Waypoint& root = planner->lastTree().front().w;
  EXPECT_EQ(r.waypoints.front().p_world, root.p_world);
  EXPECT_EQ(r.waypoints.front().yaw_rad, current.yaw_rad);
  EXPECT_NE(root.p_world, current.p_world);
  EXPECT_LE((root.p_world - current.p_world).norm(), c.root_tolerance_m);
  EXPECT_TRUE(planner->traversability()->isSafe(root.p_world));
  expectPathValid(*map, c, root, {r.waypoints.begin() + 1, r.waypoints.end()});
  EXPECT_EQ(r.waypoints.back().p_world, home.p_world);
}

TEST_F(PlannerMaps, FarFromTheSafeVoxelsTheVehicleRecoversInOneStraightMove) {
  // The same spot 0.4 m from the west wall, with a root tolerance too small to reach a safe voxel (as
  // after a loop closure that moved the map around the vehicle): the plan is one move, keeping the
  // heading, to a safe voxel within recovery_radius_m; from there planning goes on. Without the
  // recovery it is "no path", naming the key.
  const auto map = full();
  const Waypoint home{{-3.0, -1.5, -1.75}, 0.0};
  PlannerConfig c = roomConfig();
  c.global_max_candidates = 20;
  c.root_tolerance_m = 0.05;
  auto planner = NbvPlanner::create(c, home).value();
  const Waypoint current{{-4.6, 0.0, -1.75}, 0.4};
  const PlanResult r = planner->plan(map, current).value();
  ASSERT_FALSE(planner->traversability()->nearestSafe(current.p_world, c.root_tolerance_m).has_value());
  ASSERT_EQ(r.status, PlanStatus::kExplore) << r.reason;
  EXPECT_NE(r.reason.find("recovering"), std::string::npos) << r.reason;
  ASSERT_EQ(r.waypoints.size(), 1u);
  const Waypoint& escape = r.waypoints.front();
  EXPECT_TRUE(planner->traversability()->isSafe(escape.p_world));
  EXPECT_EQ(escape.yaw_rad, current.yaw_rad);
  EXPECT_LE((escape.p_world - current.p_world).norm(), c.recovery_radius_m);
  EXPECT_GT(escape.p_world.x(), current.p_world.x());  // away from the wall
  EXPECT_TRUE(planner->plan(map, escape).ok());

  c.recovery_radius_m = 0.0;
  auto off = NbvPlanner::create(c, home).value();
  const PlanResult none = off->plan(map, current).value();
  EXPECT_EQ(none.status, PlanStatus::kNoPath);
  EXPECT_NE(none.reason.find("recovery_radius_m"), std::string::npos) << none.reason;
}

TEST_F(PlannerMaps, AnEstimateMovedOutsideTheBoxMovesBackIn) {
  // A loop closure moved the estimate 0.8 m south of the exploration box, into free space of the map
  // (the box ends at y = -1.9, the known room at -3): farther out than root_tolerance_m, within
  // recovery_radius_m. The plan is one straight move, keeping the heading, to a safe voxel inside the
  // box; from there planning goes on. Farther out than recovery_radius_m is an error naming the box.
  const auto map = full();
  PlannerConfig c = roomConfig();
  c.box_min_world_m.y() = -1.9;
  const Waypoint home{{-3.0, 0.0, -1.75}, 0.0};
  auto planner = NbvPlanner::create(c, home).value();
  const Waypoint current{{-3.0, -2.7, -1.75}, 0.0};
  ASSERT_GT(Eigen::AlignedBox3d(c.box_min_world_m, c.box_max_world_m).exteriorDistance(current.p_world),
            c.root_tolerance_m);
  const PlanResult r = planner->plan(map, current).value();
  ASSERT_EQ(r.status, PlanStatus::kExplore) << r.reason;
  EXPECT_NE(r.reason.find("recovering"), std::string::npos) << r.reason;
  ASSERT_EQ(r.waypoints.size(), 1u);
  const Waypoint& in = r.waypoints.front();
  EXPECT_TRUE(planner->traversability()->isSafe(in.p_world));
  EXPECT_TRUE(planner->traversability()->insideBox(in.p_world));
  EXPECT_EQ(in.yaw_rad, current.yaw_rad);
  EXPECT_LE((in.p_world - current.p_world).norm(), c.recovery_radius_m);
  EXPECT_FALSE(test_fixtures::sweepTouchesNewOccupied(*map, current.p_world, in.p_world, c.collision_box_m));
  EXPECT_TRUE(planner->plan(map, in).ok());

  const Waypoint far{{-3.0, c.box_min_world_m.y() - c.recovery_radius_m - 0.1, -1.75}, 0.0};
  const auto err = planner->plan(map, far);
  ASSERT_FALSE(err.ok());
  EXPECT_NE(err.error().message.find("outside the exploration box"), std::string::npos) << err.error().message;
}

TEST_F(PlannerMaps, AfterAnObstructionTheVehicleBacksOffAndTheKeptBranchIsDropped) {
  // In the known room the vehicle at (-2, 0) heading east was stopped on its way to (0, 0) (by
  // something the map does not show): the next plan backs it off 0.3 m the way it came, keeping its
  // heading, and plans afresh from there (no seeded node).
  const auto map = full();
  const Waypoint home{{-3.0, -1.5, -1.75}, 0.0};
  PlannerConfig c = roomConfig();
  c.global_max_candidates = 20;
  auto planner = NbvPlanner::create(c, home).value();
  const Eigen::Vector3d stopped(-2.0, 0.0, -1.75), target(0.0, 0.0, -1.75);
  ASSERT_TRUE(planner->plan(map, {stopped, 0.0}).ok());

  const auto back = planner->reportObstruction(stopped, target + Eigen::Vector3d(0, 0, 0.5));
  ASSERT_TRUE(back.has_value());
  EXPECT_LT((*back - Eigen::Vector3d(-2.3, 0.0, -1.75)).norm(), 1e-9);  // horizontal, depth kept
  const PlanResult r = planner->plan(map, {stopped, 0.25}).value();
  ASSERT_EQ(r.status, PlanStatus::kExplore);
  ASSERT_EQ(r.waypoints.size(), 1u);
  EXPECT_EQ(r.waypoints[0].p_world, *back);
  EXPECT_EQ(r.waypoints[0].yaw_rad, 0.25);
  EXPECT_NE(r.reason.find("backing off"), std::string::npos) << r.reason;
  // Once: the next call plans normally, from the retreat, without the old branch.
  ASSERT_TRUE(planner->plan(map, {*back, 0.25}).ok());
  EXPECT_GT(planner->lastTree().size(), 1u);
  for (const TreeNode& n : planner->lastTree()) EXPECT_FALSE(n.seeded);
  // The place it ran into stays blocked although the map shows it free: no later edge sweeps the
  // box over the contact, half the footprint diagonal ahead of where it stopped.
  const Eigen::Vector3d contact = stopped + Eigen::Vector3d(std::sqrt(0.5), 0.0, 0.0);
  EXPECT_FALSE(planner->traversability()->isSafe(contact));
  EXPECT_FALSE(planner->traversability()->isSafe(stopped));
  for (int call = 0; call < 5; ++call) {
    const auto& tree = planner->lastTree();
    for (std::size_t i = 1; i < tree.size(); ++i) {
      const Eigen::Vector3d a = tree[static_cast<std::size_t>(tree[i].parent)].w.p_world, b = tree[i].w.p_world;
      for (double t = 0.0; t <= 1.0; t += 0.01) {
        const Eigen::Vector3d q = a + t * (b - a) - contact;
        EXPECT_GT(q.head<2>().cwiseAbs().maxCoeff(), 0.5 * std::sqrt(2.0)) << "edge " << i << " call " << call;
      }
    }
    ASSERT_TRUE(planner->plan(map, {*back, 0.25}).ok());
  }
  // Turning on the spot gives no direction; non-finite input is refused.
  EXPECT_FALSE(planner->reportObstruction(stopped, stopped).has_value());
  EXPECT_FALSE(planner->reportObstruction(Eigen::Vector3d(NAN, 0, 0), target).has_value());
}

// Complete, but home is not reachable through known free space: the way "home" ends at the
// reachable safe position nearest to home (plan() and planHome() alike), on free edges.
TEST(NbvPlanner, CompleteButNoWayHomeGoesToTheReachableSafePositionNearestHome) {
  const map::GridConfig config;
  auto all = [](const map::VoxelKey&) { return true; };
  // Two separate known rooms: the vehicle is in one, home in the other.
  const Eigen::AlignedBox3d west(Eigen::Vector3d(-5.0, -3.0, -3.0), Eigen::Vector3d(-0.5, 3.0, -0.5));
  const Eigen::AlignedBox3d east(Eigen::Vector3d(0.5, -3.0, -3.0), Eigen::Vector3d(5.0, 3.0, -0.5));
  auto map = test_fixtures::mergedOf(
      config, {test_fixtures::carvedGrid(config, west, all), test_fixtures::carvedGrid(config, east, all)});
  PlannerConfig c = roomConfig();
  c.n_tol = 20;  // (the gain is zero everywhere: a smaller tree says so sooner)
  c.max_samples = 200;
  const Waypoint home{{-3.0, 0.0, -1.75}, 0.0};
  const Waypoint current{{3.0, 0.0, -1.75}, 0.0};
  auto planner = NbvPlanner::create(c, home).value();
  const PlanResult r = planner->plan(map->snapshot(), current).value();
  ASSERT_EQ(r.status, PlanStatus::kNearHome) << r.reason;
  EXPECT_NE(r.reason.find("not reachable through known free space"), std::string::npos) << r.reason;
  ASSERT_FALSE(r.waypoints.empty());
  const TraversabilityGrid& grid = *planner->traversability();
  const Eigen::Vector3d end = r.waypoints.back().p_world;
  ASSERT_TRUE(grid.isSafe(end));
  // No reachable safe voxel is nearer to home.
  const auto reachable = grid.reachable(current.p_world, grid.statusArray().size());
  ASSERT_FALSE(reachable.empty());
  for (const map::VoxelKey& k : reachable)
    ASSERT_GE((map::keyToCentre(k, config.resolution_m) - home.p_world).norm(), (end - home.p_world).norm() - 1e-9);
  EXPECT_LT(end.x(), 2.0);  // the east room's west side, toward home
  expectPathValid(*map->snapshot(), planner->config(), current, r.waypoints);
  // The one way home says the same.
  const PlanResult h = planner->planHome(map->snapshot(), current).value();
  ASSERT_EQ(h.status, PlanStatus::kNearHome) << h.reason;
  EXPECT_EQ(h.waypoints.back().p_world, end);
}

// The clearance widens the checked box's vertical sides only (depth does not drift): a 1.8 m door
// lets the any-heading box (1.41 m) through without it and not with 0.2 m of clearance, and the
// vertical margin stays.
TEST(TraversabilityGrid, ClearanceNarrowsDoorsButNotTheVerticalMargin) {
  const Eigen::AlignedBox3d west(Eigen::Vector3d(-5.0, -3.0, -3.0), Eigen::Vector3d(-0.2, 3.0, -0.5));
  const Eigen::AlignedBox3d east(Eigen::Vector3d(0.2, -3.0, -3.0), Eigen::Vector3d(5.0, 3.0, -0.5));
  const Eigen::AlignedBox3d door(Eigen::Vector3d(-0.3, 0.0, -3.0), Eigen::Vector3d(0.3, 1.8, -0.5));
  auto map = test_fixtures::roomsWithADoor(map::GridConfig{}, west, east, door);
  const Eigen::Vector3d box(1.0, 1.0, 0.5);
  EXPECT_TRUE(anyHeadingFootprint(box, 0.2).vertical_cylinder);
  EXPECT_TRUE(
      anyHeadingFootprint(box, 0.2).size_m.isApprox(Eigen::Vector3d(std::sqrt(2.0) + 0.4, std::sqrt(2.0) + 0.4, 0.5)));
  const auto tight = TraversabilityGrid::build(*map, kRoom, anyHeadingFootprint(box)).value();
  const auto clear = TraversabilityGrid::build(*map, kRoom, anyHeadingFootprint(box, 0.2)).value();
  EXPECT_EQ(clear.inflationVoxels().z(), tight.inflationVoxels().z());
  EXPECT_EQ(clear.inflationVoxels().x(), tight.inflationVoxels().x() + 2);
  const Eigen::Vector3d from(-3.0, 0.9, -1.75), to(3.0, 0.9, -1.75);
  const auto through = tight.findPath(from, to);
  ASSERT_TRUE(through.ok()) << through.error().message;
  for (std::size_t i = 1; i < through->size(); ++i)
    EXPECT_TRUE(bruteForceEdgeFree(*map, (*through)[i - 1], (*through)[i], anyHeadingFootprint(box)));
  EXPECT_TRUE(clear.isSafe(from));
  EXPECT_TRUE(clear.isSafe(to));
  EXPECT_FALSE(clear.findPath(from, to).ok());
}

// A contact blocks its surroundings like an occupied voxel, outlives updates from snapshots that show
// its voxel free, and only a rebuild forgets it.
TEST(TraversabilityGrid, AContactStaysBlockedThroughUpdatesUntilARebuild) {
  const map::GridConfig config;
  auto all = [](const map::VoxelKey&) { return true; };
  const Eigen::AlignedBox3d west(kRoom.min(), Eigen::Vector3d(0.0, kRoom.max().y(), kRoom.max().z()));
  auto merged = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, west, all)});
  const Eigen::Vector3d box(1.0, 1.0, 0.5);
  auto grid = TraversabilityGrid::build(*merged->snapshot(), kRoom, anyHeadingFootprint(box)).value();
  const Eigen::Vector3d contact(-2.5, 0.0, -1.75), near(-2.0, 0.0, -1.75), far(-4.0, 0.0, -1.75);
  ASSERT_TRUE(grid.isSafe(contact));
  ASSERT_TRUE(grid.edgeIsFree(far, near));
  grid.addContact(contact);
  grid.addContact(Eigen::Vector3d(NAN, 0.0, 0.0));      // ignored
  grid.addContact(Eigen::Vector3d(100.0, 0.0, -1.75));  // outside the grid: ignored
  EXPECT_EQ(grid.status(map::pointToKey(contact, 1.0 / config.resolution_m)), map::Occupancy::kOccupied);
  EXPECT_FALSE(grid.isSafe(contact));
  EXPECT_FALSE(grid.isSafe(near));  // 0.5 m away: within the inflation
  EXPECT_TRUE(grid.isSafe(far));
  EXPECT_FALSE(grid.edgeIsFree(far, near));
  // A newer snapshot carves the whole room free, the contact's block included.
  ASSERT_TRUE(merged->add(test_fixtures::entryAtIdentity(1, test_fixtures::carvedGrid(config, kRoom, all))).ok());
  const auto newer = merged->snapshot();
  ASSERT_TRUE(grid.update(*newer).ok());
  EXPECT_FALSE(grid.isSafe(contact));
  EXPECT_FALSE(grid.edgeIsFree(far, near));
  const auto rebuilt = TraversabilityGrid::build(*newer, kRoom, anyHeadingFootprint(box)).value();
  EXPECT_TRUE(rebuilt.isSafe(contact));
  EXPECT_TRUE(rebuilt.edgeIsFree(far, near));
}

TEST(TraversabilityGrid, ReachableIsTheConnectedSafeRegionInBreadthFirstOrder) {
  const map::GridConfig config;
  const double res = config.resolution_m;
  auto all = [](const map::VoxelKey&) { return true; };
  const Eigen::AlignedBox3d west(Eigen::Vector3d(-5.0, -3.0, -3.0), Eigen::Vector3d(-0.5, 3.0, -0.5));
  const Eigen::AlignedBox3d east(Eigen::Vector3d(0.5, -3.0, -3.0), Eigen::Vector3d(5.0, 3.0, -0.5));
  auto map = test_fixtures::mergedOf(
      config, {test_fixtures::carvedGrid(config, west, all), test_fixtures::carvedGrid(config, east, all)});
  const auto grid = TraversabilityGrid::build(*map, kRoom, anyHeadingFootprint({1.0, 1.0, 0.5})).value();
  const Eigen::Vector3d from(-3.0, 0.0, -1.75);
  const auto order = grid.reachable(from, grid.statusArray().size());
  ASSERT_FALSE(order.empty());
  EXPECT_EQ(order.front(), map::pointToKey(from, 1.0 / res));
  // Exactly the safe voxels of the west room (the east room is safe too, but not connected).
  std::size_t west_safe = 0;
  const map::KeyBox keys = grid.gridKeys();
  map::VoxelKey k;
  for (k.z() = keys.min.z(); k.z() <= keys.max.z(); ++k.z())
    for (k.y() = keys.min.y(); k.y() <= keys.max.y(); ++k.y())
      for (k.x() = keys.min.x(); k.x() <= keys.max.x(); ++k.x())
        if (grid.isSafeKey(k) && map::keyToCentre(k, res).x() < 0.0) ++west_safe;
  ASSERT_GT(west_safe, 100u);
  EXPECT_EQ(order.size(), west_safe);
  // Breadth-first: every voxel after the first is a face neighbour of one listed before it, and
  // its step count is one more than that neighbour's (the first listed), never decreasing.
  std::map<std::tuple<int, int, int>, int> steps;
  steps[{order[0].x(), order[0].y(), order[0].z()}] = 0;
  int last_steps = 0;
  for (std::size_t i = 1; i < order.size(); ++i) {
    const map::VoxelKey& v = order[i];
    EXPECT_TRUE(grid.isSafeKey(v));
    EXPECT_LT(map::keyToCentre(v, res).x(), 0.0);
    int best = -1;
    for (const map::VoxelKey& d : {map::VoxelKey(1, 0, 0), map::VoxelKey(-1, 0, 0), map::VoxelKey(0, 1, 0),
                                   map::VoxelKey(0, -1, 0), map::VoxelKey(0, 0, 1), map::VoxelKey(0, 0, -1)}) {
      const map::VoxelKey n = v + d;
      const auto it = steps.find({n.x(), n.y(), n.z()});
      if (it != steps.end() && (best < 0 || it->second < best)) best = it->second;
    }
    ASSERT_GE(best, 0) << "voxel " << i << " has no earlier neighbour";
    const auto [pos, inserted] = steps.emplace(std::make_tuple(v.x(), v.y(), v.z()), best + 1);
    ASSERT_TRUE(inserted) << "voxel " << i << " listed twice";
    EXPECT_GE(pos->second, last_steps);
    last_steps = pos->second;
  }
  // The cap is honoured; an unsafe start gives nothing.
  EXPECT_EQ(grid.reachable(from, 10).size(), 10u);
  EXPECT_TRUE(grid.reachable(Eigen::Vector3d(0.0, 0.0, -1.75), 1000).empty());
}

}  // namespace
}  // namespace vog::plan
