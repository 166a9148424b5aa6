#include "vog/map/merged_map.hpp"

#include "vog/map/octree_file.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

namespace vog::map {

Status MergeConfig::validate() const {
  if (!(remerge_translation_m >= 0.0) || !std::isfinite(remerge_translation_m))
    return Error{"merge.remerge_translation_m must be finite and >= 0, got " + std::to_string(remerge_translation_m)};
  if (!(remerge_rotation_rad >= 0.0) || !std::isfinite(remerge_rotation_rad))
    return Error{"merge.remerge_rotation_rad must be finite and >= 0, got " + std::to_string(remerge_rotation_rad)};
  if (max_moves_per_sync < 0)
    return Error{"merge.max_moves_per_sync must be >= 0, got " + std::to_string(max_moves_per_sync)};
  if (threads < 0 || threads > 64) return Error{"merge.threads must be in [0, 64], got " + std::to_string(threads)};
  return {};
}

VoxelKey MergedMap::unpackBlock(std::uint64_t p) {
  return {static_cast<int>(p & kPackMask) - kPackBias, static_cast<int>((p >> kPackBits) & kPackMask) - kPackBias,
          static_cast<int>((p >> (2 * kPackBits)) & kPackMask) - kPackBias};
}

MergedMap::MergedMap(const GridConfig& config)
    : config_(config), bounds_(config.bounds()), inv_resolution_(1.0 / config.resolution_m) {
  static std::atomic<std::uint64_t> next_writer_id{1};
  writer_id_ = next_writer_id.fetch_add(1, std::memory_order_relaxed);
}

Result<std::unique_ptr<MergedMap>> MergedMap::create(const GridConfig& config) {
  if (auto s = config.validate(); !s) return s.error();
  return std::unique_ptr<MergedMap>(new MergedMap(config));
}

std::vector<LineSample> MergedMap::lineQuery(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) const {
  std::vector<LineSample> out;
  if (!p1.allFinite() || !p2.allFinite()) return out;
  const double length = (p2 - p1).norm();
  const Eigen::Vector3d v = length > 0.0 ? Eigen::Vector3d((p2 - p1) / length) : Eigen::Vector3d::Zero();
  const double step = config_.resolution_m;
  const auto n = static_cast<int>(std::floor(length / step));
  out.reserve(static_cast<std::size_t>(n) + 1);
  const Block* block = nullptr;
  std::uint64_t block_packed = ~std::uint64_t{0};
  for (int k = 0; k <= n; ++k) {
    const Eigen::Vector3d x = p1 + (k * step) * v;
    const VoxelKey key = pointToKey(x, inv_resolution_);
    const std::uint64_t packed = packBlock(blockOf(key));
    if (packed != block_packed) {
      block_packed = packed;
      block = findPacked(packed);
    }
    out.push_back({x, block != nullptr ? valueOf(*block, indexIn(key)) : VoxelValue{}});
  }
  return out;
}

CastResult MergedMap::castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& end) const {
  CastResult result;
  traverse(origin, end, [&](const VoxelKey& key, const VoxelValue& value) {
    if (value.status == Occupancy::kOccupied) {
      result.hit = true;
      result.hit_world = keyToCentre(key, config_.resolution_m);
      return false;
    }
    (value.status == Occupancy::kFree ? result.n_free : result.n_unknown)++;
    return true;
  });
  return result;
}

Status MergedMap::add(const SubmapEntry& entry) {
  if (!entry.grid) return Error{"merge: submap " + std::to_string(entry.id) + " has no grid"};
  if (!entry.grid->finalized()) return Error{"merge: submap " + std::to_string(entry.id) + " is not finalized"};
  if (std::abs(entry.grid->resolution() - config_.resolution_m) > 1e-12) {
    return Error{"merge: submap " + std::to_string(entry.id) + " resolution " +
                 std::to_string(entry.grid->resolution()) + " differs from " + std::to_string(config_.resolution_m)};
  }
  if (!geometry::isValidPose(entry.T_world_submap) || !geometry::isValidPose(entry.T_submap_world)) {
    return Error{"merge: pose of submap " + std::to_string(entry.id) + " is not a finite rigid transform"};
  }
  if (merged_.count(entry.id) != 0) return Error{"merge: submap " + std::to_string(entry.id) + " is already merged"};
  if (merged_.size() >= std::numeric_limits<std::uint16_t>::max()) return Error{"merge: too many submaps (65535)"};
  ++version_;
  applySerial({&entry, nullptr, +1, version_});
  merged_.emplace(entry.id, entry);
  return {};
}

