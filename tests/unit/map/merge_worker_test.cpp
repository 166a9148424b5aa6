// The merge thread publishes exactly what a synchronous merge of the newest submitted set gives,
// coalesces a burst of submissions, keeps the last good snapshot after a failed merge, and stops
// promptly with work queued.
#include "vog/map/merge_worker.hpp"

#include "map_fixtures.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace vog::map {
namespace {

std::vector<SubmapEntry> entriesOf(const std::vector<test_fixtures::BuiltSubmap>& built, std::size_t n,
                                   const geometry::Pose3& T_shift = geometry::Pose3::Identity()) {
  std::vector<SubmapEntry> out;
  for (std::size_t i = 0; i < n; ++i) {
    SubmapEntry e;
    e.id = static_cast<SubmapId>(i);
    e.grid = built[i].grid;
    e.T_world_submap = T_shift * built[i].T_world_submap;
    out.push_back(e);
  }
  return out;
}

std::unique_ptr<MergedMap> mergedFromScratch(const GridConfig& config, const std::vector<SubmapEntry>& entries) {
  auto m = MergedMap::create(config).value();
  for (const SubmapEntry& e : entries) EXPECT_TRUE(m->add(e).ok());
  return m;
}

TEST(MergeWorker, PublishesTheMergeOfEachSubmittedSet) {
  const GridConfig config;
  const auto built = test_fixtures::buildSubmaps(config, 4, 15, 7, 4.0);
  auto worker = MergeWorker::create(config, MergeConfig{}).value();
  EXPECT_EQ(worker->snapshot(), nullptr);
  for (std::size_t n = 1; n <= built.size(); ++n) {
    const std::uint64_t seq = worker->submit(entriesOf(built, n));
    ASSERT_TRUE(worker->waitIdle().ok());
    EXPECT_EQ(worker->mergedSequence(), seq);
    const auto snap = worker->snapshot();
    ASSERT_NE(snap, nullptr);
    EXPECT_EQ(snap->submapCount(), n);
    EXPECT_TRUE(snap->sameVoxels(*mergedFromScratch(config, entriesOf(built, n))));
  }
  // A deformation (every pose moved) is re-merged: same voxels as merging at the new poses.
  const geometry::Pose3 T_shift = geometry::poseFromXyzRpy(0.3, -0.2, 0.05, 0.0, 0.0, 0.1);
  worker->submit(entriesOf(built, built.size(), T_shift));
  ASSERT_TRUE(worker->waitIdle().ok());
  EXPECT_TRUE(worker->snapshot()->sameVoxels(*mergedFromScratch(config, entriesOf(built, built.size(), T_shift))));
  const auto records = worker->takeRecords();
  ASSERT_EQ(records.size(), built.size() + 1);
  EXPECT_EQ(records.back().stats.remerged, static_cast<int>(built.size()));
  EXPECT_TRUE(worker->takeRecords().empty());
}

// A set whose moves exceed MergeConfig::max_moves_per_sync is synced until none is deferred: each sync
// publishes, waitIdle() waits for the last.
TEST(MergeWorker, DeferredMovesAreMergedBeforeTheWorkerIsIdle) {
  const GridConfig config;
  const auto built = test_fixtures::buildSubmaps(config, 5, 10, 3, 4.0);
  MergeConfig limited;
  limited.max_moves_per_sync = 2;
  auto worker = MergeWorker::create(config, limited).value();
  worker->submit(entriesOf(built, built.size()));
  ASSERT_TRUE(worker->waitIdle().ok());
  ASSERT_EQ(worker->takeRecords().size(), 1u);
  const geometry::Pose3 T_shift = geometry::poseFromXyzRpy(0.3, -0.2, 0.0, 0.0, 0.0, 0.02);
  const std::uint64_t seq = worker->submit(entriesOf(built, built.size(), T_shift));
  ASSERT_TRUE(worker->waitIdle().ok());
  EXPECT_EQ(worker->mergedSequence(), seq);
  EXPECT_TRUE(worker->snapshot()->sameVoxels(*mergedFromScratch(config, entriesOf(built, built.size(), T_shift))));
  const auto records = worker->takeRecords();
  ASSERT_EQ(records.size(), 3u);
  for (std::size_t k = 0; k < records.size(); ++k) {
    EXPECT_EQ(records[k].sequence, seq);
    EXPECT_EQ(records[k].stats.deferred, std::max(0, 3 - 2 * static_cast<int>(k)));
  }
}

TEST(MergeWorker, ABurstOfSubmissionsEndsAtTheNewestSet) {
  const GridConfig config;
  const auto built = test_fixtures::buildSubmaps(config, 5, 10, 3, 4.0);
  auto worker = MergeWorker::create(config, MergeConfig{}).value();
  std::uint64_t last = 0;
  for (int round = 0; round < 20; ++round)
    last = worker->submit(entriesOf(built, 1 + static_cast<std::size_t>(round) % 5));
  ASSERT_TRUE(worker->waitIdle().ok());
  EXPECT_EQ(worker->mergedSequence(), last);
  // Round 19 submitted 5 submaps.
  EXPECT_TRUE(worker->snapshot()->sameVoxels(*mergedFromScratch(config, entriesOf(built, 5))));
  EXPECT_LE(worker->takeRecords().size(), 20u);
}

TEST(MergeWorker, AFailedMergeIsReportedAndTheLastSnapshotStays) {
  const GridConfig config;
  const auto built = test_fixtures::buildSubmaps(config, 2, 10, 5, 4.0);
  auto worker = MergeWorker::create(config, MergeConfig{}).value();
  worker->submit(entriesOf(built, 1));
  ASSERT_TRUE(worker->waitIdle().ok());
  const auto good = worker->snapshot();

  GridConfig coarse = config;
  coarse.resolution_m = 2 * config.resolution_m;
  const auto other = test_fixtures::buildSubmaps(coarse, 1, 5, 5, 4.0);
  auto bad = entriesOf(built, 2);
  bad[1].grid = other[0].grid;  // a grid of another resolution cannot be merged
  worker->submit(bad);
  const Status st = worker->waitIdle();
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("merge of submap set 2"), std::string::npos) << st.error().message;
  EXPECT_TRUE(worker->error().has_value());
  EXPECT_EQ(worker->snapshot(), good);
  // Later submissions are not merged after a failure (the caller decides what to do).
  worker->submit(entriesOf(built, 1));
  EXPECT_FALSE(worker->waitIdle().ok());
  EXPECT_EQ(worker->snapshot(), good);
}

TEST(MergeWorker, StopsWithWorkQueuedAndWaitIdleReturns) {
  const GridConfig config;
  const auto built = test_fixtures::buildSubmaps(config, 3, 10, 9, 4.0);
  auto worker = MergeWorker::create(config, MergeConfig{}).value();
  for (int k = 0; k < 5; ++k) worker->submit(entriesOf(built, 3));
  worker->stop();
  EXPECT_TRUE(worker->waitIdle().ok());  // returns at once after stop
  worker->stop();                        // idempotent
  const std::uint64_t beat = worker->heartbeat();
  EXPECT_GT(beat, 0u);
}

}  // namespace
}  // namespace vog::map
