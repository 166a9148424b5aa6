#include "vog/map/merged_map.hpp"

#include "vog/map/octree_file.hpp"

#include <octomap/OcTree.h>

#include <atomic>
#include <cmath>

namespace vog::map {

namespace {
constexpr int kPackBits = 21;
constexpr std::uint64_t kPackMask = (std::uint64_t{1} << kPackBits) - 1;
constexpr int kPackBias = 1 << (kPackBits - 1);
}  // namespace

Status MergeConfig::validate() const {
  if (!(remerge_translation_m >= 0.0) || !std::isfinite(remerge_translation_m))
    return Error{"merge.remerge_translation_m must be finite and >= 0, got " + std::to_string(remerge_translation_m)};
  if (!(remerge_rotation_rad >= 0.0) || !std::isfinite(remerge_rotation_rad))
    return Error{"merge.remerge_rotation_rad must be finite and >= 0, got " + std::to_string(remerge_rotation_rad)};
  return {};
}

std::uint64_t MergedMap::packBlock(const VoxelKey& b) {
  return (static_cast<std::uint64_t>(b.x() + kPackBias) & kPackMask) |
         ((static_cast<std::uint64_t>(b.y() + kPackBias) & kPackMask) << kPackBits) |
         ((static_cast<std::uint64_t>(b.z() + kPackBias) & kPackMask) << (2 * kPackBits));
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

const MergedMap::Block* MergedMap::findBlock(const VoxelKey& key) const {
  return blocks_.find(packBlock(blockOf(key)));
}

VoxelValue MergedMap::valueOf(const Block& block, int index) const {
  const auto i = static_cast<std::size_t>(index);
  if (block.count(i) == 0) return {};
  const double clamped = bounds_.clamp(block.sum(i));
  return {clamped, bounds_.classify(clamped)};
}

VoxelValue MergedMap::at(const VoxelKey& key) const {
  const Block* block = findBlock(key);
  return block != nullptr ? valueOf(*block, indexIn(key)) : VoxelValue{};
}

VoxelValue MergedMap::query(const Eigen::Vector3d& p_world) const {
  if (!p_world.allFinite()) return {};
  return at(pointToKey(p_world, inv_resolution_));
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
      block = blocks_.find(packed);
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
  apply(entry, +1);
  merged_.emplace(entry.id, entry);
  return {};
}

Status MergedMap::remove(SubmapId id) {
  const auto it = merged_.find(id);
  if (it == merged_.end()) return Error{"merge: submap " + std::to_string(id) + " is not merged"};
  ++version_;
  apply(it->second, -1);
  merged_.erase(it);
  return {};
}

Result<SyncStats> MergedMap::sync(const std::vector<SubmapEntry>& entries, const MergeConfig& config,
                                  const std::function<bool()>& cancelled) {
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
    if (!geometry::isValidPose(e.T_world_submap))
      return Error{"merge: pose of submap " + std::to_string(e.id) + " is not a finite rigid transform"};
  }
  SyncStats stats;
  std::vector<SubmapId> gone;
  for (const auto& [id, e] : merged_) {
    if (wanted.count(id) == 0) gone.push_back(id);
  }
  for (SubmapId id : gone) {
    if (stop()) return cancel_error;
    (void)remove(id);
    ++stats.removed;
  }
  for (const auto& e : entries) {
    if (stop()) return cancel_error;
    const auto it = merged_.find(e.id);
    if (it == merged_.end()) {
      if (auto s = add(e); !s) return s.error();
      ++stats.added;
      continue;
    }
    const SubmapEntry& old = it->second;
    // Moves accumulate against the pose the submap was merged at, so many small ones still trigger.
    const bool same_pose = old.T_world_submap.matrix() == e.T_world_submap.matrix();
    const bool exact = config.remerge_translation_m == 0.0 && config.remerge_rotation_rad == 0.0;
    const bool beyond_tolerance =
        geometry::translationDistance(old.T_world_submap, e.T_world_submap) > config.remerge_translation_m ||
        geometry::rotationAngle(old.T_world_submap, e.T_world_submap) > config.remerge_rotation_rad;
    const bool moved = old.grid != e.grid || (!same_pose && (exact || beyond_tolerance));
    if (!moved) continue;
    (void)remove(e.id);
    if (auto s = add(e); !s) return s.error();
    ++stats.remerged;
  }
  return stats;
}

void MergedMap::apply(const SubmapEntry& entry, int sign) {
  const double res = config_.resolution_m;
  const Eigen::Matrix3d R = entry.T_world_submap.linear();
  const Eigen::Matrix3d R_abs = R.cwiseAbs();
  const Eigen::Vector3d t = entry.T_world_submap.translation();

  Block* block = nullptr;
  std::uint64_t block_packed = ~std::uint64_t{0};
  std::vector<std::uint64_t> emptied;

  entry.grid->forEachLeaf([&](const LocalGrid::Leaf& leaf) {
    // World box of the leaf's rotated cube; global centres inside it are the candidates.
    const Eigen::Vector3d lo = leaf.min.cast<double>() * res;
    const Eigen::Vector3d hi = (leaf.max.cast<double>().array() + 1.0).matrix() * res;
    const Eigen::Vector3d centre_world = R * (0.5 * (lo + hi)) + t;
    const Eigen::Vector3d extent_world = R_abs * (0.5 * (hi - lo));
    VoxelKey gmin;
    VoxelKey gmax;
    for (int i = 0; i < 3; ++i) {
      // Centre (g + 0.5) * res within [c - e, c + e], widened by a hair: candidates are verified below.
      gmin[i] = static_cast<int>(std::ceil((centre_world[i] - extent_world[i]) * inv_resolution_ - 0.5 - 1e-6));
      gmax[i] = static_cast<int>(std::floor((centre_world[i] + extent_world[i]) * inv_resolution_ - 0.5 + 1e-6));
    }
    // One addition updates sum and count together: value * 2^16 + 1 (times the sign).
    const std::int64_t delta =
        sign * (std::llround(static_cast<double>(leaf.log_odds) * kFixedScale) * (std::int64_t{1} << kCountBits) + 1);
    VoxelKey g;
    for (g.z() = gmin.z(); g.z() <= gmax.z(); ++g.z()) {
      for (g.y() = gmin.y(); g.y() <= gmax.y(); ++g.y()) {
        for (g.x() = gmin.x(); g.x() <= gmax.x(); ++g.x()) {
          const VoxelKey local = pointToKey(entry.toSubmap(keyToCentre(g, res)), inv_resolution_);
          if ((local.array() < leaf.min.array()).any() || (local.array() > leaf.max.array()).any()) continue;
          const std::uint64_t packed = packBlock(blockOf(g));
          if (packed != block_packed) {
            block_packed = packed;
            auto& slot = blocks_.slot(packed);
            if (!slot) {
              slot = std::make_shared<Block>();
              slot->generation = generation_;
              removed_.erase(packed);
            } else if (slot->generation != generation_) {
              // A snapshot taken since the block was made may hold it: copy on write. (Not use_count():
              // a reader dropping its snapshot is a relaxed decrement that orders nothing against its
              // last reads of the block.)
              slot = std::make_shared<Block>(*slot);
              slot->generation = generation_;
            }
            block = slot.get();
            block->version = version_;
          }
          const auto i = static_cast<std::size_t>(indexIn(g));
          const std::uint32_t before = block->count(i);
          block->packed[i] += delta;
          if (before == 0) ++block->n_known;
          if (block->count(i) == 0) {
            --block->n_known;
            if (block->n_known == 0) emptied.push_back(packed);
          }
        }
      }
    }
  });
  for (std::uint64_t packed : emptied) {
    const Block* b = blocks_.find(packed);
    if (b != nullptr && b->n_known == 0) {
      blocks_.erase(packed);
      removed_[packed] = version_;
    }
  }
}

std::shared_ptr<const MergedMap> MergedMap::snapshot() {
  ++generation_;  // every block existing now is shared with this snapshot from here on
  return std::make_shared<const MergedMap>(*this);
}

std::size_t MergedMap::knownVoxelCount() const {
  std::size_t n = 0;
  blocks_.forEach([&](std::uint64_t, const std::shared_ptr<Block>& block) { n += block->n_known; });
  return n;
}

std::size_t MergedMap::memoryBytes() const {
  // Blocks with their shared_ptr control blocks (make_shared: one allocation), and the table.
  const std::size_t per_block = sizeof(Block) + 2 * sizeof(long) + 16;
  return blocks_.size() * per_block + blocks_.memoryBytes();
}

std::vector<std::pair<VoxelKey, std::shared_ptr<const MergedMap::Block>>> MergedMap::blocksChangedSince(
    std::uint64_t since_version) const {
  std::vector<std::pair<VoxelKey, std::shared_ptr<const Block>>> out;
  blocks_.forEach([&](std::uint64_t packed, const std::shared_ptr<Block>& block) {
    if (block->version > since_version) out.emplace_back(unpackBlock(packed) * kBlockSide, block);
  });
  return out;
}

std::vector<VoxelKey> MergedMap::blocksRemovedSince(std::uint64_t since_version) const {
  std::vector<VoxelKey> out;
  if (since_version == 0) return out;  // the map at version 0 is empty: nothing of it can have gone
  for (const auto& [packed, version] : removed_) {
    if (version > since_version) out.push_back(unpackBlock(packed) * kBlockSide);
  }
  return out;
}

bool MergedMap::sameVoxels(const MergedMap& other) const {
  if (blocks_.size() != other.blocks_.size()) return false;
  bool same = true;
  blocks_.forEach([&](std::uint64_t packed, const std::shared_ptr<Block>& block) {
    const Block* theirs = other.blocks_.find(packed);
    same = same && theirs != nullptr && block->packed == theirs->packed;
  });
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