Status MergedMap::remove(SubmapId id) {
  const auto it = merged_.find(id);
  if (it == merged_.end()) return Error{"merge: submap " + std::to_string(id) + " is not merged"};
  ++version_;
  applySerial({&it->second, nullptr, -1, version_});
  merged_.erase(it);
  return {};
}

double MergedMap::moveCost(const SubmapEntry& from, const SubmapEntry& to) const {
  // How far the submap's farthest known corner moves, in voxels.
  const Eigen::AlignedBox3d box = to.grid->knownBox();
  const double radius = box.isEmpty() ? 0.0 : box.min().cwiseAbs().cwiseMax(box.max().cwiseAbs()).norm();
  const double shift = (geometry::translationDistance(from.T_world_submap, to.T_world_submap) +
                        geometry::rotationAngle(from.T_world_submap, to.T_world_submap) * radius) *
                       inv_resolution_;
  // Measured with vog-bench map (remerge_third_small_parallel_ms against merge_scratch_parallel_s, a
  // third of 150 submaps moved by 7.5 to 100 mm): about 0.8 of a merge for a shift of a few
  // millimetres (both poses tested at every candidate, a small part written), 1.7 for a whole voxel.
  return 0.8 + 0.9 * std::min(1.0, shift);
}

Result<SyncStats> MergedMap::sync(const std::vector<SubmapEntry>& entries, const MergeConfig& config,
                                  const std::function<bool()>& cancelled, const MergeThreads& threads) {
  const auto stop = [&] { return cancelled && cancelled(); };
  const Error cancel_error{"merge: cancelled"};
  if (auto s = config.validate(); !s) return s.error();
  // Validate everything before changing anything.
  std::map<SubmapId, const SubmapEntry*> wanted;
  for (const auto& e : entries) {
    if (!wanted.emplace(e.id, &e).second) return Error{"merge: submap id " + std::to_string(e.id) + " listed twice"};
    if (!e.grid || !e.grid->finalized()) return Error{"merge: submap " + std::to_string(e.id) + " is not finalized"};
    if (std::abs(e.grid->resolution() - config_.resolution_m) > 1e-12)
      return Error{"merge: submap " + std::to_string(e.id) + " has a different resolution"};
    if (!geometry::isValidPose(e.T_world_submap) || !geometry::isValidPose(e.T_submap_world))
      return Error{"merge: pose of submap " + std::to_string(e.id) + " is not a finite rigid transform"};
  }
  if (entries.size() > std::numeric_limits<std::uint16_t>::max()) return Error{"merge: too many submaps (65535)"};

  // The submaps to merge out, in and over, in the order a submap-by-submap sync takes them: the vanished
  // ones (by id), then `entries` in order; a moved one from its old pose to its new one in one op, or out
  // and in when its grid changed.
  SyncStats stats;
  std::vector<MergeOp> ops;
  std::uint64_t version = version_;
  std::size_t unchanged = 0;
  double move_cost = 0.0;
  for (const auto& [id, e] : merged_) {
    if (wanted.count(id) != 0) continue;
    ops.push_back({&e, nullptr, -1, ++version});
    ++stats.removed;
  }
  const bool exact = config.remerge_translation_m == 0.0 && config.remerge_rotation_rad == 0.0;
  // The submaps whose pose moved beyond the tolerance (same grid). Moves accumulate against the pose
  // the submap was merged at, so many small ones still trigger. Past MergeConfig::max_moves_per_sync
  // only the nearest to the newest submap's base move now (ties by index), the others are deferred.
  std::vector<char> move(entries.size(), 0);
  std::vector<std::pair<double, std::size_t>> moves;  // (squared distance to the newest base, entry index)
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const auto it = merged_.find(entries[k].id);
    if (it == merged_.end() || it->second.grid != entries[k].grid) continue;
    const geometry::Pose3& from = it->second.T_world_submap;
    const geometry::Pose3& to = entries[k].T_world_submap;
    if (from.matrix() == to.matrix()) continue;
    if (exact || geometry::translationDistance(from, to) > config.remerge_translation_m ||
        geometry::rotationAngle(from, to) > config.remerge_rotation_rad) {
      move[k] = 1;
      moves.emplace_back(0.0, k);
    }
  }
  const auto limit = static_cast<std::size_t>(config.max_moves_per_sync);
  if (limit > 0 && moves.size() > limit) {
    const Eigen::Vector3d newest = wanted.rbegin()->second->T_world_submap.translation();
    for (auto& [d2, k] : moves) d2 = (entries[k].T_world_submap.translation() - newest).squaredNorm();
    std::nth_element(moves.begin(), moves.begin() + static_cast<std::ptrdiff_t>(limit), moves.end());
    for (std::size_t j = limit; j < moves.size(); ++j) move[moves[j].second] = 0;
    stats.deferred = static_cast<int>(moves.size() - limit);
  }
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const SubmapEntry& e = entries[k];
    const auto it = merged_.find(e.id);
    if (it == merged_.end()) {
      ops.push_back({&e, nullptr, +1, ++version});
      ++stats.added;
      continue;
    }
    const SubmapEntry& old = it->second;
    if (old.grid == e.grid && move[k] == 0) {
      ++unchanged;
      continue;
    }
    if (old.grid == e.grid) {
      ops.push_back({&e, &old, +1, ++version});
      move_cost += moveCost(old, e);
    } else {
      ops.push_back({&old, nullptr, -1, ++version});
      ops.push_back({&e, nullptr, +1, ++version});
      move_cost += 2.0;
    }
    ++stats.remerged;
  }
  // In merges of one submap: from scratch, one per entry (the unchanged, the moved and the new ones);
  // the incremental way, one per vanished or new submap and the moves' cost.
  const auto kept = static_cast<double>(unchanged + static_cast<std::size_t>(stats.remerged));
  if (kept < static_cast<double>(stats.removed) + move_cost && !merged_.empty()) {
    stats.remerged += std::exchange(stats.deferred, 0);  // from scratch every submap is merged at its pose
    return rebuild(entries, stats, cancelled, threads);
  }

  const auto record = [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      const MergeOp& op = ops[k];
      version_ = op.version;
      const SubmapId id = op.entry->id;
      if (op.sign < 0) {
        merged_.erase(id);  // `op.entry` pointed into merged_: not used again
      } else {
        merged_.insert_or_assign(id, *op.entry);  // a move's `op.from` pointed into merged_: not used again
      }
    }
  };
  const bool parallel = threads.tasks > 1 && threads.run;
  const std::size_t group = parallel ? kParallelGroup : 1;
  for (std::size_t begin = 0; begin < ops.size(); begin += group) {
    if (stop()) return cancel_error;
    const std::size_t end = std::min(ops.size(), begin + group);
    if (parallel) {
      applyParallel(ops, begin, end, threads);
    } else {
      applySerial(ops[begin]);
    }
    record(begin, end);
  }
  if (ops.empty() && !entries.empty() && stop()) return cancel_error;
  return stats;
}

