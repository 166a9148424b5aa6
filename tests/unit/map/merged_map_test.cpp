#include "vog/map/merged_map.hpp"

#include "map_fixtures.hpp"
#include "small_tmpfs.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <limits>
#include <map>
#include <tuple>

namespace vog::map {
namespace {

using geometry::poseFromXyzRpy;

class MergedMapTest : public ::testing::Test {
 protected:
  void SetUp() override {
    vog_ = VogMap::create(config_).value();
    std::mt19937_64 rng(21);
    int id = 0;
    for (const auto& s : test_fixtures::buildSubmaps(config_, 6, 20, 9, 4.0)) {
      // Random general rotations and translations (not voxel-aligned) to exercise aliasing.
      ASSERT_TRUE(
          vog_->addSubmap(static_cast<SubmapId>(id++), s.grid, test_fixtures::perturb(s.T_world_submap, 0.3, 0.15, rng))
              .ok());
    }
  }

  std::unique_ptr<MergedMap> mergeFromScratch() const {
    auto merged = MergedMap::create(config_).value();
    for (const auto& e : vog_->entries()) EXPECT_TRUE(merged->add(e).ok());
    return merged;
  }

  // Every global voxel centre inside the world boxes of all submaps: merged == sequential.
  void expectMergedEqualsSequential(const MergedMap& merged) const {
    KeyBox box;
    for (const auto& e : vog_->entries()) {
      const Eigen::AlignedBox3d local = e.grid->knownBox();
      for (int c = 0; c < 8; ++c) {
        const Eigen::Vector3d w = e.T_world_submap * local.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c));
        const VoxelKey k = pointToKey(w, 1.0 / config_.resolution_m);
        box.extend(k, k);
      }
    }
    ASSERT_FALSE(box.empty());
    std::size_t checked = 0;
    std::size_t known = 0;
    VoxelKey k;
    for (k.z() = box.min.z(); k.z() <= box.max.z(); ++k.z())
      for (k.y() = box.min.y(); k.y() <= box.max.y(); ++k.y())
        for (k.x() = box.min.x(); k.x() <= box.max.x(); ++k.x()) {
          const VoxelValue seq = vog_->query(keyToCentre(k, config_.resolution_m));
          const VoxelValue mrg = merged.at(k);
          ASSERT_EQ(seq.status, mrg.status) << k.transpose();
          ASSERT_NEAR(seq.log_odds, mrg.log_odds, 1e-5) << k.transpose();
          ++checked;
          known += seq.status != Occupancy::kUnknown;
        }
    EXPECT_EQ(known, merged.knownVoxelCount());  // nothing known outside the boxes
    EXPECT_GT(known, 10000u);
    EXPECT_GT(checked, known);
  }

  GridConfig config_;
  std::unique_ptr<VogMap> vog_;
};

TEST_F(MergedMapTest, MergedEqualsSequentialAtEveryVoxelCentre) {
  auto merged = mergeFromScratch();
  expectMergedEqualsSequential(*merged);
}

TEST_F(MergedMapTest, IncrementalAndPartialRemergeEqualFromScratch) {
  auto incremental = MergedMap::create(config_).value();
  const MergeConfig exact{0.0, 0.0};
  // Grow one submap at a time, as the merge thread does.
  std::vector<SubmapEntry> grown;
  for (const auto& e : vog_->entries()) {
    grown.push_back(e);
    const auto stats = incremental->sync(grown, exact);
    ASSERT_TRUE(stats.ok());
    EXPECT_EQ(stats->added, 1);
    EXPECT_EQ(stats->remerged, 0);
  }
  // Deform: move two submaps (a loop closure), keep the rest.
  auto poses = vog_->poses();
  poses[1] = poseFromXyzRpy(0.2, -0.1, 0.05, 0.01, 0.0, 0.07) * poses[1];
  poses[4] = poseFromXyzRpy(-0.15, 0.3, 0.0, 0.0, 0.02, -0.05) * poses[4];
  ASSERT_TRUE(vog_->deform(poses).ok());
  const auto stats = incremental->sync(vog_->entries(), exact);
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->remerged, 2);
  EXPECT_EQ(stats->added, 0);

  auto scratch = mergeFromScratch();
  EXPECT_TRUE(incremental->sameVoxels(*scratch));
  EXPECT_EQ(incremental->knownVoxelCount(), scratch->knownVoxelCount());
  expectMergedEqualsSequential(*incremental);
}

