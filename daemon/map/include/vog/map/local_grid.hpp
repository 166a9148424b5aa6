#pragma once
// LocalGrid (thesis 3.2): one OctoMap OcTree holding the scans of one submap, in the frame of its base
// pose (the pose of the submap's first scan).
//
// Lifecycle: mutable while scans are inserted; `finalize()` makes it immutable and computes the cached
// AABB of its known space and its downsampled occupied point cloud with normals (thesis 4.2 caches this
// for ICP). After finalize() only its base pose changes, and that pose lives in the VogMap, not here.
// A finalized grid is shared read-only (std::shared_ptr<const LocalGrid>) and safe for concurrent readers.
//
// A finalized grid no longer holds its OcTree: its leaves are kept as PackedLeaves (about 1.3 bytes per
// leaf against the tree's 50-80), which answer the point queries and the merge, and reproduce the
// tree's .ot file byte for byte when the grid is saved.

#include "vog/geometry/point_cloud.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"
#include "vog/map/grid_config.hpp"
#include "vog/map/packed_leaves.hpp"
#include "vog/map/voxel_key.hpp"

#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace octomap {
class KeyRay;
class OcTree;
}  // namespace octomap

namespace vog::map {

// One beam from a common origin: its end point, and whether the end is a return (occupied) or the
// beam ran free to there.
struct BeamEnd {
  Eigen::Vector3d end_grid;
  bool hit = true;
};

class LocalGrid {
 public:
  static Result<std::unique_ptr<LocalGrid>> create(const GridConfig& config);
  // Adopts a tree read from disk (resolution must match config); the grid is finalized. `sensor_origins`
  // are the scans' origins (grid frame) as sensorOrigins() gave them when the grid was saved: with them
  // the cloud's normals are oriented as they were live; without them (empty) towards the base.
  static Result<std::unique_ptr<LocalGrid>> fromTree(const GridConfig& config, std::unique_ptr<octomap::OcTree> tree,
                                                     std::vector<Eigen::Vector3d> sensor_origins = {});
  static Result<std::unique_ptr<LocalGrid>> load(const GridConfig& config, const std::filesystem::path& ot_file,
                                                 std::vector<Eigen::Vector3d> sensor_origins = {});
  // The inverse of serialize(): a finalized grid from .ot bytes (e.g. received over the API).
  static Result<std::unique_ptr<LocalGrid>> deserialize(const GridConfig& config, std::string_view ot_bytes);

  ~LocalGrid();
  LocalGrid(const LocalGrid&) = delete;
  LocalGrid& operator=(const LocalGrid&) = delete;

  // Integrates one sonar ping by log-odds ray casting (thesis Eq. 3.3-3.4). T_grid_sensor is the sensor
  // pose in this grid's frame. A return marks free space up to it and the end voxel occupied; a beam with
  // no return (or a return beyond max_range_m) marks free space up to max_range_m. Returns an error and
  // leaves the grid unchanged on a finalized grid, an invalid pose, a NaN or negative range, or a scan
  // whose beam count differs from the fan's.
  Status insertScan(const geometry::Pose3& T_grid_sensor, const geometry::SonarFan& fan,
                    const geometry::RangeScan& scan);
  // The same for arbitrary rays from one origin (grid frame); ends are clipped to max_range_m.
  Status insertRays(const Eigen::Vector3d& origin_grid, std::span<const BeamEnd> beams);

  void finalize();
  bool finalized() const { return finalized_; }

  // Log-odds of the voxel containing p (grid frame), or nullopt where the grid knows nothing.
  std::optional<float> logOdds(const Eigen::Vector3d& p_grid) const;
  // Log-odds at an integer voxel key of this grid, nullopt when unknown.
  std::optional<float> logOddsAt(const VoxelKey& key) const;

  const GridConfig& config() const { return config_; }
  double resolution() const { return config_.resolution_m; }
  double invResolution() const { return inv_resolution_; }
  // The tree of a grid still open for scans (a finalized grid has none: see leaves()).
  const octomap::OcTree& tree() const;
  std::size_t scanCount() const { return scan_count_; }

  // Valid after finalize(): inclusive voxel-key box and metric box of known space (grid frame); the key
  // box is empty for a grid that knows nothing.
  const KeyBox& knownKeys() const { return known_keys_; }
  Eigen::AlignedBox3d knownBox() const;
  // Downsampled centres of occupied voxels with unit normals (grid frame), oriented towards the sensor.
  const geometry::PointCloud& cloud() const { return cloud_; }
  // The origin of every scan inserted (grid frame), in insertion order; what orients the cloud's normals.
  // Kept after finalize() (24 bytes per scan) so that a saved grid can be read back with the same cloud.
  const std::vector<Eigen::Vector3d>& sensorOrigins() const { return sensor_origins_; }
  Eigen::Vector3d cloudCentroid() const;

  // Every leaf of the tree: the inclusive key box it covers and its log-odds.
  struct Leaf {
    VoxelKey min;
    VoxelKey max;
    float log_odds;
  };
  std::vector<Leaf> leaves() const;
  // The same leaves, in the same order, from the packed copy made by finalize(). Finalized grids only.
  template <class F>
  void forEachLeaf(F&& f) const;
  std::size_t leafCount() const { return leaves_.size(); }
  // Heap bytes a finalized grid holds (its leaves and its cloud).
  std::size_t residentBytes() const;

  // The tree in OctoMap's .ot format (finalized grids only): the bytes OctoMap's writer would produce,
  // made from the packed leaves. They are made in memory and written by save() (or the caller) with
  // every write checked (OctoMap's own writer reports success whatever its stream did).
  Result<std::string> serialize() const;
  // Writes serialize() atomically (writeFileAtomically: each write, the fsync, the rename and the
  // directory fsync checked); a full disk or any failed write is an error naming the file and leaves
  // no file of that name behind that was not there before.
  Status save(const std::filesystem::path& ot_file) const;

 private:
  LocalGrid(const GridConfig& config, std::unique_ptr<octomap::OcTree> tree);
  void packLeaves();
  void computeKnownBox();
  void computeCloud();

  GridConfig config_;
  double inv_resolution_;
  std::unique_ptr<octomap::OcTree> tree_;  // null once finalized
  std::size_t scan_count_ = 0;
  bool finalized_ = false;
  std::vector<Eigen::Vector3d> sensor_origins_;  // for orienting normals; not in the .ot (see fromTree)
  // insertRays()'s buffer of ray keys: OctoMap sizes it for 100,000 keys (600 kB), so it is made once
  // per grid, not per scan, and dropped by finalize().
  std::unique_ptr<octomap::KeyRay> ray_;
  PackedLeaves leaves_;
  KeyBox known_keys_;
  geometry::PointCloud cloud_;
};

template <class F>
void LocalGrid::forEachLeaf(F&& f) const {
  Leaf leaf;
  leaves_.forEach([&](const PackedLeaves::Leaf& p) {
    leaf.min = p.min;
    leaf.max = p.min + VoxelKey::Constant((1 << p.span_log2) - 1);
    leaf.log_odds = p.log_odds;
    f(leaf);
  });
}

}  // namespace vog::map