Result<SyncStats> MergedMap::rebuild(const std::vector<SubmapEntry>& entries, SyncStats stats,
                                     const std::function<bool()>& cancelled, const MergeThreads& threads) {
  std::vector<MergeOp> ops;
  ops.reserve(entries.size());
  for (std::size_t k = 0; k < entries.size(); ++k) ops.push_back({&entries[k], nullptr, +1, version_ + k + 1});
  std::array<Shard, kShards> old = std::move(shards_);
  shards_ = {};
  const bool parallel = threads.tasks > 1 && threads.run;
  const std::size_t group = parallel ? kParallelGroup : 1;
  for (std::size_t begin = 0; begin < ops.size(); begin += group) {
    if (cancelled && cancelled()) {
      shards_ = std::move(old);  // as it was: nothing of the new merge is kept
      return Error{"merge: cancelled"};
    }
    const std::size_t end = std::min(ops.size(), begin + group);
    if (parallel) {
      applyParallel(ops, begin, end, threads);
    } else {
      applySerial(ops[begin]);
    }
  }
  version_ += entries.size();
  // Removal records: blocks that existed and are gone now were erased at this version; earlier records
  // stay for blocks still absent.
  for (std::size_t s = 0; s < shards_.size(); ++s) {
    Shard& now = shards_[s];
    const Shard& before = old[s];
    for (const auto& [packed, at] : before.removed) {
      if (now.blocks.find(packed) == nullptr) now.removed.emplace(packed, at);
    }
    before.blocks.forEach([&](std::uint64_t packed, const std::shared_ptr<Block>&) {
      if (now.blocks.find(packed) == nullptr) now.removed[packed] = version_;
    });
  }
  merged_.clear();
  for (const auto& e : entries) merged_.emplace(e.id, e);
  return stats;
}

