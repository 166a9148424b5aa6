#include "vog/plan/traversability.hpp"

#include "plan_fixtures.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>

namespace vog::plan {
namespace {

using test_fixtures::bruteForceEdgeFree;

const Eigen::Vector3d kCollisionBox(1.0, 1.0, 0.5);
const Eigen::AlignedBox3d kPierBox(Eigen::Vector3d(-8.0, -8.0, -4.5), Eigen::Vector3d(8.0, 8.0, 0.5));

class PierTraversability : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    entries_ = new std::vector<map::SubmapEntry>(test_fixtures::pierSubmaps(map::GridConfig{}, 8, 60, 3));
  }
  static void TearDownTestSuite() {
    delete entries_;
    entries_ = nullptr;
  }
  static std::unique_ptr<map::MergedMap> merged(std::size_t first, std::size_t last) {
    auto m = map::MergedMap::create(map::GridConfig{}).value();
    for (std::size_t i = first; i < last; ++i) EXPECT_TRUE(m->add((*entries_)[i]).ok());
    return m;
  }
  static std::vector<map::SubmapEntry>* entries_;
};
std::vector<map::SubmapEntry>* PierTraversability::entries_ = nullptr;

TEST_F(PierTraversability, EdgeCheckIsConservativeAgainstBruteForce) {
  const auto map = merged(0, entries_->size());
  const auto grid = TraversabilityGrid::build(*map, kPierBox, Footprint::box(kCollisionBox)).value();
  ASSERT_GT(grid.safeCount(), 1000u);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> radius(2.0, 7.0);
  std::uniform_real_distribution<double> angle(0.0, 6.283);
  std::uniform_real_distribution<double> depth(-3.0, -1.0);
  int grid_free = 0;
  int brute_free = 0;
  for (int i = 0; i < 300; ++i) {
    // Edges around the orbit, where the sonar has seen free space; every other one starts at a safe
    // point, so that many edges are free.
    Eigen::Vector3d a;
    for (int tries = 0; tries < 2000; ++tries) {
      const double r = radius(rng);
      const double t = angle(rng);
      a = Eigen::Vector3d(r * std::cos(t), r * std::sin(t), depth(rng));
      if (i % 2 == 1 || grid.isSafe(a)) break;
    }
    const Eigen::Vector3d b = a + 2.0 * std::abs(u(rng)) * Eigen::Vector3d(u(rng), u(rng), 0.3 * u(rng)).normalized();
    const bool fast = grid.edgeIsFree(a, b);
    const bool brute = kPierBox.contains(a) && kPierBox.contains(b) && bruteForceEdgeFree(*map, a, b, kCollisionBox);
    // Conservative: never free when the brute-force check finds a non-free voxel in the swept box.
    ASSERT_FALSE(fast && !brute) << "edge " << a.transpose() << " -> " << b.transpose();
    grid_free += fast;
    brute_free += brute;
  }
  EXPECT_GE(grid_free, 30);  // the test exercises free edges, not only blocked ones
  // At most one voxel per side stricter than exact: most exactly-free edges stay free.
  EXPECT_GE(grid_free, brute_free / 2) << grid_free << " of " << brute_free;
}

TEST_F(PierTraversability, SafeFlagMatchesBruteForceBoxAtVoxelCentresNearTheBoundary) {
  const auto map = merged(0, entries_->size());
  const auto grid = TraversabilityGrid::build(*map, kPierBox, Footprint::box(kCollisionBox)).value();
  const Eigen::Vector3i r = grid.inflationVoxels();
  EXPECT_EQ(r, Eigen::Vector3i(6, 6, 3));  // floor(h / 0.095) + 1
  // Safe voxel v <=> every voxel within r of v is known free (the definition, checked literally).
  std::mt19937_64 rng(8);
  std::uniform_int_distribution<int> ux(grid.gridKeys().min.x(), grid.gridKeys().max.x());
  std::uniform_int_distribution<int> uy(grid.gridKeys().min.y(), grid.gridKeys().max.y());
  std::uniform_int_distribution<int> uz(grid.gridKeys().min.z(), grid.gridKeys().max.z());
  int safe = 0;
  for (int i = 0; i < 20000 && safe < 200; ++i) {
    const map::VoxelKey v(ux(rng), uy(rng), uz(rng));
    bool expect = true;
    for (int dz = -r.z(); dz <= r.z() && expect; ++dz)
      for (int dy = -r.y(); dy <= r.y() && expect; ++dy)
        for (int dx = -r.x(); dx <= r.x() && expect; ++dx) {
          const map::VoxelKey k = v + map::VoxelKey(dx, dy, dz);
          expect = grid.gridKeys().contains(k) && map->at(k).status == map::Occupancy::kFree;
        }
    ASSERT_EQ(grid.isSafeKey(v), expect) << v.transpose();
    safe += expect;
  }
  EXPECT_GT(safe, 20);
}

