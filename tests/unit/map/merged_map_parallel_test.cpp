// MergedMap::sync with threads: the merged map (every voxel's sum and count, every block's version, the
// removal records) equals the serial merge's exactly, for any number of tasks, for a merge from scratch,
// growth one submap at a time, a partial re-merge and a re-merge of every submap.
#include "vog/map/merge_worker.hpp"
#include "vog/map/merged_map.hpp"

#include "map_fixtures.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <map>
#include <tuple>

namespace vog::map {
namespace {

using geometry::poseFromXyzRpy;
using BlockOrigin = std::tuple<int, int, int>;

struct BlockDump {
  std::array<std::int64_t, MergedMap::kBlockVoxels> packed{};
  std::uint32_t n_known = 0;
  std::uint64_t version = 0;
};

std::map<BlockOrigin, BlockDump> dump(const MergedMap& m) {
  std::map<BlockOrigin, BlockDump> out;
  for (const auto& [origin, block] : m.blocksChangedSince(0)) {
    BlockDump& d = out[{origin.x(), origin.y(), origin.z()}];
    d.packed = block->packed;
    d.n_known = block->n_known;
    d.version = block->version;
  }
  return out;
}

std::map<BlockOrigin, int> removedSince(const MergedMap& m, std::uint64_t since) {
  std::map<BlockOrigin, int> out;
  for (const VoxelKey& origin : m.blocksRemovedSince(since)) ++out[{origin.x(), origin.y(), origin.z()}];
  return out;
}

// Voxel for voxel: the same blocks, the same sums and counts (the packed int64s), the same versions.
void expectSameMap(const MergedMap& parallel, const MergedMap& serial, bool same_versions) {
  const auto a = dump(parallel);
  const auto b = dump(serial);
  ASSERT_EQ(a.size(), b.size());
  std::size_t voxels = 0;
  for (const auto& [origin, block] : b) {
    const auto it = a.find(origin);
    ASSERT_NE(it, a.end()) << "block " << std::get<0>(origin) << " " << std::get<1>(origin) << " "
                           << std::get<2>(origin) << " missing";
    for (int i = 0; i < MergedMap::kBlockVoxels; ++i) {
      const auto k = static_cast<std::size_t>(i);
      ASSERT_EQ(it->second.packed[k], block.packed[k]) << "voxel " << i;
      voxels += (block.packed[k] & 0xFFFF) != 0;
    }
    EXPECT_EQ(it->second.n_known, block.n_known);
    if (same_versions) {
      EXPECT_EQ(it->second.version, block.version);
    }
  }
  EXPECT_TRUE(parallel.sameVoxels(serial));
  EXPECT_EQ(parallel.knownVoxelCount(), voxels);
  EXPECT_GT(voxels, 1000u);
}

// Tasks run one after the other, last first: the partition alone, without real threads.
MergeThreads sequentialReversed(int tasks) {
  MergeThreads t;
  t.tasks = tasks;
  t.run = [tasks](const std::function<void(int)>& task) {
    for (int k = tasks - 1; k >= 0; --k) task(k);
  };
  return t;
}

class MergedMapParallelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937_64 rng(5);
    for (const auto& s : test_fixtures::buildSubmaps(config_, 8, 20, 13, 4.0)) {
      // General rotations and sub-voxel translations: submaps overlap and alias.
      const auto T = test_fixtures::perturb(s.T_world_submap, 0.3, 0.15, rng);
      SubmapEntry e;
      e.id = static_cast<SubmapId>(entries_.size());
      e.grid = s.grid;
      e.T_world_submap = T;
      e.T_submap_world = T.inverse();
      entries_.push_back(e);
    }
  }

  std::unique_ptr<MergedMap> serialFromScratch(const std::vector<SubmapEntry>& entries) const {
    auto merged = MergedMap::create(config_).value();
    for (const auto& e : entries) EXPECT_TRUE(merged->add(e).ok());
    return merged;
  }

