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
// rounding of each term (< 1e-9). A moved submap is evaluated at both poses in one pass, and only the
// centres that enter or leave a leaf change (a move of a few millimetres: about one in six).
//
// Storage: 8x8x8 voxel blocks in 16 hash tables (shards; a block's shard is fixed by the low bits of its
// x and y block coordinates). Blocks are shared copy-on-write with snapshots.
//
// Lifecycle and threads: one writer (the merge thread) owns a MergedMap and calls add/remove/sync and
// snapshot(). Readers (planner, API) only ever see `std::shared_ptr<const MergedMap>` snapshots, which
// never change; the writer copies a block before changing one that a snapshot still holds.
// Parallel merge: sync() may be lent threads (MergeThreads; the map creates none). The submaps to merge
// in or out form one ordered list, taken 16 at a time in two phases while the writer thread waits:
// first each task evaluates its share of the submaps, reading only them and the map's configuration, into
// lists it alone fills; then task t of n alone writes the shards s with s % n == t (their blocks and
// removal records), applying its lists submap by submap in list order. So every voxel sees the same
// additions in the same order as in a serial merge, and the result (sums, counts, block versions,
// removal records) does not depend on the number of threads.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/map/block_table.hpp"
#include "vog/map/grid_config.hpp"
#include "vog/map/vog_map.hpp"
#include "vog/map/voxel_key.hpp"

#include <algorithm>
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
  // At most this many moved submaps are re-merged by one sync(), those whose new base poses are nearest
  // to the newest submap's (where the vehicle is) first; the others keep the pose they were merged at
  // until a later sync (SyncStats::deferred; MergeWorker syncs again until none is left). So the map
  // around the vehicle follows a loop closure that moves most of a long mission's submaps in a bounded
  // time. 0: no limit.
  int max_moves_per_sync = 200;
  // Threads of one merge (MergeWorker): 0 = std::thread::hardware_concurrency(), at most 4; 1 = serial.
  // The merged map is the same for any number.
  int threads = 0;

  Status validate() const;
};

// Threads lent to one sync() call: `run(task)` calls task(0) ... task(tasks - 1), each exactly once,
// possibly concurrently, and returns when all have returned. tasks <= 1 or an empty `run`: serial.
struct MergeThreads {
  int tasks = 1;
  std::function<void(const std::function<void(int)>& task)> run;
};

struct SyncStats {
  int added = 0;
  int removed = 0;
  int remerged = 0;
  int deferred = 0;  // moved beyond the tolerance, left at the pose they were merged at (max_moves_per_sync)
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
  // vanished ones, moves only submaps whose pose moved beyond the tolerance (changing only the voxels
  // that differ; at most MergeConfig::max_moves_per_sync, the nearest to the newest submap). When that costs more than
  // merging all of `entries` from scratch (a move costs 0.8 to 1.7 merges, by how far it shifts the submap's voxels: a
  // loop closure that moves nearly every submap), it does that instead (the same sums and counts, every block gets a
  // new version). Everything is checked before anything changes. `cancelled`, when given, is asked by the calling
  // thread between submaps (with threads, between groups of 16): once it says true, sync stops with an error and leaves
  // the map part-way (consistent, for a writer that is shutting down and discards it); a merge from scratch leaves it
  // as it was.
  Result<SyncStats> sync(const std::vector<SubmapEntry>& entries, const MergeConfig& config,
                         const std::function<bool()>& cancelled = {}, const MergeThreads& threads = {});
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
  std::size_t blockCount() const;
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

  static constexpr int kShardBits = 4;
  static constexpr int kShards = 1 << kShardBits;
  // One shard: its blocks and the blocks it lost. During a parallel sync it is written by one task only.
  struct alignas(64) Shard {
    BlockTable<Block> blocks;
    std::unordered_map<std::uint64_t, std::uint64_t> removed;  // packed block -> version it was erased at
  };
  // Blocks interleave over the shards in x and y (4 x 4), so any n tasks get even shares of any region.
  static int shardOf(std::uint64_t packed) {
    return static_cast<int>((packed & 3) | (((packed >> kPackBits) & 3) << 2));
  }
  // One submap merged in (sign +1) or out (-1), or moved (`from`: the same grid at the pose it was
  // merged at; sign +1), with the map version it gets. A move adds only the difference: the voxels whose
  // centres enter or leave each leaf.
  struct MergeOp {
    const SubmapEntry* entry;
    const SubmapEntry* from;
    int sign;
    std::uint64_t version;
  };