TEST_F(PierTraversability, IncrementalUpdateEqualsRebuild) {
  // Grow the map as the merge thread does, with a removal (a submap leaving) in between.
  auto writer = map::MergedMap::create(map::GridConfig{}).value();
  for (std::size_t i = 0; i < 3; ++i) ASSERT_TRUE(writer->add((*entries_)[i]).ok());
  auto grid = TraversabilityGrid::build(*writer->snapshot(), kPierBox, Footprint::box(kCollisionBox)).value();
  const std::size_t safe_before = grid.safeCount();
  for (std::size_t i = 3; i < entries_->size(); ++i) {
    ASSERT_TRUE(writer->add((*entries_)[i]).ok());
    if (i == 5) {
      ASSERT_TRUE(writer->remove((*entries_)[1].id).ok());
    }
    if (i % 2 == 0 && i + 1 < entries_->size()) continue;  // sometimes two changes per update
    const auto snap = writer->snapshot();
    const auto stats = grid.update(*snap).value();
    EXPECT_FALSE(stats.rebuilt);
    EXPECT_GT(stats.blocks_read, 0);
    const auto scratch = TraversabilityGrid::build(*snap, kPierBox, Footprint::box(kCollisionBox)).value();
    ASSERT_TRUE(grid.sameFlags(scratch)) << "after submap " << i;
    EXPECT_EQ(grid.mapVersion(), snap->version());
  }
  EXPECT_NE(grid.safeCount(), safe_before);  // the updates changed something
  // Removing everything leaves nothing safe.
  for (std::size_t i = 0; i < entries_->size(); ++i) {
    if (i != 1) {
      ASSERT_TRUE(writer->remove((*entries_)[i].id).ok());
    }
  }
  ASSERT_TRUE(grid.update(*writer->snapshot()).ok());
  EXPECT_EQ(grid.safeCount(), 0u);
}

// The flags an update made stale are recomputed by the queries that read them, a group of blocks at a
// time: voxel by voxel, in a scattered order and before anything settles the whole grid, the queries
// answer as a rebuilt grid does.
TEST_F(PierTraversability, QueriesAfterAnUpdateReadTheRebuiltFlags) {
  auto writer = merged(0, 3);
  auto grid = TraversabilityGrid::build(*writer->snapshot(), kPierBox, Footprint::box(kCollisionBox)).value();
  for (std::size_t i = 3; i < entries_->size(); ++i) ASSERT_TRUE(writer->add((*entries_)[i]).ok());
  const auto snap = writer->snapshot();
  const auto stats = grid.update(*snap).value();
  EXPECT_GT(stats.blocks_stale, 0);
  const auto scratch = TraversabilityGrid::build(*snap, kPierBox, Footprint::box(kCollisionBox)).value();
  std::vector<map::VoxelKey> keys;
  const map::KeyBox g = grid.gridKeys();
  map::VoxelKey k;
  for (k.z() = g.min.z(); k.z() <= g.max.z(); ++k.z())
    for (k.y() = g.min.y(); k.y() <= g.max.y(); ++k.y())
      for (k.x() = g.min.x(); k.x() <= g.max.x(); ++k.x()) keys.push_back(k);
  std::shuffle(keys.begin(), keys.end(), std::mt19937(1));
  std::size_t safe = 0;
  for (const map::VoxelKey& key : keys) {
    ASSERT_EQ(grid.isSafeKey(key), scratch.isSafeKey(key)) << key.transpose();
    safe += scratch.isSafeKey(key) ? 1 : 0;
  }
  EXPECT_GT(safe, 0u);
  EXPECT_TRUE(grid.sameFlags(scratch));
}

