#pragma once
// MergedMap (thesis 3.4.2 Alg. 3-4, 4.5.5): the cached global map of a VogMap.
//
// Each global voxel holds the unclamped sum of the log-odds of every submap that knows the voxel's
// centre, and how many submaps know it (0 = unknown), packed in one int64: sum in fixed point
// (2^-28 log-odds) times 2^16, plus the count. A submap's contribution is one integer addition of
// (value << 16) + 1, so adding and removing a submap are exact inverses (an incrementally maintained
// map is bit-identical to one merged from scratch), and a lookup touches one cache line. Values are clamped at query
// time (OctoMap would clamp on every update, which breaks removal).
//
// Merging a submap evaluates it at global voxel centres (never scatters its voxels: rotations alias):
// for every leaf of the submap's tree, the global centres inside the leaf's rotated box get the leaf's
// value. The local coordinates are computed exactly as VogMap::query computes them, so the merged value
// at every global voxel centre equals the sequential query there (Alg. 2) up to the fixed-point
// rounding of each term (< 1e-9).
//
// Storage: 8x8x8 voxel blocks in a hash table. Blocks are shared copy-on-write with snapshots.
//
// Lifecycle and threads: one writer (the merge thread) owns a MergedMap and calls add/remove/sync and
// snapshot(). Readers (planner, API) only ever see `std::shared_ptr<const MergedMap>` snapshots, which
// never change; the writer copies a block before changing one that a snapshot still holds.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/map/block_table.hpp"
#include "vog/map/grid_config.hpp"
#include "vog/map/vog_map.hpp"
#include "vog/map/voxel_key.hpp"

#include <array>
#include <functional>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

namespace octomap {
class OcTree;
}

namespace vog::map {

struct MergeConfig {
  // A submap is re-merged when its base pose moved more than this since it was merged. 0 re-merges on
  // any change (exactness); the defaults keep every voxel of a 5.6 m submap within 1/20 resolution.
  double remerge_translation_m = 0.005;
  double remerge_rotation_rad = 0.0008;

  Status validate() const;
};

struct SyncStats {
  int added = 0;
  int removed = 0;
  int remerged = 0;
};

class MergedMap {
 public:
  static constexpr int kBlockBits = 3;
  static constexpr int kBlockSide = 1 << kBlockBits;
  static constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;
  static constexpr double kFixedScale = 268435456.0;  // 2^28 fixed-point units per log-odds
  static constexpr int kCountBits = 16;               // up to 65535 submaps know one voxel
  // 47 bits of sum magnitude at 2^-28 hold +-524288 log-odds: 65535 submaps at the clamping bound.

  struct Block {
    std::array<std::int64_t, kBlockVoxels> packed{};  // (fixed-point sum << 16) + count, unclamped
    std::uint32_t n_known = 0;                        // voxels with count > 0
    std::uint64_t version = 0;                        // map version of the last change
    std::uint64_t generation = 0;  // the writer's snapshot generation the block was made in (writer only)

    std::uint32_t count(std::size_t i) const { return static_cast<std::uint32_t>(packed[i] & 0xFFFF); }
    // Unclamped log-odds sum of voxel i.
    double sum(std::size_t i) const {
      return static_cast<double>((packed[i] - static_cast<std::int64_t>(count(i))) >> kCountBits) / kFixedScale;
    }
  };

  static Result<std::unique_ptr<MergedMap>> create(const GridConfig& config);

  // --- writer side ---
  // Merges a submap at its pose. The grid must be finalized and of this map's resolution.
  Status add(const SubmapEntry& entry);
  // Merges a submap out at the pose it was merged at.
  Status remove(SubmapId id);
  // Brings the map in line with `entries` (a VogMap's current list): merges new submaps, removes
  // vanished ones, re-merges only submaps whose pose moved beyond the tolerance.
  // `cancelled`, when given, is asked between submaps: once it says true, sync stops with an error and
  // leaves the map part-way (for a writer that is shutting down and discards it).
  Result<SyncStats> sync(const std::vector<SubmapEntry>& entries, const MergeConfig& config,
                         const std::function<bool()>& cancelled = {});
  // An immutable copy sharing every block (O(number of blocks) pointer copies). Blocks are shared by
  // generation: a block made before the newest snapshot is never written again, only copied (the
  // writer decides alone, with no reference counts read across threads), so a reader may drop or
  // read its snapshot at any time.
  std::shared_ptr<const MergedMap> snapshot();

  // --- readers ---
  VoxelValue at(const VoxelKey& key) const;
  VoxelValue query(const Eigen::Vector3d& p_world) const;
  // Same sampling as VogMap::lineQuery, answered from the merged map.
  std::vector<LineSample> lineQuery(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) const;
  // Voxel traversal (Amanatides & Woo 1987) from origin to end; stops at the first occupied voxel.
  CastResult castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& end) const;
  // Calls visit(key, value) for every voxel the segment crosses, in order, until it returns false.
  template <class Visit>
  void traverse(const Eigen::Vector3d& origin, const Eigen::Vector3d& end, Visit&& visit) const;

