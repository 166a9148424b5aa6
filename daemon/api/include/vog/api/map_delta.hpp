#pragma once
// Merged map <-> vog.v1.MapDelta (proto/vog/v1/map.proto): the server side encodes the blocks changed
// since a client's version; the client side (`MapMirror`) applies deltas to its copy.

#include "vog/core/result.hpp"
#include "vog/map/merged_map.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <tuple>

namespace octomap {
class OcTree;
}

namespace vog::v1 {
class MapDelta;
class VoxelBlock;
class BlockKey;
}  // namespace vog::v1

namespace vog::api {

// Everything changed after `since_version` (0 = the whole map) in `snapshot`.
v1::MapDelta encodeMapDelta(const map::MergedMap& snapshot, std::uint64_t since_version);

// The parts of encodeMapDelta, for transfers that encode a delta a few blocks at a time: the grid,
// versions and submap count (no blocks); one changed block (`origin` is the key of its voxel 0); one
// removed block's key.
void encodeDeltaHeader(const map::MergedMap& snapshot, std::uint64_t since_version, v1::MapDelta& delta);
void encodeBlock(const map::LogOddsBounds& bounds, const map::VoxelKey& origin, const map::MergedMap::Block& block,
                 v1::VoxelBlock& out);
void encodeRemoved(const map::VoxelKey& origin, v1::BlockKey& out);

// A client's copy of the merged map, kept up to date from deltas.
// Lifecycle: empty at version 0; each applied delta must start at the mirror's version.
class MapMirror {
 public:
  struct Block {
    std::array<float, map::MergedMap::kBlockVoxels> log_odds{};
    std::array<bool, map::MergedMap::kBlockVoxels> known{};
  };

  // Rejects (and ignores) a delta that does not start at this mirror's version, has another
  // resolution than earlier deltas, or carries malformed blocks.
  Status apply(const v1::MapDelta& delta);

  std::uint64_t version() const { return version_; }
  double resolution() const { return resolution_m_; }
  std::size_t blockCount() const { return blocks_.size(); }
  // Clamped log-odds and status of a voxel key.
  map::VoxelValue at(const map::VoxelKey& key) const;
  std::size_t knownVoxelCount() const;

  // OctoMap export as MergedMap::toOcTree does it (same keys, clamped log-odds): .ot keeps the
  // log-odds, .bt the max-likelihood map; both open in octovis. An empty mirror has no resolution and
  // is an error.
  Result<std::unique_ptr<octomap::OcTree>> toOcTree() const;
  Status writeOt(const std::filesystem::path& file) const;
  Status writeBt(const std::filesystem::path& file) const;

 private:
  std::map<std::tuple<int, int, int>, Block> blocks_;
  std::uint64_t version_ = 0;
  double resolution_m_ = 0.0;
  map::LogOddsBounds bounds_;
};

}  // namespace vog::api