// A submap merged out and back in at the same pose gives every block it touches a new version and the
// same sums: the update reads them and recomputes no safe flag (as after a loop closure that moves
// submaps without changing what is free).
TEST_F(PierTraversability, ReMergeWithTheSameStatusesRecomputesNothing) {
  auto writer = merged(0, entries_->size());
  auto grid = TraversabilityGrid::build(*writer->snapshot(), kPierBox, Footprint::box(kCollisionBox)).value();
  ASSERT_TRUE(writer->remove((*entries_)[3].id).ok());
  ASSERT_TRUE(writer->add((*entries_)[3]).ok());
  const auto snap = writer->snapshot();
  const auto stats = grid.update(*snap).value();
  EXPECT_GT(stats.blocks_read, 100);
  EXPECT_EQ(stats.blocks_stale, 0);
  const auto scratch = TraversabilityGrid::build(*snap, kPierBox, Footprint::box(kCollisionBox)).value();
  EXPECT_TRUE(grid.sameFlags(scratch));
}

// Changes at both ends of a long box make the blocks around each end stale, not a box spanning the
// length between them, and the flags equal a rebuild's.
TEST(Traversability, ChangesAtBothEndsOfALongBoxAreRecomputedApart) {
  const map::GridConfig config;
  const Eigen::AlignedBox3d box(Eigen::Vector3d(-12.0, -1.5, -2.5), Eigen::Vector3d(12.0, 1.5, -0.5));
  auto all = [](const map::VoxelKey&) { return true; };
  const auto room = [&](double x0, double x1) {
    return test_fixtures::carvedGrid(
        config, Eigen::AlignedBox3d(Eigen::Vector3d(x0, -1.4, -2.4), Eigen::Vector3d(x1, 1.4, -0.6)), all);
  };
  auto writer = test_fixtures::mergedOf(config, {room(-11.5, -8.0), room(8.0, 11.5)});
  auto grid = TraversabilityGrid::build(*writer->snapshot(), box, Footprint::box(kCollisionBox)).value();
  // Each end's room grows by a carved room beside it.
  ASSERT_TRUE(writer->add(test_fixtures::entryAtIdentity(2, room(-8.5, -6.0))).ok());
  ASSERT_TRUE(writer->add(test_fixtures::entryAtIdentity(3, room(6.0, 8.5))).ok());
  const auto snap = writer->snapshot();
  const auto stats = grid.update(*snap).value();
  const Eigen::Vector3i blocks =
      (grid.gridSize().array() + map::MergedMap::kBlockSide - 1) / map::MergedMap::kBlockSide;
  const int grid_blocks = blocks.x() * blocks.y() * blocks.z();
  EXPECT_GT(stats.blocks_stale, 0);
  // One box around both ends spans about 17 of the grid's 25 m; the two runs about 2 x 4 m.
  EXPECT_LT(stats.blocks_stale, grid_blocks / 2) << "of " << grid_blocks;
  const auto scratch = TraversabilityGrid::build(*snap, box, Footprint::box(kCollisionBox)).value();
  EXPECT_TRUE(grid.sameFlags(scratch));
  EXPECT_GT(grid.safeCount(), 0u);
}

// The any-heading footprint: a vertical cylinder (1.41 m across and 0.5 m high, the 1 x 1 x 0.5 m box
// turning on the spot, grown by 0.3 m of clearance).
const Footprint kCylinder = Footprint::cylinder(std::sqrt(2.0) + 0.6, 0.5);

