#pragma once
// Merged maps for the planner tests: carved rooms with exactly known free space and walls, and sonar
// maps of the synthetic pier built from real scans.

#include "vog/map/merged_map.hpp"
#include "vog/plan/traversability.hpp"

#include "synthetic_scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

namespace vog::plan::test_fixtures {

using map::VoxelKey;

// Keys of the voxels whose centres lie in the box.
inline map::KeyBox centreKeys(const Eigen::AlignedBox3d& box, double res) {
  map::KeyBox k;
  for (int i = 0; i < 3; ++i) {
    k.min[i] = static_cast<int>(std::ceil(box.min()[i] / res - 0.5));
    k.max[i] = static_cast<int>(std::floor(box.max()[i] / res - 0.5));
  }
  return k;
}

// One LocalGrid at the identity pose: every voxel whose centre is in `free_box` is seen free once
// (axis-aligned rays along x), and every voxel of the one-voxel shell around it for which `wall(key)`
// holds is hit once (occupied). Everything else stays unknown.
inline std::shared_ptr<const map::LocalGrid> carvedGrid(const map::GridConfig& config,
                                                        const Eigen::AlignedBox3d& free_box,
                                                        const std::function<bool(const VoxelKey&)>& wall) {
  auto grid = map::LocalGrid::create(config).value();
  const double res = config.resolution_m;
  const map::KeyBox k = centreKeys(free_box, res);
  for (int z = k.min.z(); z <= k.max.z(); ++z)
    for (int y = k.min.y(); y <= k.max.y(); ++y) {
      const map::BeamEnd beam{map::keyToCentre(VoxelKey(k.max.x(), y, z), res), false};
      EXPECT_TRUE(grid->insertRays(map::keyToCentre(VoxelKey(k.min.x(), y, z), res), {&beam, 1}).ok());
    }
  VoxelKey s;
  for (s.z() = k.min.z() - 1; s.z() <= k.max.z() + 1; ++s.z())
    for (s.y() = k.min.y() - 1; s.y() <= k.max.y() + 1; ++s.y())
      for (s.x() = k.min.x() - 1; s.x() <= k.max.x() + 1; ++s.x()) {
        if (k.contains(s) || !wall(s)) continue;
        const VoxelKey inside = s.cwiseMax(k.min).cwiseMin(k.max);
        const map::BeamEnd beam{map::keyToCentre(s, res), true};
        EXPECT_TRUE(grid->insertRays(map::keyToCentre(inside, res), {&beam, 1}).ok());
      }
  grid->finalize();
  return std::shared_ptr<const map::LocalGrid>(std::move(grid));
}

inline map::SubmapEntry entryAtIdentity(map::SubmapId id, std::shared_ptr<const map::LocalGrid> grid) {
  map::SubmapEntry e;
  e.id = id;
  e.grid = std::move(grid);
  return e;
}

inline std::unique_ptr<map::MergedMap> mergedOf(const map::GridConfig& config,
                                                const std::vector<std::shared_ptr<const map::LocalGrid>>& grids) {
  auto merged = map::MergedMap::create(config).value();
  map::SubmapId id = 0;
  for (const auto& g : grids) EXPECT_TRUE(merged->add(entryAtIdentity(id++, g)).ok());
  return merged;
}

// Two carved rooms and the door between them (a carved box across the wall): the rooms' walls leave
// out the voxels whose centres are strictly inside the door's x-y extent (a wall voxel seen free
// once and hit once stays occupied).
inline std::unique_ptr<map::MergedMap> roomsWithADoor(const map::GridConfig& config, const Eigen::AlignedBox3d& west,
                                                      const Eigen::AlignedBox3d& east,
                                                      const Eigen::AlignedBox3d& door) {
  auto notInDoor = [&](const VoxelKey& k) {
    const Eigen::Vector3d c = map::keyToCentre(k, config.resolution_m);
    return !((c.head<2>().array() > door.min().head<2>().array()).all() &&
             (c.head<2>().array() < door.max().head<2>().array()).all());
  };
  auto none = [](const VoxelKey&) { return false; };
  return mergedOf(config, {carvedGrid(config, west, notInDoor), carvedGrid(config, east, notInDoor),
                           carvedGrid(config, door, none)});
}

// Sonar submaps of the synthetic pier: scans along an orbit (radius 5.5 m, depth 2 m), split into
// submaps of `scans_per_submap`, each at its first scan's true pose.
inline std::vector<map::SubmapEntry> pierSubmaps(const map::GridConfig& config, int n_submaps, int scans_per_submap,
                                                 std::uint64_t seed) {
  const auto scene = vog::test::SyntheticScene::pier();
  geometry::SonarFan fan;
  fan.max_range_m = 5.0;
  std::mt19937_64 rng(seed);
  const auto poses = vog::test::orbitTrajectory(n_submaps * scans_per_submap, 5.5, -2.0);
  std::vector<map::SubmapEntry> out;
  for (int s = 0; s < n_submaps; ++s) {
    auto grid = map::LocalGrid::create(config).value();
    const geometry::Pose3 T_world_base = poses[static_cast<std::size_t>(s * scans_per_submap)];
    for (int k = 0; k < scans_per_submap; ++k) {
      const geometry::Pose3& T = poses[static_cast<std::size_t>(s * scans_per_submap + k)];
      EXPECT_TRUE(
          grid->insertScan(T_world_base.inverse() * T * fan.T_vehicle_sensor, fan, scene.scan(T, fan, 0.01, rng)).ok());
    }
    grid->finalize();
    map::SubmapEntry e;
    e.id = static_cast<map::SubmapId>(s);
    e.grid = std::move(grid);
    e.T_world_submap = T_world_base;
    e.T_submap_world = T_world_base.inverse();
    out.push_back(e);
  }
  return out;
}

// Brute force: is the collision box (full sides `box_m`) known free at fine steps along a -> b?
// Checks every voxel the box overlaps at each step of res / 4 (and at b).
inline bool bruteForceEdgeFree(const map::MergedMap& map, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& box_m) {
  const double res = map.resolution();
  const double inv = 1.0 / res;
  const Eigen::Vector3d h = 0.5 * box_m;
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / (0.25 * res))));
  for (int i = 0; i <= n; ++i) {
    const Eigen::Vector3d p = a + (b - a) * (static_cast<double>(i) / n);
    const VoxelKey lo = map::pointToKey(p - h, inv);
    const VoxelKey hi = map::pointToKey(p + h, inv);
    VoxelKey k;
    for (k.z() = lo.z(); k.z() <= hi.z(); ++k.z())
      for (k.y() = lo.y(); k.y() <= hi.y(); ++k.y())
        for (k.x() = lo.x(); k.x() <= hi.x(); ++k.x())
          if (map.at(k).status != map::Occupancy::kFree) return false;
  }
  return true;
}