TEST_F(MergedMapTest, RemovingEverySubmapLeavesAnEmptyMap) {
  auto merged = mergeFromScratch();
  for (const auto& e : vog_->entries()) ASSERT_TRUE(merged->remove(e.id).ok());
  EXPECT_EQ(merged->blockCount(), 0u);
  EXPECT_EQ(merged->knownVoxelCount(), 0u);
  EXPECT_FALSE(merged->remove(0).ok());
}

TEST_F(MergedMapTest, SmallMovesWithinToleranceAreNotRemerged) {
  auto merged = mergeFromScratch();
  auto poses = vog_->poses();
  poses[2] = poseFromXyzRpy(0.001, 0, 0, 0, 0, 0) * poses[2];
  poses[3] = poseFromXyzRpy(0.5, 0, 0, 0, 0, 0) * poses[3];
  ASSERT_TRUE(vog_->deform(poses).ok());
  const auto stats = merged->sync(vog_->entries(), MergeConfig{});
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->remerged, 1);
}

TEST_F(MergedMapTest, SnapshotsNeverChange) {
  auto merged = MergedMap::create(config_).value();
  const auto entries = vog_->entries();
  ASSERT_TRUE(merged->add(entries[0]).ok());
  const auto snap = merged->snapshot();
  auto reference = MergedMap::create(config_).value();
  ASSERT_TRUE(reference->add(entries[0]).ok());
  const std::uint64_t v = snap->version();
  for (std::size_t i = 1; i < entries.size(); ++i) ASSERT_TRUE(merged->add(entries[i]).ok());
  ASSERT_TRUE(merged->remove(entries[0].id).ok());
  EXPECT_TRUE(snap->sameVoxels(*reference));  // copy-on-write kept the snapshot intact
  EXPECT_FALSE(merged->sameVoxels(*reference));
  EXPECT_EQ(snap->version(), v);
  EXPECT_EQ(snap->submapCount(), 1u);
  // Changed blocks since the snapshot are exactly the blocks that differ.
  const auto changed = merged->blocksChangedSince(v);
  EXPECT_GT(changed.size(), 0u);
  for (const auto& [origin, block] : changed) EXPECT_GT(block->version, v);
}

// A remote copy of the merged map: blocks by origin.
using Mirror = std::map<std::tuple<int, int, int>, MergedMap::Block>;

// Brings a copy taken at version `since` up to date from the removed and changed blocks alone.
void catchUp(Mirror& mirror, const MergedMap& merged, std::uint64_t since) {
  for (const auto& origin : merged.blocksRemovedSince(since)) mirror.erase({origin.x(), origin.y(), origin.z()});
  for (const auto& [origin, block] : merged.blocksChangedSince(since))
    mirror[{origin.x(), origin.y(), origin.z()}] = *block;
}

void expectMirrors(const Mirror& mirror, const MergedMap& merged, const GridConfig& config) {
  std::size_t known = 0;
  for (const auto& [origin, block] : mirror) {
    known += block.n_known;
    for (int i = 0; i < MergedMap::kBlockVoxels; ++i) {
      const VoxelKey k = VoxelKey(std::get<0>(origin), std::get<1>(origin), std::get<2>(origin)) +
                         VoxelKey(i & 7, (i >> 3) & 7, i >> 6);
      const VoxelValue v = merged.at(k);
      ASSERT_EQ(v.status == Occupancy::kUnknown, block.count(static_cast<std::size_t>(i)) == 0);
      if (v.status != Occupancy::kUnknown) {
        ASSERT_EQ(v.log_odds, config.bounds().clamp(block.sum(static_cast<std::size_t>(i))));
      }
    }
  }
  EXPECT_EQ(known, merged.knownVoxelCount());
  EXPECT_EQ(mirror.size(), merged.blockCount());
}

// A remote copy taken at one version catches up from the changed and removed blocks alone.
TEST_F(MergedMapTest, ChangedAndRemovedBlocksBringACopyUpToDate) {
  auto merged = MergedMap::create(config_).value();
  const auto entries = vog_->entries();
  for (std::size_t i = 0; i < 3; ++i) ASSERT_TRUE(merged->add(entries[i]).ok());
  Mirror mirror;
  catchUp(mirror, *merged, 0);
  const std::uint64_t seen = merged->version();

  ASSERT_TRUE(merged->remove(entries[0].id).ok());
  for (std::size_t i = 3; i < entries.size(); ++i) ASSERT_TRUE(merged->add(entries[i]).ok());
  EXPECT_GT(merged->blocksRemovedSince(seen).size(), 0u);
  catchUp(mirror, *merged, seen);
  expectMirrors(mirror, *merged, config_);
}