namespace {

// A voxel's change from one submap's value: value * 2^16 + 1 in 2^-28 log-odds units, times the sign (one
// addition updates sum and count together; see merged_map.hpp). Leaves share few values, so the last
// one's is remembered.
class FixedDelta {
 public:
  std::int64_t operator()(int sign, float value) {
    if (value != value_) {
      value_ = value;
      magnitude_ = std::llround(static_cast<double>(value) * MergedMap::kFixedScale) *
                       (std::int64_t{1} << MergedMap::kCountBits) +
                   1;
    }
    return sign * magnitude_;
  }

 private:
  float value_ = std::numeric_limits<float>::quiet_NaN();
  std::int64_t magnitude_ = 0;
};

// A submap at one pose over the global grid: which global voxel centres may lie in a leaf's rotated
// cube (a box of candidates, a superset), and whether one does (exactly as VogMap::query computes the
// local key of a point).
class Placement {
 public:
  Placement(const SubmapEntry& entry, double inv_resolution)
      : entry_(entry),
        inv_resolution_(inv_resolution),
        R_(entry.T_world_submap.linear()),
        t_voxels_(entry.T_world_submap.translation() * inv_resolution) {
    const Eigen::Matrix3d R_abs = R_.cwiseAbs();
    for (std::size_t s = 0; s < half_extent_.size(); ++s) {
      half_extent_[s] = R_abs * Eigen::Vector3d::Constant(0.5 * static_cast<double>(1 << s));
    }
  }

  // The global voxels whose centres may lie in the leaf's cube: [gmin, gmax]. Worked out in voxel units
  // (world voxel coordinate = R * local voxel coordinate + t / res) and widened by a hair: its rounding
  // differs from the exact test's, which decides.
  void candidates(const LocalGrid::Leaf& leaf, VoxelKey& gmin, VoxelKey& gmax) const {
    constexpr double kHair = 1e-6;
    const int side = leaf.max.x() - leaf.min.x() + 1;
    const Eigen::Vector3d& e = half_extent_[static_cast<std::size_t>(__builtin_ctz(static_cast<unsigned>(side)))];
    const Eigen::Vector3d c = R_ * (leaf.min.cast<double>() + Eigen::Vector3d::Constant(0.5 * side)) + t_voxels_;
    for (int i = 0; i < 3; ++i) {
      // Global centre g + 0.5 within [c - e, c + e].
      // coordToIndex(x, 1.0) is floor(x) as an integer, and ceil(x) = -floor(-x).
      gmin[i] = -coordToIndex(-(c[i] - e[i] - 0.5 - kHair), 1.0);
      gmax[i] = coordToIndex(c[i] + e[i] - 0.5 + kHair, 1.0);
    }
  }
  // Extends [gmin, gmax] by the candidates at this pose.
  void extendCandidates(const LocalGrid::Leaf& leaf, VoxelKey& gmin, VoxelKey& gmax) const {
    VoxelKey lo;
    VoxelKey hi;
    candidates(leaf, lo, hi);
    gmin = gmin.cwiseMin(lo);
    gmax = gmax.cwiseMax(hi);
  }

  bool holds(const LocalGrid::Leaf& leaf, const Eigen::Vector3d& centre_world) const {
    const VoxelKey local = pointToKey(entry_.toSubmap(centre_world), inv_resolution_);
    return (local.array() >= leaf.min.array()).all() && (local.array() <= leaf.max.array()).all();
  }

 private:
  const SubmapEntry& entry_;
  double inv_resolution_;
  Eigen::Matrix3d R_;
  Eigen::Vector3d t_voxels_;
  std::array<Eigen::Vector3d, 17> half_extent_;  // of a rotated cube of side 2^s voxels (OctoMap's levels)
};

}  // namespace

