#pragma once
// VogMap (thesis 3.1): an ordered set of local grids, each with its base pose T_world_submap.
//
// Operations: deformation (Alg. 1, replace every base pose, O(N)), sequential point query (Alg. 2 /
// Eq. 3.5), line query (Alg. 5) and a visibility cast for the planner.
//
// Thread safety: queries take `mutex_` shared and may run concurrently with each other; adding a
// submap and deforming take it exclusively. Grids are immutable (finalized) and shared, so a copy of
// the entry list (`entries()`) stays valid without the lock.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/map/grid_config.hpp"
#include "vog/map/local_grid.hpp"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <shared_mutex>
#include <vector>

namespace vog::map {

using SubmapId = std::uint32_t;

// One submap as the map holds it. T_submap_world is the cached inverse: every query transforms through
// it with `toSubmap()`, so all paths compute the same local coordinates bit for bit.
struct SubmapEntry {
  SubmapId id = 0;
  std::shared_ptr<const LocalGrid> grid;
  geometry::Pose3 T_world_submap = geometry::Pose3::Identity();
  geometry::Pose3 T_submap_world = geometry::Pose3::Identity();

  Eigen::Vector3d toSubmap(const Eigen::Vector3d& p_world) const {
    return T_submap_world.linear() * p_world + T_submap_world.translation();
  }
};

// A queried value: clamped log-odds (0 when unknown) and status.
struct VoxelValue {
  double log_odds = 0.0;
  Occupancy status = Occupancy::kUnknown;
};

struct LineSample {
  Eigen::Vector3d point_world;
  VoxelValue value;
};

// Result of a visibility cast: samples up to and including the first occupied one.
struct CastResult {
  bool hit = false;  // an occupied sample was reached within the range
  Eigen::Vector3d hit_world = Eigen::Vector3d::Zero();
  int n_free = 0;
  int n_unknown = 0;
};

class VogMap {
 public:
  static Result<std::unique_ptr<VogMap>> create(const GridConfig& config);

  VogMap(const VogMap&) = delete;
  VogMap& operator=(const VogMap&) = delete;

  // Appends a finalized grid of the same resolution and clamping with its base pose. Ids are unique.
  Status addSubmap(SubmapId id, std::shared_ptr<const LocalGrid> grid, const geometry::Pose3& T_world_submap);
  // Alg. 1: replaces every base pose, in submap order. Nothing changes when the list has the wrong
  // length or holds an invalid pose.
  Status deform(const std::vector<geometry::Pose3>& T_world_submap);

  std::size_t size() const;
  const GridConfig& config() const { return config_; }
  // A consistent copy of the entries (shared grids, poses at the time of the call).
  std::vector<SubmapEntry> entries() const;
  std::vector<geometry::Pose3> poses() const;

  // Alg. 2 / Eq. 3.5: sum of the log-odds of every submap that knows the point, clamped.
  VoxelValue query(const Eigen::Vector3d& p_world) const;
  // Alg. 5: samples p1 + k * resolution * v for k = 0..floor(|p2 - p1| / resolution), summing only the
  // submaps whose oriented known-space box the segment crosses.
  std::vector<LineSample> lineQuery(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) const;
  // Steps like lineQuery from `origin` towards `end` and stops at the first occupied sample.
  CastResult castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& end) const;

  // One .ot per submap plus `poses.txt` (id x y z qx qy qz qw) and `grid.txt` (the GridConfig).
  Status save(const std::filesystem::path& dir) const;
  static Result<std::unique_ptr<VogMap>> load(const std::filesystem::path& dir);

 private:
  explicit VogMap(const GridConfig& config) : config_(config), bounds_(config.bounds()) {}
  // Sum over the given entries; caller holds the lock.
  VoxelValue sumAt(const Eigen::Vector3d& p_world, const std::vector<const SubmapEntry*>& subset) const;
  std::vector<const SubmapEntry*> crossedBy(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) const;

  const GridConfig config_;
  const LogOddsBounds bounds_;
  mutable std::shared_mutex mutex_;
  std::vector<SubmapEntry> entries_;  // guarded by mutex_
};

// Segment-vs-box test in the box's frame (slab method): does the segment [a, b] meet the box?
bool segmentIntersectsBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::AlignedBox3d& box);

}  // namespace vog::map