// The same for a footprint: a box as above; a vertical cylinder overlaps every voxel whose cell comes
// within its radius horizontally (and within half its height vertically).
inline bool bruteForceEdgeFree(const map::MergedMap& map, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Footprint& footprint) {
  if (!footprint.vertical_cylinder) return bruteForceEdgeFree(map, a, b, footprint.size_m);
  const double res = map.resolution();
  const double radius = 0.5 * footprint.size_m.x();
  const Eigen::Vector3d h(radius, radius, 0.5 * footprint.size_m.z());
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / (0.25 * res))));
  for (int i = 0; i <= n; ++i) {
    const Eigen::Vector3d p = a + (b - a) * (static_cast<double>(i) / n);
    const VoxelKey lo = map::pointToKey(p - h, 1.0 / res);
    const VoxelKey hi = map::pointToKey(p + h, 1.0 / res);
    VoxelKey k;
    for (k.z() = lo.z(); k.z() <= hi.z(); ++k.z())
      for (k.y() = lo.y(); k.y() <= hi.y(); ++k.y())
        for (k.x() = lo.x(); k.x() <= hi.x(); ++k.x()) {
          const Eigen::Vector3d c = map::keyToCentre(k, res);
          const double dx = std::max(std::abs(p.x() - c.x()) - 0.5 * res, 0.0);
          const double dy = std::max(std::abs(p.y() - c.y()) - 0.5 * res, 0.0);
          if (dx * dx + dy * dy >= radius * radius) continue;
          if (map.at(k).status != map::Occupancy::kFree) return false;
        }
  }
  return true;
}

// Brute force for the recovery move: does the box (full sides box_m, axis-aligned) translated from a
// to b overlap an occupied voxel that it does not already overlap at a? Steps of res / 8.
inline bool sweepTouchesNewOccupied(const map::MergedMap& map, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                    const Eigen::Vector3d& box_m) {
  const double res = map.resolution();
  const Eigen::Vector3d h = 0.5 * box_m;
  auto overlapped = [&](const Eigen::Vector3d& c, const std::function<bool(const map::VoxelKey&)>& f) {
    const map::VoxelKey lo = map::pointToKey(c - h, 1.0 / res), hi = map::pointToKey(c + h, 1.0 / res);
    map::VoxelKey k;
    for (k.z() = lo.z(); k.z() <= hi.z(); ++k.z())
      for (k.y() = lo.y(); k.y() <= hi.y(); ++k.y())
        for (k.x() = lo.x(); k.x() <= hi.x(); ++k.x())
          if (map.at(k).status == map::Occupancy::kOccupied && f(k)) return true;
    return false;
  };
  auto at_start = [&](const map::VoxelKey& k) {
    const Eigen::Vector3d d = (map::keyToCentre(k, res) - a).cwiseAbs();
    return ((d - h).array() < 0.5 * res).all();
  };
  const int steps = static_cast<int>(std::ceil((b - a).norm() / (res / 8))) + 1;
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector3d c = a + (b - a) * (static_cast<double>(i) / steps);
    if (overlapped(c, [&](const map::VoxelKey& k) { return !at_start(k); })) return true;
  }
  return false;
}

}  // namespace vog::plan::test_fixtures