template <class Sink>
void MergedMap::evaluate(const MergeOp& op, Sink&& sink) const {
  const double res = config_.resolution_m;
  const Placement to(*op.entry, inv_resolution_);
  // Over every leaf: the candidates, each tested exactly. `moving` (a compile-time flag: the test of the
  // old pose stays out of the inner loop of a plain merge) adds the old pose's candidates and test.
  const auto run = [&](auto moving, const Placement* from) {
    op.entry->grid->forEachLeaf([&](const LocalGrid::Leaf& leaf) {
      VoxelKey gmin;
      VoxelKey gmax;
      to.candidates(leaf, gmin, gmax);
      if constexpr (decltype(moving)::value) from->extendCandidates(leaf, gmin, gmax);
      VoxelKey g;
      for (g.z() = gmin.z(); g.z() <= gmax.z(); ++g.z()) {
        for (g.y() = gmin.y(); g.y() <= gmax.y(); ++g.y()) {
          for (g.x() = gmin.x(); g.x() <= gmax.x(); ++g.x()) {
            const Eigen::Vector3d centre = keyToCentre(g, res);
            const bool in = to.holds(leaf, centre);
            if constexpr (decltype(moving)::value) {
              // A move changes only the centres that enter or leave the leaf.
              if (in == from->holds(leaf, centre)) continue;
              sink(packBlock(blockOf(g)), indexIn(g), in ? op.sign : -op.sign, leaf.log_odds);
            } else {
              if (in) sink(packBlock(blockOf(g)), indexIn(g), op.sign, leaf.log_odds);
            }
          }
        }
      }
    });
  };
  if (op.from == nullptr) {
    run(std::false_type{}, nullptr);
  } else {
    const Placement from(*op.from, inv_resolution_);
    run(std::true_type{}, &from);
  }
}

void MergedMap::applyParallel(const std::vector<MergeOp>& ops, std::size_t begin, std::size_t end,
                              const MergeThreads& threads) {
  std::vector<std::vector<Contribution>>& scratch = lists_.lists;
  const auto tasks = static_cast<std::size_t>(std::min(threads.tasks, kShards));
  const std::size_t n = end - begin;
  if (scratch.size() < n * tasks) scratch.resize(n * tasks);
  for (auto& list : scratch) list.clear();
  // The task owning each shard, looked up per voxel (instead of a 64-bit division by `tasks` per voxel).
  std::array<std::uint8_t, kShards> owner{};
  for (std::size_t s = 0; s < owner.size(); ++s) owner[s] = static_cast<std::uint8_t>(s % tasks);
  // Phase 1: each op evaluated by one task, read-only, into one list per owner of the shards it touches.
  threads.run([&](int task) {
    if (static_cast<std::size_t>(task) >= tasks) return;  // more threads than shards: idle
    for (std::size_t k = static_cast<std::size_t>(task); k < n; k += tasks) {
      std::vector<Contribution>* lists = &scratch[k * tasks];
      evaluate(ops[begin + k], [&](std::uint64_t packed, int index, int sign, float value) {
        lists[owner[static_cast<std::size_t>(shardOf(packed))]].push_back(
            {packed, value, static_cast<std::int16_t>(sign), static_cast<std::uint16_t>(index)});
      });
    }
  });
  // Phase 2: each task writes only its shards, op by op in order.
  threads.run([&](int task) {
    if (static_cast<std::size_t>(task) >= tasks) return;
    WriteCursor cursor;
    FixedDelta delta;
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint64_t version = ops[begin + k].version;
      for (const Contribution& c : scratch[k * tasks + static_cast<std::size_t>(task)]) {
        addVoxel(cursor, c.packed, c.index, delta(c.sign, c.log_odds), version);
      }
      finishOp(cursor, version);
    }
  });
}

void MergedMap::applySerial(const MergeOp& op) {
  WriteCursor cursor;
  FixedDelta delta;
  evaluate(op, [&](std::uint64_t packed, int index, int sign, float value) {
    addVoxel(cursor, packed, static_cast<std::size_t>(index), delta(sign, value), op.version);
  });
  finishOp(cursor, op.version);
}

void MergedMap::addVoxel(WriteCursor& cursor, std::uint64_t packed, std::size_t index, std::int64_t delta,
                         std::uint64_t version) {
  if (packed != cursor.packed) {
    cursor.packed = packed;
    Shard& shard = shards_[static_cast<std::size_t>(shardOf(packed))];
    auto& slot = shard.blocks.slot(packed);
    if (!slot) {
      slot = std::make_shared<Block>();
      slot->generation = generation_;
      shard.removed.erase(packed);
    } else if (slot->generation != generation_) {
      // A snapshot taken since the block was made may hold it: copy on write. (Not use_count(): a reader
      // dropping its snapshot is a relaxed decrement that orders nothing against its last reads of the
      // block.)
      slot = std::make_shared<Block>(*slot);
      slot->generation = generation_;
    }
    cursor.block = slot.get();
    cursor.block->version = version;
  }
  Block* block = cursor.block;
  const std::uint32_t before = block->count(index);
  block->packed[index] += delta;
  if (before == 0) ++block->n_known;
  if (block->count(index) == 0) {
    --block->n_known;
    if (block->n_known == 0) cursor.emptied.push_back(packed);
  }
}