// A loop closure late in a survey moves many submaps by millimetres. Each is moved in one pass that
// changes only the voxels entering or leaving its leaves: the map stays equal to one merged from
// scratch and to the sequential query, and a remote copy still catches up from the changed blocks.
TEST_F(MergedMapTest, MillimetreMovesEqualFromScratchAndBringACopyUpToDate) {
  const MergeConfig exact{0.0, 0.0};
  auto merged = mergeFromScratch();
  Mirror mirror;
  catchUp(mirror, *merged, 0);
  std::uint64_t seen = merged->version();
  std::mt19937_64 rng(5);
  for (std::size_t round = 0; round < 4; ++round) {
    SCOPED_TRACE(round);
    auto poses = vog_->poses();
    for (std::size_t k = round % 2; k < poses.size(); k += 2)
      poses[k] = test_fixtures::perturb(poses[k], 0.006, 0.0008, rng);
    ASSERT_TRUE(vog_->deform(poses).ok());
    const auto stats = merged->sync(vog_->entries(), exact);
    ASSERT_TRUE(stats.ok());
    EXPECT_EQ(stats->remerged, 3);
    EXPECT_EQ(merged->version(), seen + 3);  // one version per moved submap: moved, not rebuilt
    catchUp(mirror, *merged, seen);
    seen = merged->version();
    expectMirrors(mirror, *merged, config_);
  }
  EXPECT_TRUE(merged->sameVoxels(*mergeFromScratch()));
  expectMergedEqualsSequential(*merged);
}

// With MergeConfig::max_moves_per_sync, a sync moves the submaps nearest to the newest one and leaves the
// others where they were merged; the syncs that follow move the rest, and the map ends equal to a merge
// from scratch.
TEST_F(MergedMapTest, MovesBeyondTheLimitAreDeferredNearestFirstAndCaughtUpExactly) {
  MergeConfig limited{0.0, 0.0};
  limited.max_moves_per_sync = 2;
  auto merged = mergeFromScratch();
  const std::vector<SubmapEntry> before = vog_->entries();
  std::mt19937_64 rng(6);
  auto poses = vog_->poses();
  for (auto& pose : poses) pose = test_fixtures::perturb(pose, 0.006, 0.0008, rng);
  ASSERT_TRUE(vog_->deform(poses).ok());
  const std::vector<SubmapEntry> after = vog_->entries();
  // The expected order: by distance of the new base to the newest submap's.
  std::vector<std::pair<double, std::size_t>> order;
  for (std::size_t k = 0; k < after.size(); ++k)
    order.emplace_back((after[k].T_world_submap.translation() - after.back().T_world_submap.translation()).norm(), k);
  std::sort(order.begin(), order.end());
  std::vector<SubmapEntry> expected = before;
  Mirror mirror;
  catchUp(mirror, *merged, 0);
  std::uint64_t seen = merged->version();
  for (std::size_t step = 0; step < 3; ++step) {
    SCOPED_TRACE(step);
    const auto stats = merged->sync(after, limited);
    ASSERT_TRUE(stats.ok());
    EXPECT_EQ(stats->remerged, 2);
    EXPECT_EQ(stats->deferred, 4 - 2 * static_cast<int>(step));
    for (std::size_t j = 2 * step; j < 2 * step + 2; ++j) expected[order[j].second] = after[order[j].second];
    auto reference = MergedMap::create(config_).value();
    for (const auto& e : expected) ASSERT_TRUE(reference->add(e).ok());
    EXPECT_TRUE(merged->sameVoxels(*reference));
    catchUp(mirror, *merged, seen);
    seen = merged->version();
    expectMirrors(mirror, *merged, config_);
  }
  const auto done = merged->sync(after, limited);
  ASSERT_TRUE(done.ok());
  EXPECT_EQ(done->remerged, 0);
  EXPECT_EQ(done->deferred, 0);
  EXPECT_TRUE(merged->sameVoxels(*mergeFromScratch()));
  expectMergedEqualsSequential(*merged);
}