  static std::vector<SubmapEntry> moved(std::vector<SubmapEntry> entries, const std::vector<std::size_t>& which,
                                        double dx) {
    for (std::size_t k : which) {
      auto& e = entries[k];
      e.T_world_submap = poseFromXyzRpy(dx, -0.7 * dx, 0.2 * dx, 0.01, -0.02, 0.5 * dx) * e.T_world_submap;
      e.T_submap_world = e.T_world_submap.inverse();
    }
    return entries;
  }

  std::vector<MergeThreads> runners() const {
    return {spawnMergeThreads(2),  spawnMergeThreads(3),   sequentialReversed(2),
            sequentialReversed(5), sequentialReversed(16), sequentialReversed(20)};
  }

  GridConfig config_;
  std::vector<SubmapEntry> entries_;
};

TEST_F(MergedMapParallelTest, MergeFromScratchEqualsSerialVoxelForVoxel) {
  const auto serial = serialFromScratch(entries_);
  for (const MergeThreads& threads : runners()) {
    SCOPED_TRACE(threads.tasks);
    auto parallel = MergedMap::create(config_).value();
    const auto stats = parallel->sync(entries_, MergeConfig{}, {}, threads);
    ASSERT_TRUE(stats.ok()) << stats.error().message;
    EXPECT_EQ(stats->added, static_cast<int>(entries_.size()));
    EXPECT_EQ(parallel->version(), serial->version());
    expectSameMap(*parallel, *serial, true);
  }
}

TEST_F(MergedMapParallelTest, GrowthAndRemergesEqualSerialSyncs) {
  const MergeConfig exact{0.0, 0.0};
  // The same sequence of sets through a serial and a parallel sync: the same maps at every step, versions
  // and removal records included; and each equal in sums and counts to a serial merge from scratch.
  std::vector<std::vector<SubmapEntry>> sets;
  for (std::size_t n = 1; n <= entries_.size(); ++n) sets.emplace_back(entries_.begin(), entries_.begin() + n);
  sets.push_back(moved(entries_, {1, 5}, 0.2));                        // a small loop closure: out and in
  sets.push_back(moved(sets.back(), {0, 1, 2, 3, 4, 5, 6, 7}, -0.1));  // every submap moved: from scratch
  std::vector<SubmapEntry> fewer(sets.back().begin() + 2, sets.back().end());
  sets.push_back(fewer);                                // two vanish
  sets.push_back(moved(fewer, {0, 1, 2, 3, 4}, 0.05));  // most moved, two vanished earlier

  for (const MergeThreads& threads : runners()) {
    SCOPED_TRACE(threads.tasks);
    auto serial = MergedMap::create(config_).value();
    auto parallel = MergedMap::create(config_).value();
    for (std::size_t step = 0; step < sets.size(); ++step) {
      SCOPED_TRACE(step);
      const auto a = serial->sync(sets[step], exact);
      const auto b = parallel->sync(sets[step], exact, {}, threads);
      ASSERT_TRUE(a.ok() && b.ok());
      EXPECT_EQ(a->added, b->added);
      EXPECT_EQ(a->removed, b->removed);
      EXPECT_EQ(a->remerged, b->remerged);
      EXPECT_EQ(parallel->version(), serial->version());
      EXPECT_EQ(parallel->submapCount(), sets[step].size());
      expectSameMap(*parallel, *serial, true);
      EXPECT_EQ(removedSince(*parallel, 1), removedSince(*serial, 1));
      const auto scratch = serialFromScratch(sets[step]);
      expectSameMap(*parallel, *scratch, false);
    }
  }
}