TEST_F(PierTraversability, CylinderSafeFlagIsTheDiscDefinitionCheckedLiterally) {
  const auto map = merged(0, entries_->size());
  const auto grid = TraversabilityGrid::build(*map, kPierBox, kCylinder).value();
  const Eigen::Vector3i r = grid.inflationVoxels();
  const double rho = 0.5 * kCylinder.size_m.x() / map->resolution();
  EXPECT_EQ(r, Eigen::Vector3i(11, 11, 3));  // floor(rho) + 1 = floor(10.6) + 1; floor(0.25 / 0.095) + 1
  // Safe voxel v <=> every voxel whose cell comes within rho of v's cell (horizontally), within r_z
  // layers, is known free.
  std::mt19937_64 rng(9);
  std::uniform_int_distribution<int> ux(grid.gridKeys().min.x(), grid.gridKeys().max.x());
  std::uniform_int_distribution<int> uy(grid.gridKeys().min.y(), grid.gridKeys().max.y());
  std::uniform_int_distribution<int> uz(grid.gridKeys().min.z(), grid.gridKeys().max.z());
  int safe = 0, unsafe_by_a_corner_only = 0;
  for (int i = 0; i < 40000 && safe < 200; ++i) {
    const map::VoxelKey v(ux(rng), uy(rng), uz(rng));
    bool expect = true, square = true;
    for (int dz = -r.z(); dz <= r.z(); ++dz)
      for (int dy = -r.y(); dy <= r.y(); ++dy)
        for (int dx = -r.x(); dx <= r.x(); ++dx) {
          const map::VoxelKey k = v + map::VoxelKey(dx, dy, dz);
          const bool free = grid.gridKeys().contains(k) && map->at(k).status == map::Occupancy::kFree;
          const double mx = std::max(std::abs(dx) - 1, 0), my = std::max(std::abs(dy) - 1, 0);
          if (!free && mx * mx + my * my <= rho * rho) expect = false;
          if (!free) square = false;
        }
    ASSERT_EQ(grid.isSafeKey(v), expect) << v.transpose();
    safe += expect;
    unsafe_by_a_corner_only += expect && !square;
  }
  EXPECT_GT(safe, 20);
  EXPECT_GT(unsafe_by_a_corner_only, 0) << "the disc admits voxels the square around it refuses";
}

TEST_F(PierTraversability, CylinderEdgeCheckIsConservativeAndIncrementalUpdateEqualsRebuild) {
  auto writer = map::MergedMap::create(map::GridConfig{}).value();
  for (std::size_t i = 0; i < 3; ++i) ASSERT_TRUE(writer->add((*entries_)[i]).ok());
  auto grid = TraversabilityGrid::build(*writer->snapshot(), kPierBox, kCylinder).value();
  for (std::size_t i = 3; i < entries_->size(); ++i) {
    ASSERT_TRUE(writer->add((*entries_)[i]).ok());
    if (i == 5) {
      ASSERT_TRUE(writer->remove((*entries_)[1].id).ok());
    }
    const auto snap = writer->snapshot();
    ASSERT_TRUE(grid.update(*snap).ok());
    ASSERT_TRUE(grid.sameFlags(TraversabilityGrid::build(*snap, kPierBox, kCylinder).value())) << "after submap " << i;
  }
  const auto map = writer->snapshot();
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> u(-1.0, 1.0), radius(2.0, 7.0), angle(0.0, 6.283), depth(-3.0, -1.0);
  int grid_free = 0;
  for (int i = 0; i < 300; ++i) {
    Eigen::Vector3d a;
    for (int tries = 0; tries < 2000; ++tries) {
      const double t = angle(rng), r = radius(rng);
      a = Eigen::Vector3d(r * std::cos(t), r * std::sin(t), depth(rng));
      if (i % 2 == 1 || grid.isSafe(a)) break;
    }
    const Eigen::Vector3d b = a + 2.0 * std::abs(u(rng)) * Eigen::Vector3d(u(rng), u(rng), 0.3 * u(rng)).normalized();
    const bool fast = grid.edgeIsFree(a, b);
    ASSERT_FALSE(fast && !bruteForceEdgeFree(*map, a, b, kCylinder))
        << "edge " << a.transpose() << " -> " << b.transpose();
    grid_free += fast;
  }
  EXPECT_GE(grid_free, 20);  // the test exercises free edges, not only blocked ones
}

TEST_F(PierTraversability, OlderSnapshotIsAnError) {
  auto writer = map::MergedMap::create(map::GridConfig{}).value();
  ASSERT_TRUE(writer->add((*entries_)[0]).ok());
  const auto old_snap = writer->snapshot();
  ASSERT_TRUE(writer->add((*entries_)[1]).ok());
  auto grid = TraversabilityGrid::build(*writer->snapshot(), kPierBox, Footprint::box(kCollisionBox)).value();
  const auto r = grid.update(*old_snap);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("older"), std::string::npos);
}

