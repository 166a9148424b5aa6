#include "vog/map/packed_leaves.hpp"

#include "vog/map/local_grid.hpp"
#include "vog/map/octree_file.hpp"

#include "synthetic_scene.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <bit>
#include <random>
#include <set>
#include <sstream>

namespace vog::map {
namespace {

using Leaf = PackedLeaves::Leaf;

bool sameLeaves(const std::vector<Leaf>& a, const std::vector<Leaf>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].min != b[i].min || a[i].span_log2 != b[i].span_log2 ||
        std::bit_cast<std::uint32_t>(a[i].log_odds) != std::bit_cast<std::uint32_t>(b[i].log_odds)) {
      return false;
    }
  }
  return true;
}

std::vector<Leaf> unpack(const PackedLeaves& packed) {
  std::vector<Leaf> out;
  packed.forEach([&](const Leaf& leaf) { out.push_back(leaf); });
  return out;
}

// Random octree leaves: a cube of side 2^top at an aligned random place, split at random into
// children, each kept as a leaf, left unknown or split again; values from a palette of `n_values`.
std::vector<Leaf> randomLeaves(std::mt19937_64& rng, int top, int n_values) {
  std::uniform_int_distribution<int> cell(-(1 << (15 - top)), (1 << (15 - top)) - 1);
  std::uniform_real_distribution<float> value(-2.0f, 3.5f);
  std::vector<float> palette;
  for (int i = 0; i < n_values; ++i) palette.push_back(value(rng));
  std::uniform_int_distribution<int> pick(0, n_values - 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Leaf> out;
  auto split = [&](auto&& self, const VoxelKey& min, int span_log2) -> void {
    const double r = u(rng);
    // The root always splits; below it, 2.4 children split on average per node.
    if (span_log2 == 0 || (r < 0.35 && span_log2 < top)) {
      out.push_back({min, span_log2, palette[static_cast<std::size_t>(pick(rng))]});
    } else if (r < 0.7 && span_log2 < top) {
      return;  // unknown
    } else {
      const int half = 1 << (span_log2 - 1);
      for (int c = 0; c < 8; ++c) {
        self(self, VoxelKey(min.x() + (c & 1) * half, min.y() + ((c >> 1) & 1) * half, min.z() + ((c >> 2) & 1) * half),
             span_log2 - 1);
      }
    }
  };
  split(split, VoxelKey(cell(rng), cell(rng), cell(rng)) * (1 << top), top);
  return out;
}

// The voxel's value by brute force over the leaves.
std::optional<float> bruteFind(const std::vector<Leaf>& leaves, const VoxelKey& k) {
  for (const Leaf& leaf : leaves) {
    const VoxelKey max = leaf.min + VoxelKey::Constant((1 << leaf.span_log2) - 1);
    if ((k.array() >= leaf.min.array()).all() && (k.array() <= max.array()).all()) return leaf.log_odds;
  }
  return std::nullopt;
}

std::string octomapBytes(const octomap::OcTree& tree) {
  std::ostringstream out(std::ios_base::out | std::ios_base::binary);
  EXPECT_TRUE(tree.write(out));
  return std::move(out).str();
}

std::unique_ptr<octomap::OcTree> readTree(const std::string& bytes) {
  std::istringstream in(bytes, std::ios_base::in | std::ios_base::binary);
  std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(in));
  auto* tree = dynamic_cast<octomap::OcTree*>(any.get());
  if (tree == nullptr) return nullptr;
  any.release();
  return std::unique_ptr<octomap::OcTree>(tree);
}

TEST(Morton, EncodeAndDecodeAreInversesOverTheKeyRange) {
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<int> key(-32768, 32767);
  for (int i = 0; i < 100000; ++i) {
    const VoxelKey k(key(rng), key(rng), key(rng));
    ASSERT_EQ(morton::decode(morton::encode(k)), k);
  }
  for (const int e : {-32768, -1, 0, 1, 32767}) {
    const VoxelKey k(e, -e - 1, e);
    EXPECT_EQ(morton::decode(morton::encode(k)), k);
  }
  // x is the lowest bit of each octet (OctoMap's child index: x + 2y + 4z).
  EXPECT_EQ(morton::encode(VoxelKey(-32767, -32768, -32768)), 1u);
  EXPECT_EQ(morton::encode(VoxelKey(-32768, -32767, -32768)), 2u);
  EXPECT_EQ(morton::encode(VoxelKey(-32768, -32768, -32767)), 4u);
  EXPECT_FALSE(morton::inRange(VoxelKey(32768, 0, 0)));
  EXPECT_FALSE(morton::inRange(VoxelKey(0, -32769, 0)));
}

