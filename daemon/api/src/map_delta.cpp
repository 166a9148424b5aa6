#include "vog/api/map_delta.hpp"

#include "vog/map/octree_file.hpp"
#include "vog/v1/map.pb.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace vog::api {

namespace {

constexpr int kVoxels = map::MergedMap::kBlockVoxels;
static_assert(std::endian::native == std::endian::little, "the wire format is little-endian float32");

int floorDiv8(int v) { return v >> map::MergedMap::kBlockBits; }

}  // namespace

void encodeDeltaHeader(const map::MergedMap& snapshot, std::uint64_t since_version, v1::MapDelta& delta) {
  const map::LogOddsBounds bounds = snapshot.config().bounds();
  auto* grid = delta.mutable_grid();
  grid->set_resolution_m(snapshot.resolution());
  grid->set_log_odds_min(bounds.min);
  grid->set_log_odds_max(bounds.max);
  grid->set_log_odds_occupied(bounds.occupied);
  delta.set_since_version(since_version);
  delta.set_version(snapshot.version());
  delta.set_n_submaps(static_cast<std::uint32_t>(snapshot.submapCount()));
}

void encodeBlock(const map::LogOddsBounds& bounds, const map::VoxelKey& origin, const map::MergedMap::Block& block,
                 v1::VoxelBlock& out) {
  out.set_origin_x(origin.x());
  out.set_origin_y(origin.y());
  out.set_origin_z(origin.z());
  out.set_version(block.version);
  std::string known(kVoxels / 8, '\0');
  std::string values(kVoxels * sizeof(float), '\0');
  for (int i = 0; i < kVoxels; ++i) {
    const auto idx = static_cast<std::size_t>(i);
    if (block.count(idx) == 0) continue;
    known[idx / 8] = static_cast<char>(known[idx / 8] | (1 << (i % 8)));
    const auto value = static_cast<float>(bounds.clamp(block.sum(idx)));
    std::memcpy(values.data() + idx * sizeof(float), &value, sizeof(float));
  }
  out.set_known(std::move(known));
  out.set_log_odds(std::move(values));
}

void encodeRemoved(const map::VoxelKey& origin, v1::BlockKey& out) {
  out.set_origin_x(origin.x());
  out.set_origin_y(origin.y());
  out.set_origin_z(origin.z());
}

v1::MapDelta encodeMapDelta(const map::MergedMap& snapshot, std::uint64_t since_version) {
  v1::MapDelta delta;
  encodeDeltaHeader(snapshot, since_version, delta);
  const map::LogOddsBounds bounds = snapshot.config().bounds();
  for (const auto& [origin, block] : snapshot.blocksChangedSince(since_version)) {
    encodeBlock(bounds, origin, *block, *delta.add_changed());
  }
  for (const auto& origin : snapshot.blocksRemovedSince(since_version)) encodeRemoved(origin, *delta.add_removed());
  return delta;
}

Status MapMirror::apply(const v1::MapDelta& delta) {
  if (delta.since_version() != version_) {
    return Error{"map delta starts at version " + std::to_string(delta.since_version()) + ", the copy is at " +
                 std::to_string(version_)};
  }
  const double res = delta.grid().resolution_m();
  if (!(res > 0.0) || !std::isfinite(res)) return Error{"map delta has an invalid resolution"};
  if (version_ != 0 && res != resolution_m_) return Error{"map delta resolution differs from the copy's"};
  for (const auto& b : delta.changed()) {
    if (b.known().size() != kVoxels / 8 || b.log_odds().size() != kVoxels * sizeof(float)) {
      return Error{"map delta block has " + std::to_string(b.known().size()) + " known bytes and " +
                   std::to_string(b.log_odds().size()) + " value bytes (want 64 and 2048)"};
    }
    if (b.origin_x() % 8 != 0 || b.origin_y() % 8 != 0 || b.origin_z() % 8 != 0) {
      return Error{"map delta block origin is not a multiple of 8"};
    }
  }
  // Validated: apply removals first (a block may be removed and rebuilt within one delta).
  for (const auto& k : delta.removed())
    blocks_.erase({floorDiv8(k.origin_x()), floorDiv8(k.origin_y()), floorDiv8(k.origin_z())});
  for (const auto& b : delta.changed()) {
    Block& block = blocks_[{floorDiv8(b.origin_x()), floorDiv8(b.origin_y()), floorDiv8(b.origin_z())}];
    for (int i = 0; i < kVoxels; ++i) {
      const auto idx = static_cast<std::size_t>(i);
      block.known[idx] = (static_cast<unsigned char>(b.known()[idx / 8]) >> (i % 8)) & 1u;
      std::memcpy(&block.log_odds[idx], b.log_odds().data() + idx * sizeof(float), sizeof(float));
    }
  }
  version_ = delta.version();
  resolution_m_ = res;
  bounds_ = {delta.grid().log_odds_min(), delta.grid().log_odds_max(), delta.grid().log_odds_occupied()};
  return {};
}