// Merged from scratch when most submaps moved: blocks that were known and are not any more are reported
// as removed, blocks that changed as changed.
TEST_F(MergedMapParallelTest, RemergeOfEverySubmapReportsRemovedAndChangedBlocks) {
  auto merged = MergedMap::create(config_).value();
  ASSERT_TRUE(merged->sync(entries_, MergeConfig{}, {}, spawnMergeThreads(2)).ok());
  const auto before = dump(*merged);
  const std::uint64_t since = merged->version();
  const auto after_entries = moved(entries_, {0, 1, 2, 3, 4, 5, 6, 7}, 1.5);
  const auto stats = merged->sync(after_entries, MergeConfig{}, {}, spawnMergeThreads(2));
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->remerged, 8);
  const auto after = dump(*merged);
  const auto removed = removedSince(*merged, since);
  std::size_t gone = 0;
  for (const auto& [origin, block] : before) {
    if (after.count(origin) != 0) continue;
    ++gone;
    EXPECT_EQ(removed.count(origin), 1u);
  }
  EXPECT_GT(gone, 0u);
  EXPECT_EQ(removed.size(), gone);
  EXPECT_EQ(merged->blocksChangedSince(since).size(), after.size());
  expectSameMap(*merged, *serialFromScratch(after_entries), false);
}

// A writer shutting down stops a merge from scratch between groups and keeps the map it had.
TEST_F(MergedMapParallelTest, ACancelledRemergeOfEverySubmapLeavesTheMapAsItWas) {
  auto merged = MergedMap::create(config_).value();
  ASSERT_TRUE(merged->sync(entries_, MergeConfig{}).ok());
  const auto before = dump(*merged);
  const std::uint64_t version = merged->version();
  int asked = 0;
  const auto stats =
      merged->sync(moved(entries_, {0, 1, 2, 3, 4, 5, 6, 7}, 0.3), MergeConfig{}, [&] { return ++asked > 3; });
  ASSERT_FALSE(stats.ok());
  EXPECT_EQ(merged->version(), version);
  const auto after = dump(*merged);
  ASSERT_EQ(after.size(), before.size());
  for (const auto& [origin, block] : before) {
    ASSERT_EQ(after.count(origin), 1u);
    EXPECT_EQ(after.at(origin).packed, block.packed);
    EXPECT_EQ(after.at(origin).version, block.version);
  }
}

// With threads the cancellation is asked between groups of submaps: the map keeps what it had.
TEST_F(MergedMapParallelTest, ACancelledParallelSyncKeepsTheMapItHad) {
  auto merged = MergedMap::create(config_).value();
  const std::vector<SubmapEntry> first(entries_.begin(), entries_.begin() + 6);
  ASSERT_TRUE(merged->sync(first, MergeConfig{}, {}, spawnMergeThreads(2)).ok());
  const std::uint64_t version = merged->version();
  const auto stats = merged->sync(
      entries_, MergeConfig{}, [] { return true; }, spawnMergeThreads(2));
  ASSERT_FALSE(stats.ok());
  EXPECT_EQ(stats.error().message, "merge: cancelled");
  EXPECT_EQ(merged->version(), version);
  EXPECT_EQ(merged->submapCount(), first.size());
  expectSameMap(*merged, *serialFromScratch(first), true);
  ASSERT_TRUE(merged->sync(entries_, MergeConfig{}, {}, spawnMergeThreads(2)).ok());
  expectSameMap(*merged, *serialFromScratch(entries_), true);
}

TEST(MergeThreadsTest, ThreadCountFromConfig) {
  MergeConfig c;
  c.threads = 3;
  EXPECT_EQ(mergeThreadCount(c), 3);
  c.threads = 0;
  EXPECT_GE(mergeThreadCount(c), 1);
  EXPECT_LE(mergeThreadCount(c), 4);
  c.threads = -1;
  EXPECT_FALSE(c.validate().ok());
  // Every task runs exactly once.
  std::array<std::atomic<int>, 4> ran{};
  spawnMergeThreads(4).run([&](int task) { ran[static_cast<std::size_t>(task)]++; });
  for (const auto& r : ran) EXPECT_EQ(r.load(), 1);
}

}  // namespace
}  // namespace vog::map