TEST(Traversability, CarvedRoomMarginsAndPathHome) {
  const map::GridConfig config;
  const Eigen::AlignedBox3d room(Eigen::Vector3d(-3.0, -2.0, -2.5), Eigen::Vector3d(3.0, 2.0, -0.5));
  auto all = [](const map::VoxelKey&) { return true; };
  const auto grid_room = test_fixtures::carvedGrid(config, room, all);
  auto map = test_fixtures::mergedOf(config, {grid_room});
  const auto grid = TraversabilityGrid::build(*map, room, Footprint::box(kCollisionBox)).value();
  // Exactly known room: a box centre is safe iff it keeps r voxels from the walls.
  const map::KeyBox free_keys = test_fixtures::centreKeys(room, config.resolution_m);
  const Eigen::Vector3i r = grid.inflationVoxels();
  map::VoxelKey k;
  std::size_t expected = 0;
  for (k.z() = free_keys.min.z(); k.z() <= free_keys.max.z(); ++k.z())
    for (k.y() = free_keys.min.y(); k.y() <= free_keys.max.y(); ++k.y())
      for (k.x() = free_keys.min.x(); k.x() <= free_keys.max.x(); ++k.x()) {
        const bool inner =
            ((k - free_keys.min).array() >= r.array()).all() && ((free_keys.max - k).array() >= r.array()).all();
        ASSERT_EQ(grid.isSafeKey(k), inner) << k.transpose();
        expected += inner;
      }
  EXPECT_EQ(grid.safeCount(), expected);
  EXPECT_GT(expected, 0u);
  // A path across the room: every returned edge is free, ends are exact.
  const Eigen::Vector3d from(-2.2, -1.2, -1.5);
  const Eigen::Vector3d to(2.2, 1.2, -1.5);
  const auto path = grid.findPath(from, to).value();
  ASSERT_GE(path.size(), 2u);
  EXPECT_EQ(path.front(), from);
  EXPECT_EQ(path.back(), to);
  for (std::size_t i = 1; i < path.size(); ++i) {
    EXPECT_TRUE(grid.edgeIsFree(path[i - 1], path[i]));
    EXPECT_TRUE(bruteForceEdgeFree(*map, path[i - 1], path[i], kCollisionBox));
  }
  // Unsafe goal (against a wall): an error naming the goal.
  const auto bad = grid.findPath(from, Eigen::Vector3d(2.9, 1.9, -0.6));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("goal"), std::string::npos);
}

// Every voxel, not a sample: a room with walls full of gaps (unknown) and pillars of one voxel
// scattered inside; the cylinder's safe flags equal the disc definition evaluated on the grid's own
// status copy at every voxel of the room.
TEST(Traversability, CylinderSafeFlagIsTheDiscDefinitionAtEveryVoxelOfARoom) {
  const map::GridConfig config;
  const double res = config.resolution_m;
  const Eigen::AlignedBox3d room(Eigen::Vector3d(-2.5, -2.0, -1.5), Eigen::Vector3d(2.5, 2.0, -0.7));
  const auto walls =
      test_fixtures::carvedGrid(config, room, [](const map::VoxelKey& k) { return (k.x() + 2 * k.y()) % 3 != 0; });
  auto pillars = map::LocalGrid::create(config).value();
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> ux(-2.3, 2.3), uy(-1.8, 1.8), uz(-1.4, -0.8);
  for (int i = 0; i < 5; ++i) {
    const Eigen::Vector3d p(ux(rng), uy(rng), uz(rng));
    const map::BeamEnd hit{p, true};
    ASSERT_TRUE(pillars->insertRays(p - Eigen::Vector3d(0.0, 0.0, 2.0 * res), {&hit, 1}).ok());
  }
  pillars->finalize();
  const auto map = test_fixtures::mergedOf(config, {walls, std::shared_ptr<const map::LocalGrid>(std::move(pillars))});
  const Footprint cylinder = Footprint::cylinder(1.3, 0.3);
  const auto grid = TraversabilityGrid::build(*map, room, cylinder).value();
  const Eigen::Vector3i r = grid.inflationVoxels();
  const double rho = 0.5 * cylinder.size_m.x() / res;
  const map::KeyBox& keys = grid.gridKeys();
  auto blocked = [&](const map::VoxelKey& k) {
    if (!keys.contains(k)) return true;
    const map::VoxelKey d = k - keys.min;
    const std::size_t i = static_cast<std::size_t>(d.x()) +
                          static_cast<std::size_t>(grid.gridSize().x()) *
                              (static_cast<std::size_t>(d.y()) +
                               static_cast<std::size_t>(grid.gridSize().y()) * static_cast<std::size_t>(d.z()));
    return grid.statusArray()[i] != static_cast<std::uint8_t>(map::Occupancy::kFree);
  };
  const map::KeyBox inside = test_fixtures::centreKeys(room, res);
  int safe = 0, unsafe = 0;
  map::VoxelKey v;
  for (v.z() = inside.min.z(); v.z() <= inside.max.z(); ++v.z())
    for (v.y() = inside.min.y(); v.y() <= inside.max.y(); ++v.y())
      for (v.x() = inside.min.x(); v.x() <= inside.max.x(); ++v.x()) {
        bool expect = true;
        for (int dz = -r.z(); dz <= r.z() && expect; ++dz)
          for (int dy = -r.y(); dy <= r.y() && expect; ++dy)
            for (int dx = -r.x(); dx <= r.x() && expect; ++dx) {
              const double mx = std::max(std::abs(dx) - 1, 0), my = std::max(std::abs(dy) - 1, 0);
              if (mx * mx + my * my <= rho * rho && blocked(v + map::VoxelKey(dx, dy, dz))) expect = false;
            }
        ASSERT_EQ(grid.isSafeKey(v), expect) << v.transpose();
        (expect ? safe : unsafe) += 1;
      }
  EXPECT_GT(safe, 200) << unsafe;
  EXPECT_GT(unsafe, 200) << safe;
}