TEST(PackedLeaves, KeepsEveryLeafExactlyAndFindsEveryVoxel) {
  for (const std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    std::mt19937_64 rng(seed);
    // Up to 40 distinct values (the palette's escape) and sides up to 2^9 (the side's escape).
    std::vector<Leaf> leaves = randomLeaves(rng, seed % 2 == 0 ? 9 : 5, seed % 3 == 0 ? 40 : 6);
    std::vector<Leaf> shuffled = leaves;
    std::shuffle(shuffled.begin(), shuffled.end(), rng);
    const PackedLeaves packed = PackedLeaves::pack(shuffled);
    ASSERT_EQ(packed.size(), leaves.size());
    if (seed == 6) {  // both escapes are exercised
      EXPECT_TRUE(std::any_of(leaves.begin(), leaves.end(), [](const Leaf& l) { return l.span_log2 >= 7; }));
      std::set<float> values;
      for (const Leaf& l : leaves) values.insert(l.log_odds);
      EXPECT_GT(values.size(), 15u);
    }
    // randomLeaves emits in depth-first child order, which is code order.
    EXPECT_TRUE(sameLeaves(unpack(packed), leaves)) << "seed " << seed;

    // Every voxel of small leaves' neighbourhoods, and random voxels in and around the cube.
    KeyBox box;
    for (const Leaf& leaf : leaves) box.extend(leaf.min, leaf.min + VoxelKey::Constant((1 << leaf.span_log2) - 1));
    std::uniform_int_distribution<int> x(box.min.x() - 3, box.max.x() + 3);
    std::uniform_int_distribution<int> y(box.min.y() - 3, box.max.y() + 3);
    std::uniform_int_distribution<int> z(box.min.z() - 3, box.max.z() + 3);
    for (int i = 0; i < 3000; ++i) {
      const VoxelKey k(x(rng), y(rng), z(rng));
      const auto expected = bruteFind(leaves, k);
      const auto got = packed.find(k);
      ASSERT_EQ(expected.has_value(), got.has_value()) << k.transpose();
      if (expected) {
        ASSERT_EQ(*expected, *got);
      }
    }
    for (const Leaf& leaf : leaves) {
      ASSERT_EQ(packed.find(leaf.min), leaf.log_odds);
      ASSERT_EQ(packed.find(leaf.min + VoxelKey::Constant((1 << leaf.span_log2) - 1)), leaf.log_odds);
    }
  }
  EXPECT_FALSE(PackedLeaves{}.find(VoxelKey::Zero()).has_value());
  EXPECT_FALSE(PackedLeaves::pack({}).find(VoxelKey::Zero()).has_value());
  EXPECT_FALSE(PackedLeaves::pack({{VoxelKey::Zero(), 0, 1.0f}}).find(VoxelKey(40000, 0, 0)).has_value());
}

// The .ot bytes made from the leaves are OctoMap's own: OctoMap reads them back to the same leaves
// and writes them again unchanged, for sides up to 2^9 and the palette's escape.
TEST(PackedLeaves, WritesTheOcTreeFileOctoMapReadsAndWritesUnchanged) {
  for (const std::uint64_t seed : {11, 12, 13, 14}) {
    std::mt19937_64 rng(seed);
    const std::vector<Leaf> leaves = randomLeaves(rng, seed % 2 == 0 ? 9 : 6, seed % 3 == 0 ? 40 : 7);
    const std::string bytes = PackedLeaves::pack(leaves).writeOcTree(0.095);
    auto tree = readTree(bytes);
    ASSERT_TRUE(tree) << "OctoMap cannot read the file made from the leaves";
    EXPECT_EQ(octomapBytes(*tree), bytes) << "seed " << seed;
    std::vector<Leaf> read;
    for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
      const int span_log2 = 16 - static_cast<int>(it.getDepth());
      const int half = (1 << span_log2) / 2;
      const octomap::OcTreeKey& k = it.getKey();
      read.push_back(
          {VoxelKey(k[0] - 32768 - half, k[1] - 32768 - half, k[2] - 32768 - half), span_log2, it->getLogOdds()});
    }
    EXPECT_TRUE(sameLeaves(read, leaves)) << "seed " << seed;
  }
  // An empty tree: the header alone.
  octomap::OcTree empty(0.095);
  EXPECT_EQ(PackedLeaves{}.writeOcTree(0.095), octomapBytes(empty));
}