  const GridConfig& config() const { return config_; }
  double resolution() const { return config_.resolution_m; }
  std::uint64_t version() const { return version_; }
  // Which MergedMap this is or was snapshotted from (unique in the process): versions, and so
  // blocksChangedSince / blocksRemovedSince, compare only between snapshots of the same writer.
  std::uint64_t writerId() const { return writer_id_; }
  std::size_t submapCount() const { return merged_.size(); }
  bool contains(SubmapId id) const { return merged_.count(id) != 0; }
  std::size_t blockCount() const { return blocks_.size(); }
  std::size_t knownVoxelCount() const;
  std::size_t memoryBytes() const;

  // Calls f(key, value) for every known voxel, in no particular order.
  template <class F>
  void forEachKnown(F&& f) const;
  // Block origins (key of voxel 0) of blocks changed after `since_version`, with their blocks, and the
  // origins of blocks that became entirely unknown after it: together, what a remote copy taken at
  // `since_version` needs to catch up.
  std::vector<std::pair<VoxelKey, std::shared_ptr<const Block>>> blocksChangedSince(std::uint64_t since_version) const;
  std::vector<VoxelKey> blocksRemovedSince(std::uint64_t since_version) const;
  // Exact equality of the stored sums and counts (tests: incremental vs scratch).
  bool sameVoxels(const MergedMap& other) const;

  // OctoMap export: .ot keeps the clamped log-odds, .bt the max-likelihood map; both open in octovis.
  std::unique_ptr<octomap::OcTree> toOcTree() const;
  Status writeOt(const std::filesystem::path& file) const;
  Status writeBt(const std::filesystem::path& file) const;

  MergedMap(const MergedMap&) = default;  // shares blocks; used by snapshot()
  MergedMap& operator=(const MergedMap&) = delete;

 private:
  explicit MergedMap(const GridConfig& config);

  static std::uint64_t packBlock(const VoxelKey& block);
  static VoxelKey unpackBlock(std::uint64_t packed);
  static VoxelKey blockOf(const VoxelKey& key) {
    return {key.x() >> kBlockBits, key.y() >> kBlockBits, key.z() >> kBlockBits};
  }
  static int indexIn(const VoxelKey& key) {
    constexpr int m = kBlockSide - 1;
    return ((key.z() & m) << (2 * kBlockBits)) | ((key.y() & m) << kBlockBits) | (key.x() & m);
  }
  const Block* findBlock(const VoxelKey& key) const;
  VoxelValue valueOf(const Block& block, int index) const;
  // Adds (sign +1) or subtracts (sign -1) one submap at the entry's pose.
  void apply(const SubmapEntry& entry, int sign);

  GridConfig config_;
  LogOddsBounds bounds_;
  double inv_resolution_;
  BlockTable<Block> blocks_;
  std::unordered_map<std::uint64_t, std::uint64_t> removed_;  // packed block -> version it was erased at
  std::map<SubmapId, SubmapEntry> merged_;                    // each submap at the pose it was merged at
  std::uint64_t version_ = 0;
  std::uint64_t writer_id_ = 0;
  std::uint64_t generation_ = 0;  // snapshots taken so far (see snapshot())
};

template <class F>
void MergedMap::forEachKnown(F&& f) const {
  blocks_.forEach([&](std::uint64_t packed, const std::shared_ptr<Block>& block) {
    const VoxelKey base = unpackBlock(packed) * kBlockSide;
    for (int i = 0; i < kBlockVoxels; ++i) {
      if (block->count(static_cast<std::size_t>(i)) == 0) continue;
      const VoxelKey key =
          base + VoxelKey(i & (kBlockSide - 1), (i >> kBlockBits) & (kBlockSide - 1), i >> (2 * kBlockBits));
      f(key, valueOf(*block, i));
    }
  });
}

template <class Visit>
void MergedMap::traverse(const Eigen::Vector3d& origin, const Eigen::Vector3d& end, Visit&& visit) const {
  if (!origin.allFinite() || !end.allFinite()) return;
  VoxelWalk w = startVoxelWalk(origin, end, config_.resolution_m, inv_resolution_);
  VoxelKey& key = w.key;
  const VoxelKey last = w.last;
  const Block* block = nullptr;
  VoxelKey block_key = VoxelKey::Constant(std::numeric_limits<int>::min());
  // Upper bound on the number of voxels: guards against rounding loops.
  const long max_steps = 3 + (last - key).cwiseAbs().sum();
  for (long n = 0; n <= max_steps; ++n) {
    const VoxelKey bk = blockOf(key);
    if (bk != block_key) {
      block_key = bk;
      block = findBlock(key);
    }
    const VoxelValue value = block != nullptr ? valueOf(*block, indexIn(key)) : VoxelValue{};
    if (!visit(key, value)) return;
    if (key == last) return;
    const int axis = w.nextAxis();
    if (w.t_max[axis] > 1.0) return;
    key[axis] += w.step[axis];
    w.t_max[axis] += w.t_delta[axis];
  }
}

}  // namespace vog::map