void MergedMap::finishOp(WriteCursor& cursor, std::uint64_t version) {
  for (std::uint64_t packed : cursor.emptied) {
    Shard& shard = shards_[static_cast<std::size_t>(shardOf(packed))];
    const Block* b = shard.blocks.find(packed);
    if (b != nullptr && b->n_known == 0) {
      shard.blocks.erase(packed);
      shard.removed[packed] = version;
    }
  }
  cursor.emptied.clear();
  cursor.block = nullptr;
  cursor.packed = ~std::uint64_t{0};
}

std::shared_ptr<const MergedMap> MergedMap::snapshot() {
  ++generation_;  // every block existing now is shared with this snapshot from here on
  return std::make_shared<const MergedMap>(*this);
}

std::size_t MergedMap::knownVoxelCount() const {
  std::size_t n = 0;
  for (const Shard& shard : shards_) {
    shard.blocks.forEach([&](std::uint64_t, const std::shared_ptr<Block>& block) { n += block->n_known; });
  }
  return n;
}

std::size_t MergedMap::blockCount() const {
  std::size_t n = 0;
  for (const Shard& shard : shards_) n += shard.blocks.size();
  return n;
}

std::size_t MergedMap::memoryBytes() const {
  // Blocks with their shared_ptr control blocks (make_shared: one allocation), and the table.
  const std::size_t per_block = sizeof(Block) + 2 * sizeof(long) + 16;
  std::size_t table_bytes = 0;
  for (const Shard& shard : shards_) table_bytes += shard.blocks.memoryBytes();
  return blockCount() * per_block + table_bytes;
}

std::vector<std::pair<VoxelKey, std::shared_ptr<const MergedMap::Block>>> MergedMap::blocksChangedSince(
    std::uint64_t since_version) const {
  std::vector<std::pair<VoxelKey, std::shared_ptr<const Block>>> out;
  for (const Shard& shard : shards_) {
    shard.blocks.forEach([&](std::uint64_t packed, const std::shared_ptr<Block>& block) {
      if (block->version > since_version) out.emplace_back(unpackBlock(packed) * kBlockSide, block);
    });
  }
  return out;
}

std::vector<VoxelKey> MergedMap::blocksRemovedSince(std::uint64_t since_version) const {
  std::vector<VoxelKey> out;
  if (since_version == 0) return out;  // the map at version 0 is empty: nothing of it can have gone
  for (const Shard& shard : shards_) {
    for (const auto& [packed, version] : shard.removed) {
      if (version > since_version) out.push_back(unpackBlock(packed) * kBlockSide);
    }
  }
  return out;
}

bool MergedMap::sameVoxels(const MergedMap& other) const {
  if (blockCount() != other.blockCount()) return false;
  bool same = true;
  for (std::size_t s = 0; s < shards_.size(); ++s) {
    shards_[s].blocks.forEach([&](std::uint64_t packed, const std::shared_ptr<Block>& block) {
      const Block* theirs = other.shards_[s].blocks.find(packed);
      same = same && theirs != nullptr && block->packed == theirs->packed;
    });
  }
  return same;
}

std::unique_ptr<octomap::OcTree> MergedMap::toOcTree() const {
  auto tree = std::make_unique<octomap::OcTree>(config_.resolution_m);
  tree->setProbHit(config_.prob_hit);
  tree->setProbMiss(config_.prob_miss);
  tree->setClampingThresMin(config_.clamp_min);
  tree->setClampingThresMax(config_.clamp_max);
  tree->setOccupancyThres(config_.occupancy_threshold);
  forEachKnown([&](const VoxelKey& key, const VoxelValue& value) {
    octomap::OcTreeKey k;
    for (int i = 0; i < 3; ++i) k[static_cast<unsigned>(i)] = static_cast<octomap::key_type>(key[i] + 32768);
    tree->setNodeValue(k, static_cast<float>(value.log_odds), true);
  });
  tree->updateInnerOccupancy();
  return tree;
}

Status MergedMap::writeOt(const std::filesystem::path& file) const {
  return writeOcTreeFile(*toOcTree(), file, OcTreeFormat::kFull);
}

Status MergedMap::writeBt(const std::filesystem::path& file) const {
  return writeOcTreeFile(*toOcTree(), file, OcTreeFormat::kBinary);
}

}  // namespace vog::map
