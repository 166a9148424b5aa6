#pragma once
// Traversability of the exploration box for a vehicle's footprint (an axis-aligned box, or the
// vertical cylinder a box sweeps turning on the spot), from a MergedMap snapshot.
//
// A voxel is "safe" when the footprint centred anywhere inside it lies entirely in known free space
// (unknown is not traversable, thesis 4.3.2). Computed by inflating every voxel that is not known
// free. A box: by its half-extents plus one voxel (r_i = floor(h_i / res) + 1 voxels per axis), with a
// separable max filter: a box centred at p in voxel v overlaps only voxels within r_i of v. A
// cylinder of radius rho voxels: voxel u can be reached from v when the two voxels' cells come within
// rho of each other, i.e. max(|dx| - 1, 0)^2 + max(|dy| - 1, 0)^2 <= rho^2 (a disc per row: for
// each dy a window of half-width floor(sqrt(rho^2 - max(|dy| - 1, 0)^2)) + 1 in x), then its height
// as the box's. Either is conservative (a colliding edge is never called free) and at most one voxel
// per side stricter than the exact test.
//
// The grid covers the exploration box's voxels plus r on every side; outside it everything counts as
// blocked. An edge is free when both ends lie in the exploration box and every voxel its centre line
// crosses (Amanatides & Woo 1987 walk) is safe: the swept box is the union of boxes centred on the line.
//
// The grid also keeps every voxel's status (unknown / free / occupied, exactly as MergedMap::at
// classifies it): a dense copy of the snapshot over the box that the gain's beam walks read at a
// fraction of the cost of hashed block lookups.
//
// Lifecycle: built from one snapshot; update() catches up with a newer snapshot of the same MergedMap
// writer by re-reading only the blocks changed or removed since the version it reflects and
// recomputing the safe flags around those of them whose statuses changed, dilated by r, in runs along
// the grid's longest axis (the result equals a rebuild from the newer snapshot; the cost never
// exceeds one). Contacts (addContact) are voxels the vehicle ran into although the map shows them
// free: they count as occupied until the grid is rebuilt, whatever later snapshots say. It holds no
// reference to any snapshot. Not thread-safe: one planner owns one grid.

#include "vog/core/result.hpp"
#include "vog/map/merged_map.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

namespace vog::plan {

// The space the vehicle needs around its centre in the collision checks: an axis-aligned box of full
// sides size_m, or (vertical_cylinder) a vertical cylinder of diameter size_m.x() (= size_m.y()) and
// height size_m.z().
struct Footprint {
  Eigen::Vector3d size_m = Eigen::Vector3d::Ones();
  bool vertical_cylinder = false;
  static Footprint box(const Eigen::Vector3d& sides_m) { return {sides_m, false}; }
  static Footprint cylinder(double diameter_m, double height_m) {
    return {Eigen::Vector3d(diameter_m, diameter_m, height_m), true};
  }
};

// Unknown voxels whose centre lies within radius_m of centre_world count as free (never occupied
// ones). radius 0: none.
struct AssumedFree {
  Eigen::Vector3d centre_world = Eigen::Vector3d::Zero();
  double radius_m = 0.0;
};

struct TraversabilityUpdate {
  bool rebuilt = false;  // the snapshot was not a descendant: rebuilt from scratch
  int blocks_read = 0;   // changed or removed map blocks that touch the grid
  int blocks_stale = 0;  // 8^3 blocks of the grid whose safe flags went stale (recomputed when read)
};

class TraversabilityGrid {
 public:
  // box: the exploration box (world frame). Errors on an empty box, a footprint not > 0 on every axis
  // (a cylinder's x and y must agree), a grid too large.
  static Result<TraversabilityGrid> build(const map::MergedMap& map, const Eigen::AlignedBox3d& box_world,
                                          const Footprint& footprint, const AssumedFree& assumed_free = {});