  static constexpr int kPackBits = 21;  // per block coordinate in a packed block key
  static constexpr std::uint64_t kPackMask = (std::uint64_t{1} << kPackBits) - 1;
  static constexpr int kPackBias = 1 << (kPackBits - 1);
  static std::uint64_t packBlock(const VoxelKey& block) {
    return (static_cast<std::uint64_t>(block.x() + kPackBias) & kPackMask) |
           ((static_cast<std::uint64_t>(block.y() + kPackBias) & kPackMask) << kPackBits) |
           ((static_cast<std::uint64_t>(block.z() + kPackBias) & kPackMask) << (2 * kPackBits));
  }
  static VoxelKey unpackBlock(std::uint64_t packed);
  static VoxelKey blockOf(const VoxelKey& key) {
    return {key.x() >> kBlockBits, key.y() >> kBlockBits, key.z() >> kBlockBits};
  }
  static int indexIn(const VoxelKey& key) {
    constexpr int m = kBlockSide - 1;
    return ((key.z() & m) << (2 * kBlockBits)) | ((key.y() & m) << kBlockBits) | (key.x() & m);
  }
  const Block* findBlock(const VoxelKey& key) const { return findPacked(packBlock(blockOf(key))); }
  const Block* findPacked(std::uint64_t packed) const;
  VoxelValue valueOf(const Block& block, int index) const;
  // One voxel's change from one submap: what a parallel merge's first phase hands to the second.
  struct Contribution {
    std::uint64_t packed;  // block
    float log_odds;        // the submap's value there
    std::int16_t sign;     // +1 in, -1 out
    std::uint16_t index;   // voxel in the block
  };
  // The writer's place while it applies one op: the block last written and the blocks it emptied.
  struct WriteCursor {
    Block* block = nullptr;
    std::uint64_t packed = ~std::uint64_t{0};
    std::vector<std::uint64_t> emptied;
  };
  // Calls sink(packed block, voxel index, sign, log-odds) for every global voxel the op changes: each
  // voxel the submap knows (sign: the op's), or for a move each voxel whose leaf changed (+1 into the
  // new leaf, -1 out of the old). Reads only.
  template <class Sink>
  void evaluate(const MergeOp& op, Sink&& sink) const;
  // Adds one contribution of the op with `version` (copy-on-write, block creation, emptied blocks).
  void addVoxel(WriteCursor& cursor, std::uint64_t packed, std::size_t index, std::int64_t delta,
                std::uint64_t version);
  // Ends an op: erases the blocks it emptied, recorded as removed at `version`; resets the cursor.
  void finishOp(WriteCursor& cursor, std::uint64_t version);
  // One op on the calling thread.
  void applySerial(const MergeOp& op);
  // ops[begin, end) with the lent threads, in two phases: the tasks evaluate the ops (op k by task
  // k % tasks) into per-shard-owner lists, then task t applies, op by op in order, the lists of the
  // shards s with s % tasks == t.
  void applyParallel(const std::vector<MergeOp>& ops, std::size_t begin, std::size_t end, const MergeThreads& threads);
  // Ops per parallel call: enough to keep every task busy, few enough to bound the lists' memory (a
  // submap contributes about 1 MB) and the wait for a cancellation.
  static constexpr std::size_t kParallelGroup = 16;
  // The cost of moving a submap (same grid) from one pose to the other, in merges of one submap.
  double moveCost(const SubmapEntry& from, const SubmapEntry& to) const;
  // sync() when it merges everything from scratch; `entries` checked.
  Result<SyncStats> rebuild(const std::vector<SubmapEntry>& entries, SyncStats stats,
                            const std::function<bool()>& cancelled, const MergeThreads& threads);

  GridConfig config_;
  LogOddsBounds bounds_;
  double inv_resolution_;
  std::array<Shard, kShards> shards_;
  std::map<SubmapId, SubmapEntry> merged_;  // each submap at the pose it was merged at
  std::uint64_t version_ = 0;
  std::uint64_t writer_id_ = 0;
  std::uint64_t generation_ = 0;  // snapshots taken so far (see snapshot())
  // The parallel merge's lists (op k, owner t at k * tasks + t), kept between syncs so that their memory
  // is not faulted in again for every merge. Writer only; a snapshot's copy starts empty.
  struct ContributionLists {
    std::vector<std::vector<Contribution>> lists;
    ContributionLists() = default;
    ContributionLists(const ContributionLists&) {}
    ContributionLists& operator=(const ContributionLists&) = delete;
  };
  ContributionLists lists_;
};

template <class F>
void MergedMap::forEachKnown(F&& f) const {
  for (const Shard& shard : shards_) {
    shard.blocks.forEach([&](std::uint64_t packed, const std::shared_ptr<Block>& block) {
      const VoxelKey base = unpackBlock(packed) * kBlockSide;
      for (int i = 0; i < kBlockVoxels; ++i) {
        if (block->count(static_cast<std::size_t>(i)) == 0) continue;
        const VoxelKey key =
            base + VoxelKey(i & (kBlockSide - 1), (i >> kBlockBits) & (kBlockSide - 1), i >> (2 * kBlockBits));
        f(key, valueOf(*block, i));
      }
    });
  }
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

// The point query's path is inline and free of branches on the voxel's value: a query's cost is the
// cache miss on its block, and with no branch waiting for that load the core starts the next query's
// miss before this one's returns (independent queries overlap instead of queueing).
inline const MergedMap::Block* MergedMap::findPacked(std::uint64_t packed) const {
  return shards_[static_cast<std::size_t>(shardOf(packed))].blocks.find(packed);
}

inline VoxelValue MergedMap::valueOf(const Block& block, int index) const {
  static_assert(static_cast<int>(Occupancy::kUnknown) == 0, "an unknown voxel's status is 0 times its class");
  const auto i = static_cast<std::size_t>(index);
  const double clamped = bounds_.clamp(block.sum(i));
  const bool known = block.count(i) != 0;
  VoxelValue value;
  value.log_odds = known ? clamped : 0.0;
  value.status = static_cast<Occupancy>(static_cast<int>(known) * static_cast<int>(bounds_.classify(clamped)));
  return value;
}

inline VoxelValue MergedMap::at(const VoxelKey& key) const {
  const Block* block = findBlock(key);
  return block != nullptr ? valueOf(*block, indexIn(key)) : VoxelValue{};
}

inline VoxelValue MergedMap::query(const Eigen::Vector3d& p_world) const {
  if (!p_world.allFinite()) return {};
  return at(pointToKey(p_world, inv_resolution_));
}

}  // namespace vog::map