TEST(Traversability, PathAroundAWallThroughADoor) {
  // Two rooms joined by a 1.5 m wide door in a wall at x = 0: the path must go through the door.
  const Eigen::AlignedBox3d west(Eigen::Vector3d(-4.0, -3.0, -2.0), Eigen::Vector3d(-0.2, 3.0, -0.8));
  const Eigen::AlignedBox3d east(Eigen::Vector3d(0.2, -3.0, -2.0), Eigen::Vector3d(4.0, 3.0, -0.8));
  const Eigen::AlignedBox3d door(Eigen::Vector3d(-0.3, 1.0, -2.0), Eigen::Vector3d(0.3, 2.5, -0.8));
  auto map = test_fixtures::roomsWithADoor(map::GridConfig{}, west, east, door);
  const Eigen::AlignedBox3d box(Eigen::Vector3d(-4.0, -3.0, -2.0), Eigen::Vector3d(4.0, 3.0, -0.8));
  const auto grid = TraversabilityGrid::build(*map, box, Footprint::box(kCollisionBox)).value();
  const Eigen::Vector3d from(-3.0, -2.0, -1.4);
  const Eigen::Vector3d to(3.0, -2.0, -1.4);
  EXPECT_FALSE(grid.edgeIsFree(from, to));
  const auto path = grid.findPath(from, to).value();
  bool through_door = false;
  for (std::size_t i = 1; i < path.size(); ++i) {
    ASSERT_TRUE(bruteForceEdgeFree(*map, path[i - 1], path[i], kCollisionBox));
    through_door = through_door || (path[i].y() > 1.0 && path[i].y() < 2.5);
  }
  EXPECT_TRUE(through_door);
}

TEST(Traversability, ASnapshotOfAnotherMapIsAnErrorEvenAtTheSameVersion) {
  // Two maps built the same way (one submap each, so the same version) but of different rooms: the
  // grid of the first cannot catch up with the second by its changed blocks (there are none since
  // that version); update() must refuse so that the caller rebuilds.
  const map::GridConfig config;
  auto all = [](const map::VoxelKey&) { return true; };
  const Eigen::AlignedBox3d small(Eigen::Vector3d(-2.0, -2.0, -2.0), Eigen::Vector3d(0.0, 2.0, -0.5));
  const Eigen::AlignedBox3d large(Eigen::Vector3d(-2.0, -2.0, -2.0), Eigen::Vector3d(2.0, 2.0, -0.5));
  auto a = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, small, all)});
  auto b = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, large, all)});
  ASSERT_EQ(a->version(), b->version());
  ASSERT_NE(a->writerId(), b->writerId());
  auto grid = TraversabilityGrid::build(*a->snapshot(), large, Footprint::box(kCollisionBox)).value();
  const auto u = grid.update(*b->snapshot());
  ASSERT_FALSE(u.ok());
  EXPECT_NE(u.error().message.find("another map"), std::string::npos);
  // Snapshots of one writer share its id.
  EXPECT_EQ(a->snapshot()->writerId(), a->writerId());
  EXPECT_TRUE(grid.update(*a->snapshot()).ok());
}