  // Catches up with `newer`, a later snapshot of the map this grid was built from. A snapshot of
  // another MergedMap (writerId), with an older version than the grid's, or of another resolution
  // gives an error (the caller rebuilds).
  Result<TraversabilityUpdate> update(const map::MergedMap& newer);

  // Marks the voxel at p_world occupied (see above) and recomputes the safe flags around it;
  // outside the grid or non-finite: ignored.
  void addContact(const Eigen::Vector3d& p_world);

  // Is the footprint centred at p (world) inside the exploration box and in known free space?
  bool isSafe(const Eigen::Vector3d& p_world) const;
  bool isSafeKey(const map::VoxelKey& key) const;
  // The centre of the safe voxel nearest to p within radius_m (ties: lowest z, y, x), or nullopt.
  std::optional<Eigen::Vector3d> nearestSafe(const Eigen::Vector3d& p_world, double radius_m) const;
  // Recovery from outside the safe voxels (a loop closure moved the estimate next to a surface): the
  // safe voxel nearest to p within radius_m that a box of full sides box_m at heading yaw_rad reaches
  // by a straight translation from p without overlapping an occupied voxel (unknown space may be
  // crossed: the vehicle's own near field is never observed; occupied voxels the box overlaps already
  // at p do not count; ties: lowest z, y, x), or nullopt. Occupied voxels outside the grid (p may lie
  // outside the exploration box) are read from `snapshot`, the one the grid was synchronised with.
  std::optional<Eigen::Vector3d> nearestSafeClearOfOccupied(const map::MergedMap& snapshot,
                                                            const Eigen::Vector3d& p_world, double yaw_rad,
                                                            const Eigen::Vector3d& box_m, double radius_m) const;
  // Is the collision box swept from a to b in known free space, with a and b in the exploration box?
  bool edgeIsFree(const Eigen::Vector3d& a_world, const Eigen::Vector3d& b_world) const;
  bool insideBox(const Eigen::Vector3d& p_world) const;
  // Status of a voxel of the snapshot of mapVersion(); unknown outside the grid.
  map::Occupancy status(const map::VoxelKey& key) const {
    return grid_.contains(key) ? static_cast<map::Occupancy>(status_[indexOf(key)]) : map::Occupancy::kUnknown;
  }

  // A shortest 6-connected path of safe voxels (face neighbours) from `from` to `to` (A*, Hart 1968), shortened by
  // dropping waypoints while the direct edge stays free. Starts at `from`, ends at `to`; an error when
  // either end is not safe or no path exists.
  Result<std::vector<Eigen::Vector3d>> findPath(const Eigen::Vector3d& from_world,
                                                const Eigen::Vector3d& to_world) const;

  // The safe voxels inside the exploration box reachable from `from_world` through safe face
  // neighbours (the steps findPath takes), in breadth-first order, so by non-decreasing number of
  // steps; at most max_voxels of them. Empty when `from_world` is not safe.
  std::vector<map::VoxelKey> reachable(const Eigen::Vector3d& from_world, std::size_t max_voxels) const;

  // Dense status array (map::Occupancy per voxel, x fastest, then y, then z) over gridKeys().
  const std::vector<std::uint8_t>& statusArray() const { return status_; }
  const Eigen::Vector3i& gridSize() const { return size_; }

  std::uint64_t mapVersion() const { return map_version_; }
  double resolution() const { return resolution_; }
  const map::KeyBox& gridKeys() const { return grid_; }
  const Eigen::Vector3i& inflationVoxels() const { return r_; }
  std::size_t safeCount() const;
  // Exact equality of the safe flags (tests: incremental vs rebuild).
  bool sameFlags(const TraversabilityGrid& other) const;

