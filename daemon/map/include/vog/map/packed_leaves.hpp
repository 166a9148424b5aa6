#pragma once
// The resident form of a closed submap's occupancy: the leaves of its OcTree, in about 1.3 bytes per
// leaf instead of the tree's 50-80 (a closed submap of 100 scans has 100,000-200,000 leaves).
//
// An OcTree leaf is a cube of 2^s voxels per side whose minimum key (in OctoMap's key space, voxel
// index + 32768) is a multiple of 2^s. Interleaving the three 16-bit keys (x in bit 0, y in bit 1, z in
// bit 2: OctoMap's child order) gives a 48-bit Morton code; a leaf covers the contiguous codes
// [code, code + 8^s), and the tree's depth-first order is the order of the codes. So the leaves are
// stored sorted by code, each as
//   one header byte: bits 0-3 the value's index in a per-grid palette of log-odds (15: a varint
//   follows), bits 4-6 the side's log2 s (7: a byte follows), bit 7 set when the leaf does not start
//   where the previous one ended (a varint of the gap follows);
// and every 64th leaf's code and byte offset are indexed, so a point query is a binary search over the
// index and a scan of at most 64 leaves. Log-odds are kept exactly (the palette holds the floats; a
// grid has a few dozen distinct values at most, from sums of the hit and miss updates and clamping).
//
// The tree itself is a function of its leaves (a node exists when it is an ancestor of a leaf, and
// after OcTree::updateInnerOccupancy an inner node holds the largest log-odds of its children), so
// writeOcTree() reproduces OctoMap's .ot file of the tree byte for byte without the tree.

#include "vog/map/voxel_key.hpp"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace vog::map {

namespace morton {

constexpr int kKeyOffset = 32768;  // OctoMap key = voxel index + 32768

// Spreads the low 16 bits of v so that bit i moves to bit 3i.
inline std::uint64_t spread(std::uint64_t v) {
  v &= 0xffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

// The inverse of spread: gathers bits 0, 3, 6, ... into the low 16 bits.
inline std::uint64_t compact(std::uint64_t v) {
  v &= 0x1249249249249249ULL;
  v = (v ^ (v >> 2)) & 0x10c30c30c30c30c3ULL;
  v = (v ^ (v >> 4)) & 0x100f00f00f00f00fULL;
  v = (v ^ (v >> 8)) & 0x1f0000ff0000ffULL;
  v = (v ^ (v >> 16)) & 0x1f00000000ffffULL;
  v = (v ^ (v >> 32)) & 0x1fffffULL;
  return v;
}

inline bool inRange(const VoxelKey& k) { return (k.array() >= -kKeyOffset).all() && (k.array() < kKeyOffset).all(); }

// The code of a voxel key; the key must be inRange().
inline std::uint64_t encode(const VoxelKey& k) {
  return spread(static_cast<std::uint64_t>(k.x() + kKeyOffset)) |
         spread(static_cast<std::uint64_t>(k.y() + kKeyOffset)) << 1 |
         spread(static_cast<std::uint64_t>(k.z() + kKeyOffset)) << 2;
}

inline VoxelKey decode(std::uint64_t code) {
  return {static_cast<int>(compact(code)) - kKeyOffset, static_cast<int>(compact(code >> 1)) - kKeyOffset,
          static_cast<int>(compact(code >> 2)) - kKeyOffset};
}

}  // namespace morton

class PackedLeaves {
 public:
  struct Leaf {
    VoxelKey min;       // the cube's minimum voxel key
    int span_log2 = 0;  // the cube's side is 2^span_log2 voxels
    float log_odds = 0.0f;
  };

  PackedLeaves() = default;
  // Packs octree leaves (any order; they are sorted here). Each must be a cube aligned to its side in
  // OctoMap's key space, inside it, and disjoint from the others, as the leaves of an OcTree are;
  // anything else is a programming error (asserted).
  static PackedLeaves pack(std::vector<Leaf> leaves);

  std::size_t size() const { return count_; }
  bool empty() const { return count_ == 0; }
  // Log-odds of the leaf containing `key`, nullopt where no leaf does.
  std::optional<float> find(const VoxelKey& key) const;
  // Calls f(const Leaf&) for every leaf in code order (OctoMap's depth-first leaf order).
  template <class F>
  void forEach(F&& f) const;
  // Heap bytes held.
  std::size_t memoryBytes() const;
  // OctoMap's .ot file of the OcTree with these leaves at this resolution: the bytes
  // OcTree::write produces after updateInnerOccupancy.
  std::string writeOcTree(double resolution) const;

 private:
  static constexpr std::size_t kGroup = 64;  // leaves per index entry

  // Decodes one leaf at p, advancing p; `end` is the code just past the previous leaf.
  struct Cursor {
    const std::uint8_t* p;
    std::uint64_t end;
    std::uint64_t code = 0;
    int span_log2 = 0;
    std::uint32_t value = 0;
    void next();
  };

  std::vector<std::uint8_t> bytes_;
  std::vector<std::uint64_t> group_code_;    // code of each group's first leaf
  std::vector<std::uint32_t> group_offset_;  // its offset in bytes_
  std::vector<float> palette_;
  std::size_t count_ = 0;
};

inline void PackedLeaves::Cursor::next() {
  auto varint = [this] {
    std::uint64_t v = 0;
    for (int shift = 0;; shift += 7) {
      const std::uint8_t b = *p++;
      v |= static_cast<std::uint64_t>(b & 0x7f) << shift;
      if ((b & 0x80) == 0) return v;
    }
  };
  const std::uint8_t header = *p++;
  std::uint64_t gap = 0;
  if ((header & 0x80) != 0) gap = varint();
  span_log2 = (header >> 4) & 7;
  if (span_log2 == 7) span_log2 = *p++;
  value = header & 15;
  if (value == 15) value = static_cast<std::uint32_t>(varint());
  code = end + gap;
  end = code + (std::uint64_t{1} << (3 * span_log2));
}

template <class F>
void PackedLeaves::forEach(F&& f) const {
  Leaf leaf;
  for (std::size_t g = 0; g < group_code_.size(); ++g) {
    Cursor c{bytes_.data() + group_offset_[g], group_code_[g]};
    const std::size_t n = std::min(kGroup, count_ - g * kGroup);
    for (std::size_t i = 0; i < n; ++i) {
      c.next();
      leaf.min = morton::decode(c.code);
      leaf.span_log2 = c.span_log2;
      leaf.log_odds = palette_[c.value];
      f(leaf);
    }
  }
}

}  // namespace vog::map