// A submap whose grid was replaced under the same id is merged out with its old grid and in with its
// new one.
TEST_F(MergedMapTest, ASubmapWithANewGridIsMergedOutAndIn) {
  auto merged = mergeFromScratch();
  std::vector<SubmapEntry> entries = vog_->entries();
  entries[1].grid = entries[2].grid;
  const auto stats = merged->sync(entries, MergeConfig{});
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->remerged, 1);
  auto reference = MergedMap::create(config_).value();
  for (const auto& e : entries) ASSERT_TRUE(reference->add(e).ok());
  EXPECT_TRUE(merged->sameVoxels(*reference));
}

TEST_F(MergedMapTest, TraverseVisitsContiguousVoxelsAndAgreesWithPointQueries) {
  auto merged = mergeFromScratch();
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-6.0, 6.0);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d a(u(rng), u(rng), -2.0 + 0.3 * u(rng));
    const Eigen::Vector3d b(u(rng), u(rng), -2.0 + 0.3 * u(rng));
    std::vector<VoxelKey> keys;
    merged->traverse(a, b, [&](const VoxelKey& k, const VoxelValue& v) {
      const VoxelValue expect = merged->at(k);
      EXPECT_EQ(v.status, expect.status);
      keys.push_back(k);
      return true;
    });
    ASSERT_FALSE(keys.empty());
    EXPECT_EQ(keys.front(), pointToKey(a, 1.0 / config_.resolution_m));
    EXPECT_EQ(keys.back(), pointToKey(b, 1.0 / config_.resolution_m));
    for (std::size_t i = 1; i < keys.size(); ++i) ASSERT_EQ((keys[i] - keys[i - 1]).cwiseAbs().sum(), 1);
    // Every voxel centre on the way lies within half a voxel diagonal of the segment.
    for (const auto& k : keys) {
      const Eigen::Vector3d c = keyToCentre(k, config_.resolution_m);
      const Eigen::Vector3d d = (b - a).normalized();
      const double t = std::clamp((c - a).dot(d), 0.0, (b - a).norm());
      EXPECT_LE((a + t * d - c).norm(), 0.5 * std::sqrt(3.0) * config_.resolution_m + 1e-9);
    }
  }
}

TEST_F(MergedMapTest, CastRayMatchesTraverse) {
  auto merged = mergeFromScratch();
  int hits = 0;
  for (const auto& e : vog_->entries()) {
    const auto& pts = e.grid->cloud().points;
    for (std::size_t i = 0; i < pts.size(); i += std::max<std::size_t>(1, pts.size() / 10)) {
      // From the submap's origin through a point of its surface, a little past it.
      const Eigen::Vector3d origin = e.T_world_submap.translation();
      const Eigen::Vector3d p = e.T_world_submap * pts[i];
      const Eigen::Vector3d end = p + 0.5 * (p - origin).normalized();
      const CastResult r = merged->castRay(origin, end);
      int n = 0;
      bool hit = false;
      merged->traverse(origin, end, [&](const VoxelKey&, const VoxelValue& v) {
        if (v.status == Occupancy::kOccupied) {
          hit = true;
          return false;
        }
        ++n;
        return true;
      });
      EXPECT_EQ(r.hit, hit);
      EXPECT_EQ(r.n_free + r.n_unknown, n);
      hits += hit;
    }
  }
  EXPECT_GT(hits, 30);
}

TEST_F(MergedMapTest, ExportsOctoMapFilesWithTheClampedValues) {
  auto merged = mergeFromScratch();
  test::TempDir dir;
  ASSERT_TRUE(merged->writeOt(dir.path() / "map.ot").ok());
  ASSERT_TRUE(merged->writeBt(dir.path() / "map.bt").ok());
  std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read((dir.path() / "map.ot").string()));
  auto* ot = dynamic_cast<octomap::OcTree*>(any.get());
  ASSERT_NE(ot, nullptr);
  octomap::OcTree bt(0.1);
  ASSERT_TRUE(bt.readBinary((dir.path() / "map.bt").string()));
  EXPECT_DOUBLE_EQ(bt.getResolution(), config_.resolution_m);
  std::size_t n = 0;
  merged->forEachKnown([&](const VoxelKey& k, const VoxelValue& v) {
    const octomap::point3d c(static_cast<float>((k.x() + 0.5) * config_.resolution_m),
                             static_cast<float>((k.y() + 0.5) * config_.resolution_m),
                             static_cast<float>((k.z() + 0.5) * config_.resolution_m));
    const auto* node = ot->search(c);
    ASSERT_NE(node, nullptr);
    EXPECT_NEAR(node->getLogOdds(), v.log_odds, 1e-6);
    const auto* ml = bt.search(c);
    ASSERT_NE(ml, nullptr);
    EXPECT_EQ(bt.isNodeOccupied(ml), v.status == Occupancy::kOccupied);
    ++n;
  });
  EXPECT_EQ(n, merged->knownVoxelCount());
  EXPECT_FALSE(merged->writeOt(dir.path() / "no" / "such" / "dir.ot").ok());
}

