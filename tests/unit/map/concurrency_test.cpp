// Readers never see a half-applied write: VogMap queries run under a shared lock while deform()
// replaces every pose at once, and MergedMap snapshots stay fixed while the writer keeps merging.
#include "vog/map/merged_map.hpp"

#include "map_fixtures.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>

namespace vog::map {
namespace {

TEST(Concurrency, QueriesSeeEitherThePosesBeforeOrAfterADeformation) {
  const GridConfig config;
  auto vog = VogMap::create(config).value();
  const auto built = test_fixtures::buildSubmaps(config, 4, 20, 3, 4.0);
  std::vector<geometry::Pose3> poses_a;
  std::vector<geometry::Pose3> poses_b;
  for (std::size_t i = 0; i < built.size(); ++i) {
    ASSERT_TRUE(vog->addSubmap(static_cast<SubmapId>(i), built[i].grid, built[i].T_world_submap).ok());
    poses_a.push_back(built[i].T_world_submap);
    poses_b.push_back(geometry::poseFromXyzRpy(0.4, -0.3, 0.1, 0, 0, 0.2) * built[i].T_world_submap);
  }
  const Eigen::Vector3d p1(5.4, 1.0, -2.0);  // across the region the submaps cover
  const Eigen::Vector3d p2(1.0, 1.5, -2.2);
  auto signature = [&] {
    double s = 0.0;
    for (const auto& sample : vog->lineQuery(p1, p2)) s = s * 1.000001 + sample.value.log_odds;
    return s;
  };
  const double sig_a = signature();
  ASSERT_TRUE(vog->deform(poses_b).ok());
  const double sig_b = signature();
  ASSERT_NE(sig_a, sig_b);

  std::atomic<bool> stop{false};
  std::atomic<int> torn{0};
  std::atomic<int> reads{0};
  std::vector<std::thread> readers;
  for (int r = 0; r < 2; ++r) {
    readers.emplace_back([&] {
      while (!stop.load()) {
        const double s = signature();
        if (s != sig_a && s != sig_b) ++torn;
        ++reads;
      }
    });
  }
  for (int k = 0; k < 200; ++k) ASSERT_TRUE(vog->deform(k % 2 == 0 ? poses_a : poses_b).ok());
  while (reads.load() < 50) std::this_thread::yield();
  stop = true;
  for (auto& t : readers) t.join();
  EXPECT_EQ(torn.load(), 0);
}

TEST(Concurrency, SnapshotReadersAreUnaffectedByTheWriter) {
  const GridConfig config;
  const auto built = test_fixtures::buildSubmaps(config, 5, 20, 4, 4.0);
  std::vector<SubmapEntry> entries;
  for (std::size_t i = 0; i < built.size(); ++i) {
    entries.push_back(
        {static_cast<SubmapId>(i), built[i].grid, built[i].T_world_submap, built[i].T_world_submap.inverse()});
  }
  auto merged = MergedMap::create(config).value();
  ASSERT_TRUE(merged->add(entries[0]).ok());
  ASSERT_TRUE(merged->add(entries[1]).ok());
  const std::shared_ptr<const MergedMap> snap = merged->snapshot();
  auto checksum = [](const MergedMap& m) {
    double s = 0.0;
    std::size_t n = 0;
    m.forEachKnown([&](const VoxelKey& k, const VoxelValue& v) {
      s += v.log_odds * static_cast<double>(k.x() + 3 * k.y() + 7 * k.z());
      ++n;
    });
    return std::make_pair(s, n);
  };
  const auto expected = checksum(*snap);

  std::atomic<bool> stop{false};
  std::atomic<int> changed{0};
  std::thread reader([&] {
    while (!stop.load()) {
      if (checksum(*snap) != expected) ++changed;
    }
  });
  for (int round = 0; round < 3; ++round) {
    for (std::size_t i = 2; i < entries.size(); ++i) ASSERT_TRUE(merged->add(entries[i]).ok());
    for (std::size_t i = 2; i < entries.size(); ++i) ASSERT_TRUE(merged->remove(entries[i].id).ok());
    ASSERT_TRUE(merged->remove(entries[0].id).ok());
    ASSERT_TRUE(merged->add(entries[0]).ok());
  }
  stop = true;
  reader.join();
  EXPECT_EQ(changed.load(), 0);
  EXPECT_TRUE(merged->sameVoxels(*snap));  // same content again, yet the snapshot was never touched
}

// Readers take a snapshot from the writer's published one, read it and drop it while the writer keeps
// merging: the writer must never write a block a reader is still reading, whatever order the reader's
// release and the writer's next write take (under ThreadSanitizer a reference-count test races here).
TEST(Concurrency, ReadersDroppingSnapshotsWhileTheWriterWritesSeeFixedMaps) {
  const GridConfig config;
  const auto built = test_fixtures::buildSubmaps(config, 4, 20, 3, 4.0);
  std::vector<SubmapEntry> entries;
  for (std::size_t i = 0; i < built.size(); ++i) {
    entries.push_back(
        {static_cast<SubmapId>(i), built[i].grid, built[i].T_world_submap, built[i].T_world_submap.inverse()});
  }
  auto merged = MergedMap::create(config).value();
  ASSERT_TRUE(merged->add(entries[0]).ok());
  std::mutex published_mutex;
  std::shared_ptr<const MergedMap> published = merged->snapshot();  // guarded by published_mutex
  std::atomic<bool> stop{false};
  std::atomic<int> torn{0}, reads{0};
  std::vector<std::thread> readers;
  for (int r = 0; r < 2; ++r) {
    readers.emplace_back([&] {
      while (!stop.load()) {
        std::shared_ptr<const MergedMap> snap;
        {
          const std::lock_guard lock(published_mutex);
          snap = published;
        }
        const std::size_t before = snap->knownVoxelCount();
        double sum = 0.0;
        snap->forEachKnown([&](const VoxelKey&, const VoxelValue& v) { sum += v.log_odds; });
        if (snap->knownVoxelCount() != before || !std::isfinite(sum)) ++torn;
        ++reads;
        snap.reset();  // dropped while the writer may be about to write its blocks
      }
    });
  }
  for (int round = 0; round < 40; ++round) {
    const SubmapEntry& e = entries[1 + static_cast<std::size_t>(round) % (entries.size() - 1)];
    ASSERT_TRUE(merged->add(e).ok());
    auto next = merged->snapshot();
    {
      const std::lock_guard lock(published_mutex);
      published = std::move(next);
    }
    ASSERT_TRUE(merged->remove(e.id).ok());
  }
  while (reads.load() < 20) std::this_thread::yield();
  stop = true;
  for (auto& t : readers) t.join();
  EXPECT_EQ(torn.load(), 0);
}

}  // namespace
}  // namespace vog::map