TEST(Traversability, BadBoxesAreErrors) {
  const map::GridConfig config;
  auto map = map::MergedMap::create(config).value();
  const Eigen::AlignedBox3d flat(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 0));
  EXPECT_FALSE(TraversabilityGrid::build(*map, flat, Footprint::box(kCollisionBox)).ok());
  const Eigen::AlignedBox3d box(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1));
  EXPECT_FALSE(TraversabilityGrid::build(*map, box, Footprint::box(Eigen::Vector3d(1, 0, 1))).ok());
  const Eigen::AlignedBox3d huge(Eigen::Vector3d(-1e4, -1e4, -1e4), Eigen::Vector3d(1e4, 1e4, 1e4));
  const auto r = TraversabilityGrid::build(*map, huge, Footprint::box(kCollisionBox));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("voxels"), std::string::npos);
  // An empty map: nothing is safe, no edge is free, NaN is never free.
  const auto g = TraversabilityGrid::build(*map, box, Footprint::box(kCollisionBox)).value();
  EXPECT_EQ(g.safeCount(), 0u);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(g.edgeIsFree(Eigen::Vector3d(0.5, 0.5, 0.5), Eigen::Vector3d(nan, 0.5, 0.5)));
}

// The assumed-free sphere around the start: unknown space there counts as free, occupied space
// stays blocked, nothing outside it changes; the same after an incremental update.
TEST_F(PierTraversability, AssumedFreeSphereFreesUnknownOnly) {
  const auto map = merged(0, entries_->size());
  const Eigen::Vector3d centre(0.0, -6.0, -2.0);  // open water beside the pier
  const AssumedFree sphere{centre, 1.5};
  const auto plain = TraversabilityGrid::build(*map, kPierBox, Footprint::box(kCollisionBox)).value();
  const auto with = TraversabilityGrid::build(*map, kPierBox, Footprint::box(kCollisionBox), sphere).value();
  ASSERT_TRUE(with.isSafe(centre));
  std::size_t freed = 0;
  for (double x = -3.0; x <= 3.0; x += 0.05)
    for (double z = -4.0; z <= 0.0; z += 0.05) {
      const Eigen::Vector3d p(x, -6.0, z);
      const map::VoxelKey k = map::pointToKey(p, 1.0 / map->resolution());
      const map::Occupancy before = plain.status(k);
      const map::Occupancy after = with.status(k);
      const bool inside = (map::keyToCentre(k, map->resolution()) - centre).norm() <= 1.5;
      if (before == map::Occupancy::kUnknown && inside) {
        EXPECT_EQ(after, map::Occupancy::kFree);
        ++freed;
      } else {
        EXPECT_EQ(after, before);
      }
    }
  EXPECT_GT(freed, 0u);
  EXPECT_FALSE(TraversabilityGrid::build(*map, kPierBox, Footprint::box(kCollisionBox), {centre, -1.0}).ok());
}