 private:
  bool assumedFree(const map::VoxelKey& k) const {
    return assumed_free_keys_.contains(k) &&
           (map::keyToCentre(k, resolution_) - assumed_free_.centre_world).norm() <= assumed_free_.radius_m;
  }
  TraversabilityGrid() = default;
  // Safe voxels inside the exploration box within radius_m of p: (distance, key), nearest first
  // (ties: lowest z, y, x).
  std::vector<std::pair<double, map::VoxelKey>> safeKeysWithin(const Eigen::Vector3d& p_world, double radius_m) const;
  std::size_t indexOf(const map::VoxelKey& k) const {
    const map::VoxelKey d = k - grid_.min;
    return static_cast<std::size_t>(d.x()) +
           static_cast<std::size_t>(size_.x()) *
               (static_cast<std::size_t>(d.y()) +
                static_cast<std::size_t>(size_.y()) * static_cast<std::size_t>(d.z()));
  }
  // Copies the status of one map block (nullptr: entirely unknown) into status_; true when a status
  // in the grid changed.
  bool readBlock(const map::VoxelKey& block_origin, const map::MergedMap::Block* block);
  // The status of voxel i of a map block.
  map::Occupancy statusOf(const map::MergedMap::Block& block, std::size_t i) const;
  // readBlock's voxel by voxel form, for the part `clipped` of a block at the grid's edge or near the
  // assumed-free sphere.
  bool readClippedBlock(const map::VoxelKey& block_origin, const map::MergedMap::Block* block,
                        const map::KeyBox& clipped);
  // Recomputes safe_ inside `region` (clipped to the grid) from status_.
  void recompute(map::KeyBox region) const;
  // Blocks of the grid (8^3 voxels aligned as the map's blocks): coordinates from block_min_, index
  // into stale_, keys.
  map::VoxelKey blockOf(const map::VoxelKey& key) const;
  std::size_t blockIndex(const map::VoxelKey& block) const;
  map::KeyBox blockKeys(const map::VoxelKey& block) const;
  // Recomputes the safe flags of the stale block holding `key` (in the grid) with the other stale
  // blocks of its group; settleAll() every stale block.
  void settle(const map::VoxelKey& key) const;
  void settleAll() const;

  double resolution_ = 0.0;
  AssumedFree assumed_free_;
  map::KeyBox assumed_free_keys_;  // the keys of the sphere's bounding box in the grid; empty for radius 0
  double inv_resolution_ = 0.0;
  map::LogOddsBounds bounds_;
  Eigen::AlignedBox3d box_world_;
  map::KeyBox grid_;  // inclusive keys covered by status_ and safe_
  Eigen::Vector3i size_ = Eigen::Vector3i::Zero();
  Eigen::Vector3i r_ = Eigen::Vector3i::Zero();  // inflation radius in voxels per axis
  std::vector<int> disc_half_width_;             // a cylinder: x half-width per |dy| in [0, r_.y()]; empty: a box
  std::vector<std::uint8_t> status_;             // map::Occupancy per voxel
  // Safe flags are recomputed lazily: update() marks the blocks a changed status may reach stale, and
  // the queries recompute a stale block when they first read it, so a plan after a loop closure pays
  // for the part of the grid it looks at. The queries are const and write these: a grid is used by one
  // thread at a time (the planner's).
  static constexpr int kSettleBlocks = 4;
  mutable std::vector<std::uint8_t> safe_;           // 1 = a box centred in this voxel is in known free space
  mutable std::vector<std::uint8_t> stale_;          // per block of the grid: its safe flags wait for settle()
  mutable std::size_t stale_count_ = 0;              // blocks flagged in stale_
  map::VoxelKey block_min_ = map::VoxelKey::Zero();  // the grid's first block (map block coordinates)
  map::VoxelKey blocks_ = map::VoxelKey::Zero();     // blocks of the grid per axis
  std::vector<map::VoxelKey> contacts_;              // addContact(), inside grid_
  std::uint64_t map_version_ = 0;
  std::uint64_t map_writer_ = 0;  // MergedMap::writerId() of the snapshots this grid reflects
};

}  // namespace vog::plan
