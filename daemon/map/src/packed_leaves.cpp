#include "vog/map/packed_leaves.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>

namespace vog::map {
namespace {

constexpr int kTreeDepth = 16;

void putVarint(std::vector<std::uint8_t>& out, std::uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<std::uint8_t>(v | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<std::uint8_t>(v));
}

std::uint32_t floatBits(float f) { return std::bit_cast<std::uint32_t>(f); }

struct Coded {
  std::uint64_t code;
  int span_log2;
  float log_odds;
};

// Writes the subtree of the node covering codes [base, base + 8^level) whose leaves are leaves[lo, hi)
// (OcTreeBaseImpl::writeNodesRecurs: the node's value, a byte with a bit per existing child, then the
// children in order) and returns the node's value: its own for a leaf, the largest of its children's
// for an inner node (OcTreeNode::getMaxChildLogOdds).
float writeNode(const std::vector<Coded>& leaves, std::size_t lo, std::size_t hi, std::uint64_t base, int level,
                std::string& out, std::size_t& nodes) {
  ++nodes;
  const std::size_t value_at = out.size();
  out.append(sizeof(float), '\0');
  if (hi - lo == 1 && leaves[lo].span_log2 == level) {
    const float v = leaves[lo].log_odds;
    std::memcpy(out.data() + value_at, &v, sizeof v);
    out.push_back('\0');
    return v;
  }
  assert(level > 0);
  const int child_shift = 3 * (level - 1);
  std::size_t bounds[9];
  std::uint8_t children = 0;
  bounds[0] = lo;
  for (int c = 0; c < 8; ++c) {
    const std::uint64_t child_end = base + (static_cast<std::uint64_t>(c + 1) << child_shift);
    std::size_t i = bounds[c];
    while (i < hi && leaves[i].code < child_end) ++i;
    bounds[c + 1] = i;
    if (i > bounds[c]) children = static_cast<std::uint8_t>(children | (1u << c));
  }
  out.push_back(static_cast<char>(children));
  float max = -std::numeric_limits<float>::max();
  for (int c = 0; c < 8; ++c) {
    if (bounds[c + 1] == bounds[c]) continue;
    const float v = writeNode(leaves, bounds[c], bounds[c + 1], base + (static_cast<std::uint64_t>(c) << child_shift),
                              level - 1, out, nodes);
    if (v > max) max = v;
  }
  std::memcpy(out.data() + value_at, &max, sizeof max);
  return max;
}

}  // namespace

PackedLeaves PackedLeaves::pack(std::vector<Leaf> leaves) {
  std::vector<Coded> coded;
  coded.reserve(leaves.size());
  for (const Leaf& leaf : leaves) {
    assert(leaf.span_log2 >= 0 && leaf.span_log2 <= kTreeDepth);
    assert(morton::inRange(leaf.min));
    coded.push_back({morton::encode(leaf.min), leaf.span_log2, leaf.log_odds});
  }
  leaves = {};
  std::sort(coded.begin(), coded.end(), [](const Coded& a, const Coded& b) { return a.code < b.code; });

  // The palette, most frequent value first (ties by bit pattern, so the bytes are a function of the
  // leaves alone).
  std::map<std::uint32_t, std::size_t> frequency;
  for (const Coded& c : coded) ++frequency[floatBits(c.log_odds)];
  std::vector<std::pair<std::size_t, std::uint32_t>> by_count;
  for (const auto& [bits, n] : frequency) by_count.emplace_back(n, bits);
  std::stable_sort(by_count.begin(), by_count.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  PackedLeaves out;
  std::map<std::uint32_t, std::uint32_t> index_of;
  for (const auto& [n, bits] : by_count) {
    index_of[bits] = static_cast<std::uint32_t>(out.palette_.size());
    out.palette_.push_back(std::bit_cast<float>(bits));
  }

  out.count_ = coded.size();
  out.bytes_.reserve(coded.size() * 3 / 2 + 16);
  std::uint64_t end = 0;
  for (std::size_t i = 0; i < coded.size(); ++i) {
    const Coded& c = coded[i];
    if (i % kGroup == 0) {
      out.group_code_.push_back(c.code);
      out.group_offset_.push_back(static_cast<std::uint32_t>(out.bytes_.size()));
      end = c.code;
    }
    assert(c.code >= end);  // disjoint and sorted
    const std::uint64_t gap = c.code - end;
    const std::uint32_t value = index_of[floatBits(c.log_odds)];
    std::uint8_t header = static_cast<std::uint8_t>(std::min<std::uint32_t>(value, 15));
    header = static_cast<std::uint8_t>(header | std::min(c.span_log2, 7) << 4);
    if (gap != 0) header = static_cast<std::uint8_t>(header | 0x80);
    out.bytes_.push_back(header);
    if (gap != 0) putVarint(out.bytes_, gap);
    if (c.span_log2 >= 7) out.bytes_.push_back(static_cast<std::uint8_t>(c.span_log2));
    if (value >= 15) putVarint(out.bytes_, value);
    end = c.code + (std::uint64_t{1} << (3 * c.span_log2));
  }
  out.bytes_.shrink_to_fit();
  out.group_code_.shrink_to_fit();
  out.group_offset_.shrink_to_fit();
  return out;
}

std::optional<float> PackedLeaves::find(const VoxelKey& key) const {
  if (count_ == 0 || !morton::inRange(key)) return std::nullopt;
  const std::uint64_t q = morton::encode(key);
  const auto it = std::upper_bound(group_code_.begin(), group_code_.end(), q);
  if (it == group_code_.begin()) return std::nullopt;
  const std::size_t g = static_cast<std::size_t>(it - group_code_.begin()) - 1;
  Cursor c{bytes_.data() + group_offset_[g], group_code_[g]};
  const std::size_t n = std::min(kGroup, count_ - g * kGroup);
  // The leaf containing q, if any, is the last one starting at or before it.
  c.next();
  std::uint64_t end = c.end;
  std::uint32_t value = c.value;
  for (std::size_t i = 1; i < n; ++i) {
    c.next();
    if (c.code > q) break;
    end = c.end;
    value = c.value;
  }
  if (q >= end) return std::nullopt;
  return palette_[value];
}

std::size_t PackedLeaves::memoryBytes() const {
  return bytes_.capacity() + group_code_.capacity() * sizeof(std::uint64_t) +
         group_offset_.capacity() * sizeof(std::uint32_t) + palette_.capacity() * sizeof(float);
}

std::string PackedLeaves::writeOcTree(double resolution) const {
  std::vector<Coded> coded;
  coded.reserve(count_);
  forEach([&](const Leaf& leaf) { coded.push_back({morton::encode(leaf.min), leaf.span_log2, leaf.log_odds}); });
  std::string data;
  std::size_t nodes = 0;
  if (!coded.empty()) {
    data.reserve(coded.size() * 6);
    writeNode(coded, 0, coded.size(), 0, kTreeDepth, data, nodes);
  }
  // AbstractOcTree::write's header.
  std::ostringstream header;
  header << "# Octomap OcTree file\n# (feel free to add / change comments, but leave the first line as it is!)\n#\n"
         << "id OcTree\nsize " << nodes << "\nres " << resolution << "\ndata\n";
  return std::move(header).str() + data;
}

}  // namespace vog::map