// readOcTree reads what OctoMap writes into the same tree, and names what is wrong with a bad stream.
TEST(PackedLeaves, ReadOcTreeReadsOctoMapsFilesAndNamesWhatIsWrong) {
  const auto read = [](const std::string& bytes) {
    std::istringstream in(bytes, std::ios_base::in | std::ios_base::binary);
    return readOcTree(in);
  };
  std::mt19937_64 rng(31);
  const std::string bytes = PackedLeaves::pack(randomLeaves(rng, 8, 30)).writeOcTree(0.095);
  auto tree = read(bytes);
  ASSERT_TRUE(tree.ok()) << tree.error().message;
  EXPECT_EQ(octomapBytes(**tree), bytes);
  EXPECT_EQ((*tree)->getResolution(), 0.095);
  auto empty = read(octomapBytes(octomap::OcTree(0.2)));
  ASSERT_TRUE(empty.ok()) << empty.error().message;
  EXPECT_EQ((*empty)->size(), 0u);

  const auto error = [&](const std::string& b) {
    auto r = read(b);
    return r.ok() ? std::string("(read)") : r.error().message;
  };
  EXPECT_NE(error(bytes.substr(0, bytes.size() - 7)).find("truncated"), std::string::npos);
  EXPECT_NE(error("GIF89a").find("not an OctoMap .ot stream"), std::string::npos);
  std::string other = bytes;
  other.replace(other.find("id OcTree"), 9, "id ColorOcTree");
  EXPECT_NE(error(other).find("ColorOcTree"), std::string::npos);
  EXPECT_NE(error(bytes.substr(0, bytes.find("data"))).find("no \"data\""), std::string::npos);
}

// A grid built from sonar scans: after finalize() (which drops the tree) its file, its leaves and
// every point query are those of the OcTree it was built in.
TEST(PackedLeaves, AFinalizedGridAnswersAndSavesAsItsOcTreeDid) {
  const geometry::SonarFan fan;
  for (const std::uint64_t seed : {21, 22}) {
    auto made = LocalGrid::create(GridConfig{});
    ASSERT_TRUE(made.ok());
    LocalGrid& grid = *made.value();
    const test::SyntheticScene scene = test::SyntheticScene::pier();
    std::mt19937_64 rng(seed);
    for (const geometry::Pose3& T : test::orbitTrajectory(40, 3.0 + static_cast<double>(seed % 3), -1.5)) {
      ASSERT_TRUE(grid.insertScan(T * fan.T_vehicle_sensor, fan, scene.scan(T, fan, 0.02, rng)).ok());
    }
    octomap::OcTree reference(grid.tree());
    reference.updateInnerOccupancy();
    const std::string expected = octomapBytes(reference);
    const std::vector<LocalGrid::Leaf> expected_leaves = grid.leaves();
    grid.finalize();

    auto bytes = grid.serialize();
    ASSERT_TRUE(bytes.ok()) << bytes.error().message;
    EXPECT_EQ(*bytes, expected) << "the .ot file differs from OctoMap's";
    const auto leaves = grid.leaves();
    ASSERT_EQ(leaves.size(), expected_leaves.size());
    for (std::size_t i = 0; i < leaves.size(); ++i) {
      ASSERT_EQ(leaves[i].min, expected_leaves[i].min);
      ASSERT_EQ(leaves[i].max, expected_leaves[i].max);
      ASSERT_EQ(leaves[i].log_odds, expected_leaves[i].log_odds);
    }
    const KeyBox& box = grid.knownKeys();
    ASSERT_FALSE(box.empty());
    for (int x = box.min.x() - 1; x <= box.max.x() + 1; x += 2)
      for (int y = box.min.y() - 1; y <= box.max.y() + 1; y += 2)
        for (int z = box.min.z() - 1; z <= box.max.z() + 1; ++z) {
          const VoxelKey k(x, y, z);
          octomap::OcTreeKey ok(static_cast<octomap::key_type>(x + 32768), static_cast<octomap::key_type>(y + 32768),
                                static_cast<octomap::key_type>(z + 32768));
          const octomap::OcTreeNode* node = reference.search(ok);
          const auto got = grid.logOddsAt(k);
          ASSERT_EQ(node != nullptr, got.has_value()) << k.transpose();
          if (node != nullptr) {
            ASSERT_EQ(node->getLogOdds(), *got) << k.transpose();
          }
        }
    EXPECT_LT(grid.residentBytes(), 4 * grid.leafCount() + 64 * grid.cloud().size() + 4096);
  }
}

TEST(PackedLeaves, AnOpenGridCannotBeSerialised) {
  auto made = LocalGrid::create(GridConfig{});
  ASSERT_TRUE(made.ok());
  const std::vector<BeamEnd> beams = {{Eigen::Vector3d(1.0, 0.0, 0.0), true}};
  ASSERT_TRUE((*made)->insertRays(Eigen::Vector3d::Zero(), beams).ok());
  const auto bytes = (*made)->serialize();
  ASSERT_FALSE(bytes.ok());
  EXPECT_NE(bytes.error().message.find("open"), std::string::npos);
}

}  // namespace
}  // namespace vog::map