TEST_F(MergedMapTest, AnExportOnAFullDiskIsAnErrorAndLeavesNoFile) {
  auto merged = mergeFromScratch();
  test::SmallTmpfs disk(256 * 1024);
  if (!disk.mounted()) GTEST_SKIP() << "needs a tmpfs to fill: " << disk.error();
  ASSERT_TRUE(disk.fill());
  for (const char* name : {"map.ot", "map.bt"}) {
    const auto file = disk.path() / name;
    const Status written = std::string(name) == "map.ot" ? merged->writeOt(file) : merged->writeBt(file);
    ASSERT_FALSE(written.ok()) << name << " reported written on a full disk";
    EXPECT_NE(written.error().message.find("No space left on device"), std::string::npos) << written.error().message;
    EXPECT_FALSE(std::filesystem::exists(file));
  }
}

TEST(MergedMapInput, RejectsBadSubmapsAndChangesNothing) {
  GridConfig config;
  auto merged = MergedMap::create(config).value();
  auto grid = LocalGrid::create(config).value();
  const std::vector<BeamEnd> beams = {{Eigen::Vector3d(1, 0, 0), true}};
  ASSERT_TRUE(grid->insertRays(Eigen::Vector3d::Zero(), beams).ok());
  grid->finalize();
  std::shared_ptr<const LocalGrid> shared(std::move(grid));
  SubmapEntry good{1, shared, geometry::Pose3::Identity(), geometry::Pose3::Identity()};
  ASSERT_TRUE(merged->add(good).ok());
  const auto blocks = merged->blockCount();
  const auto version = merged->version();

  EXPECT_FALSE(merged->add(good).ok());  // duplicate
  SubmapEntry nan_pose = good;
  nan_pose.id = 2;
  nan_pose.T_world_submap.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(merged->add(nan_pose).ok());
  GridConfig coarse;
  coarse.resolution_m = 0.2;
  coarse.cloud_voxel_m = 0.4;
  auto other = LocalGrid::create(coarse).value();
  other->finalize();
  SubmapEntry mismatched{3, std::shared_ptr<const LocalGrid>(std::move(other)), geometry::Pose3::Identity(),
                         geometry::Pose3::Identity()};
  const Status s = merged->add(mismatched);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("resolution"), std::string::npos);
  // sync validates the whole list before changing anything.
  EXPECT_FALSE(merged->sync({good, nan_pose}, MergeConfig{}).ok());
  EXPECT_FALSE(merged->sync({good, good}, MergeConfig{}).ok());
  EXPECT_FALSE(merged->sync({good}, MergeConfig{-1.0, 0.0}).ok());
  EXPECT_EQ(merged->blockCount(), blocks);
  EXPECT_EQ(merged->version(), version);
  EXPECT_EQ(merged->submapCount(), 1u);
  EXPECT_EQ(merged->query({std::numeric_limits<double>::infinity(), 0, 0}).status, Occupancy::kUnknown);
}

// A writer that shuts down stops a long re-merge between submaps instead of finishing it.
TEST_F(MergedMapTest, ASyncIsCancelledBetweenSubmaps) {
  auto merged = MergedMap::create(config_).value();
  int asked = 0;
  const auto entries = vog_->entries();
  ASSERT_GT(entries.size(), 2u);
  const auto stats = merged->sync(entries, MergeConfig{}, [&] { return ++asked > 2; });
  ASSERT_FALSE(stats.ok());
  EXPECT_EQ(stats.error().message, "merge: cancelled");
  EXPECT_EQ(merged->submapCount(), 2u);  // two merged, then asked a third time: stopped
  EXPECT_TRUE(merged->sync(entries, MergeConfig{}, [] { return false; }).ok());
  EXPECT_EQ(merged->submapCount(), entries.size());
}

}  // namespace
}  // namespace vog::map