TEST(Traversability, RecoveryGoesAroundAWallNotThroughIt) {
  // A corridor too narrow for the box between the room's south wall and a thin wall along x: no voxel
  // in it is safe. The nearest safe voxels lie just north of the thin wall; the recovery move must go
  // round its end instead, and finds nothing when the radius does not reach that far.
  const map::GridConfig config;
  const Eigen::AlignedBox3d room(Eigen::Vector3d(-3.0, -1.3, -2.5), Eigen::Vector3d(3.0, 2.0, -0.5));
  const Eigen::AlignedBox3d slab(Eigen::Vector3d(-1.0, -0.05, -2.5), Eigen::Vector3d(1.0, 0.05, -0.5));
  auto all = [](const map::VoxelKey&) { return true; };
  auto map = test_fixtures::mergedOf(
      config, {test_fixtures::carvedGrid(config, room, all), test_fixtures::carvedGrid(config, slab, all)});
  const auto grid = TraversabilityGrid::build(*map, room, Footprint::box(kCollisionBox)).value();
  const Eigen::Vector3d p(0.0, -0.7, -1.5);
  ASSERT_FALSE(grid.isSafe(p));
  ASSERT_FALSE(test_fixtures::sweepTouchesNewOccupied(*map, p, p, kCollisionBox));
  const auto nearest = grid.nearestSafe(p, 1.6);
  ASSERT_TRUE(nearest.has_value());
  ASSERT_GT(nearest->y(), 0.0);  // across the thin wall
  ASSERT_TRUE(test_fixtures::sweepTouchesNewOccupied(*map, p, *nearest, kCollisionBox));

  EXPECT_FALSE(grid.nearestSafeClearOfOccupied(*map, p, 0.0, kCollisionBox, 1.6).has_value());
  const auto escape = grid.nearestSafeClearOfOccupied(*map, p, 0.0, kCollisionBox, 3.0);
  ASSERT_TRUE(escape.has_value());
  EXPECT_TRUE(grid.isSafe(*escape));
  EXPECT_GT(std::abs(escape->x()), 1.0);  // round an end of the thin wall
  EXPECT_FALSE(test_fixtures::sweepTouchesNewOccupied(*map, p, *escape, kCollisionBox));
  EXPECT_FALSE(grid.nearestSafeClearOfOccupied(*map, p, std::numeric_limits<double>::quiet_NaN(), kCollisionBox, 3.0));
}

// A wall across the room outside the grid: the exploration box ends 1.4 m north of it, farther than
// the grid's margin, and the estimate (moved there by a loop closure) lies south of it. The recovery
// move reads those voxels from the snapshot: no move through the wall; without the wall, straight in.
TEST(Traversability, RecoverySeesWallsOutsideTheGrid) {
  const map::GridConfig config;
  const Eigen::AlignedBox3d room(Eigen::Vector3d(-3.0, -3.0, -2.5), Eigen::Vector3d(3.0, 2.0, -0.5));
  const Eigen::AlignedBox3d slab(Eigen::Vector3d(-3.0, -1.9, -2.5), Eigen::Vector3d(3.0, -1.8, -0.5));
  const Eigen::AlignedBox3d box(Eigen::Vector3d(-3.0, -0.4, -2.5), room.max());
  const Eigen::Vector3d p(0.0, -2.5, -1.5);
  auto all = [](const map::VoxelKey&) { return true; };
  auto walled = test_fixtures::mergedOf(
      config, {test_fixtures::carvedGrid(config, room, all), test_fixtures::carvedGrid(config, slab, all)});
  const auto grid = TraversabilityGrid::build(*walled, box, Footprint::box(kCollisionBox)).value();
  const map::VoxelKey wall_key = map::pointToKey(Eigen::Vector3d(0.0, -1.95, -1.5), 1.0 / config.resolution_m);
  ASSERT_EQ(walled->at(wall_key).status, map::Occupancy::kOccupied);
  ASSERT_EQ(grid.status(wall_key), map::Occupancy::kUnknown);  // outside the grid
  ASSERT_FALSE(test_fixtures::sweepTouchesNewOccupied(*walled, p, p, kCollisionBox));
  EXPECT_FALSE(grid.nearestSafeClearOfOccupied(*walled, p, 0.0, kCollisionBox, 3.0).has_value());

  auto open = test_fixtures::mergedOf(config, {test_fixtures::carvedGrid(config, room, all)});
  const auto open_grid = TraversabilityGrid::build(*open, box, Footprint::box(kCollisionBox)).value();
  const auto escape = open_grid.nearestSafeClearOfOccupied(*open, p, 0.0, kCollisionBox, 3.0);
  ASSERT_TRUE(escape.has_value());
  EXPECT_TRUE(open_grid.isSafe(*escape));
  EXPECT_FALSE(test_fixtures::sweepTouchesNewOccupied(*open, p, *escape, kCollisionBox));
}

}  // namespace
}  // namespace vog::plan