map::VoxelValue MapMirror::at(const map::VoxelKey& key) const {
  const auto it = blocks_.find({floorDiv8(key.x()), floorDiv8(key.y()), floorDiv8(key.z())});
  if (it == blocks_.end()) return {};
  const int i = (key.x() & 7) | ((key.y() & 7) << 3) | ((key.z() & 7) << 6);
  const auto idx = static_cast<std::size_t>(i);
  if (!it->second.known[idx]) return {};
  const double l = static_cast<double>(it->second.log_odds[idx]);
  return {l, bounds_.classify(l)};
}

std::size_t MapMirror::knownVoxelCount() const {
  std::size_t n = 0;
  for (const auto& [origin, block] : blocks_)
    n += static_cast<std::size_t>(std::count(block.known.begin(), block.known.end(), true));
  return n;
}

Result<std::unique_ptr<octomap::OcTree>> MapMirror::toOcTree() const {
  if (!(resolution_m_ > 0.0)) return Error{"the map copy is empty (no delta applied yet)"};
  auto tree = std::make_unique<octomap::OcTree>(resolution_m_);
  // OctoMap stores probabilities for its thresholds; the delta carries their log-odds.
  const auto probability = [](double l) { return 1.0 / (1.0 + std::exp(-l)); };
  tree->setClampingThresMin(probability(bounds_.min));
  tree->setClampingThresMax(probability(bounds_.max));
  tree->setOccupancyThres(probability(bounds_.occupied));
  // OctoMap keys are 16-bit with the origin at 2^15 (OcTreeKey); voxels beyond are not representable.
  constexpr int kKeyOffset = 32768;
  std::size_t skipped = 0;
  for (const auto& [origin, block] : blocks_) {
    for (int i = 0; i < kVoxels; ++i) {
      const auto idx = static_cast<std::size_t>(i);
      if (!block.known[idx]) continue;
      const int key[3] = {std::get<0>(origin) * 8 + (i & 7), std::get<1>(origin) * 8 + ((i >> 3) & 7),
                          std::get<2>(origin) * 8 + (i >> 6)};
      octomap::OcTreeKey k;
      bool inside = true;
      for (unsigned a = 0; a < 3; ++a) {
        const int v = key[a] + kKeyOffset;
        inside = inside && v >= 0 && v <= 0xFFFF;
        k[a] = static_cast<octomap::key_type>(v & 0xFFFF);
      }
      if (!inside) {
        ++skipped;
        continue;
      }
      tree->setNodeValue(k, block.log_odds[idx], true);
    }
  }
  if (skipped > 0) return Error{std::to_string(skipped) + " voxels lie outside OctoMap's key range"};
  tree->updateInnerOccupancy();
  return tree;
}

Status MapMirror::writeOt(const std::filesystem::path& file) const {
  auto tree = toOcTree();
  if (!tree) return tree.error();
  return map::writeOcTreeFile(**tree, file, map::OcTreeFormat::kFull);
}

Status MapMirror::writeBt(const std::filesystem::path& file) const {
  auto tree = toOcTree();
  if (!tree) return tree.error();
  return map::writeOcTreeFile(**tree, file, map::OcTreeFormat::kBinary);
}

}  // namespace vog::api
