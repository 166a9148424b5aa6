// MissionStore on small hand-made submaps: what is written comes back on open() (submap records, grids
// voxel for voxel with the same cloud, closures, latest estimates, last state and waypoint); an
// unfinished submap group at the end of the journal is dropped and cut; bad input is a clear error
// that changes nothing: a mission path that is a file or not writable, a submap file missing or
// corrupt, a journal naming an unknown record type, hooks called out of order.
#include "journal_fixture.hpp"
#include "small_tmpfs.hpp"
#include "test_support.hpp"
#include "vog/map/local_grid.hpp"
#include "vog/mission/mission_store.hpp"
#include "vog/mission/submap_store.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace vog::mission {
namespace {

map::GridConfig gridConfig() {
  map::GridConfig c;
  c.resolution_m = 0.2;
  c.cloud_voxel_m = 0.4;
  return c;
}

std::shared_ptr<const map::LocalGrid> smallGrid(int seed) {
  // A plane y = const beside the base (y > 0 for every seed, so the base is on one side of it), seen
  // from the other side (+y): the cloud's normals point away from the base, which they would not
  // without the origins.
  const double y = 0.3 * (seed + 1);
  auto tree = std::make_unique<octomap::OcTree>(gridConfig().resolution_m);
  for (int i = 0; i < 30; ++i) {
    tree->updateNode(
        octomap::point3d(0.2f * static_cast<float>(i % 6), static_cast<float>(y), 0.1f * static_cast<float>(i / 6)),
        i % 3 != 0);
  }
  auto grid = map::LocalGrid::fromTree(gridConfig(), std::move(tree),
                                       {Eigen::Vector3d(0.5, y + 3.0, 0.2), Eigen::Vector3d(-0.5, y + 2.0, 0.0)});
  EXPECT_TRUE(grid.ok());
  return std::shared_ptr<const map::LocalGrid>(std::move(grid.value()));
}

slam::ClosedSubmap closedSubmap(std::int64_t index) {
  std::mt19937_64 rng(static_cast<std::uint64_t>(index));
  const SubmapClosedRecord r = testing::sampleSubmap(index, rng);
  slam::ClosedSubmap c;
  c.index = index;
  c.grid = smallGrid(static_cast<int>(index));
  c.T_world_base_odom = r.T_world_base_odom;
  c.base_z_roll_pitch = r.base_z_roll_pitch;
  c.first_stamp_ns = r.first_stamp_ns;
  c.last_stamp_ns = r.last_stamp_ns;
  c.n_scans = r.n_scans;
  c.reason = r.reason;
  c.has_previous = r.has_previous;
  c.odometry_from_previous = r.odometry_from_previous;
  c.odometry_covariance = r.odometry_covariance;
  return c;
}

slam::Vector6d estimate(std::int64_t id, int version) {
  slam::Vector6d x;
  x << static_cast<double>(id), 0.5 * static_cast<double>(version), -1.0, 0.01, -0.02, 0.1 * static_cast<double>(id);
  return x;
}

// Three submaps, a closure 0 -> 2 with a re-optimisation of every node, a waypoint and a state change.
void writeMission(MissionStore& store) {
  for (std::int64_t k = 0; k < 3; ++k) {
    ASSERT_TRUE(store.onSubmapClosed(closedSubmap(k)).ok());
    std::vector<slam::LoopClosure> closures;
    std::vector<std::pair<slam::NodeId, slam::Vector6d>> estimates = {{k, estimate(k, 0)}};
    if (k == 2) {
      std::mt19937_64 rng(5);
      const LoopClosureRecord r = testing::sampleClosure(0, 2, 3, rng);
      slam::LoopClosure lc;
      lc.from = r.from;
      lc.to = r.to;
      lc.T_from_to = r.T_from_to;
      lc.T_from_to_prior = r.T_from_to_prior;
      lc.factor = r.factor;
      closures.push_back(lc);
      estimates = {{0, estimate(0, 1)}, {1, estimate(1, 1)}, {2, estimate(2, 1)}};
    }
    ASSERT_TRUE(store.onClosures(closures).ok());
    ASSERT_TRUE(store.onOptimized(estimates).ok());
    ASSERT_TRUE(store.onWaypoint(WaypointRecord{k, 1.0 + static_cast<double>(k), 2.0, -3.0, 0.5}).ok());
  }
  ASSERT_TRUE(store.onState(MissionStateRecord{99, MissionState::kReturning}).ok());
}

void expectGridsEqual(const map::LocalGrid& a, const map::LocalGrid& b) {
  const auto la = a.leaves();
  const auto lb = b.leaves();
  ASSERT_EQ(la.size(), lb.size());
  ASSERT_FALSE(la.empty());
  for (std::size_t i = 0; i < la.size(); ++i) {
    EXPECT_TRUE(la[i].min == lb[i].min && la[i].max == lb[i].max) << "leaf " << i;
    EXPECT_EQ(la[i].log_odds, lb[i].log_odds) << "leaf " << i;
  }
}

// The cloud (what loop closures register) is computed as it was live: the sensor origins that orient
// its normals come back from the journal.
void expectCloudsEqual(const map::LocalGrid& a, const map::LocalGrid& b) {
  ASSERT_EQ(a.sensorOrigins().size(), b.sensorOrigins().size());
  for (std::size_t i = 0; i < a.sensorOrigins().size(); ++i) {
    EXPECT_TRUE(testing::bitEqual(a.sensorOrigins()[i], b.sensorOrigins()[i])) << "origin " << i;
  }
  ASSERT_EQ(a.cloud().size(), b.cloud().size());
  ASSERT_GE(a.cloud().size(), 3U);
  for (std::size_t i = 0; i < a.cloud().size(); ++i) {
    EXPECT_TRUE(testing::bitEqual(a.cloud().points[i], b.cloud().points[i])) << "point " << i;
    EXPECT_TRUE(testing::bitEqual(a.cloud().normals[i], b.cloud().normals[i])) << "normal " << i;
    EXPECT_GT(a.cloud().normals[i].y(), 0.9) << "normal " << i << " points away from the sensor";
  }
}

TEST(MissionStore, WhatIsWrittenComesBackOnOpen) {
  test::TempDir dir;
  const auto mission = dir.path() / "mission";
  {
    MissionResume fresh;
    auto store = MissionStore::open(mission, gridConfig(), &fresh);
    ASSERT_TRUE(store.ok()) << store.error().message;
    EXPECT_TRUE(fresh.pipeline.submaps.empty());
    EXPECT_FALSE(fresh.state.has_value());
    writeMission(*store.value());
  }
  MissionResume resume;
  auto store = MissionStore::open(mission, gridConfig(), &resume);
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_EQ(store.value()->nextSubmapIndex(), 3);
  EXPECT_FALSE(resume.journal_tail.torn);
  EXPECT_EQ(resume.uncommitted_records, 0U);
  ASSERT_EQ(resume.pipeline.submaps.size(), 3U);
  for (std::int64_t k = 0; k < 3; ++k) {
    const slam::ClosedSubmap want = closedSubmap(k);
    const slam::ClosedSubmap& got = resume.pipeline.submaps[static_cast<std::size_t>(k)];
    EXPECT_EQ(got.index, k);
    EXPECT_TRUE(testing::bitEqual(got.T_world_base_odom.matrix(), want.T_world_base_odom.matrix()));
    EXPECT_TRUE(testing::bitEqual(got.odometry_covariance, want.odometry_covariance));
    EXPECT_TRUE(testing::bitEqual(got.odometry_from_previous, want.odometry_from_previous));
    EXPECT_TRUE(testing::bitEqual(got.base_z_roll_pitch, want.base_z_roll_pitch));
    EXPECT_EQ(got.has_previous, want.has_previous);
    EXPECT_EQ(got.first_stamp_ns, want.first_stamp_ns);
    EXPECT_EQ(got.last_stamp_ns, want.last_stamp_ns);
    EXPECT_EQ(got.n_scans, want.n_scans);
    EXPECT_EQ(got.reason, want.reason);
    ASSERT_TRUE(got.grid && got.grid->finalized());
    expectGridsEqual(*got.grid, *want.grid);
    expectCloudsEqual(*got.grid, *want.grid);
    EXPECT_TRUE(testing::bitEqual(resume.pipeline.estimates[static_cast<std::size_t>(k)], estimate(k, 1)));
  }
  ASSERT_EQ(resume.pipeline.closures.size(), 1U);
  EXPECT_EQ(resume.pipeline.closures[0].from, 0);
  EXPECT_EQ(resume.pipeline.closures[0].to, 2);
  ASSERT_TRUE(resume.state.has_value());
  EXPECT_EQ(resume.state->state, MissionState::kReturning);
  ASSERT_TRUE(resume.waypoint.has_value());
  EXPECT_EQ(resume.waypoint->stamp_ns, 2);
  EXPECT_EQ(resume.waypoint->x_m, 3.0);
}

TEST(MissionStore, UnfinishedSubmapGroupAtTheEndIsDroppedAndCut) {
  test::TempDir dir;
  const auto mission = dir.path() / "mission";
  {
    auto store = MissionStore::open(mission, gridConfig());
    ASSERT_TRUE(store.ok());
    writeMission(*store.value());
  }
  const auto journal_path = mission / MissionStore::kJournalFile;
  const std::uint64_t committed_size = std::filesystem::file_size(journal_path);
  {
    // A crash between the group's records and its commit: submap 3 and a closure, no estimates.
    auto journal = Journal::open(journal_path);
    ASSERT_TRUE(journal.ok());
    std::mt19937_64 rng(1);
    ASSERT_TRUE(journal.value()->append(testing::sampleSubmap(3, rng)).ok());
    ASSERT_TRUE(journal.value()->append(testing::sampleClosure(1, 3, 2, rng)).ok());
    ASSERT_TRUE(journal.value()->sync().ok());
  }
  MissionResume resume;
  auto store = MissionStore::open(mission, gridConfig(), &resume);
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_EQ(resume.uncommitted_records, 2U);
  EXPECT_EQ(resume.pipeline.submaps.size(), 3U);
  EXPECT_EQ(std::filesystem::file_size(journal_path), committed_size);
  // Submap 3 can be written again and is then part of the mission.
  ASSERT_TRUE(store.value()->onSubmapClosed(closedSubmap(3)).ok());
  ASSERT_TRUE(store.value()->onOptimized({{3, estimate(3, 0)}}).ok());
  store.value().reset();
  MissionResume again;
  ASSERT_TRUE(MissionStore::open(mission, gridConfig(), &again).ok());
  EXPECT_EQ(again.pipeline.submaps.size(), 4U);
  EXPECT_EQ(again.uncommitted_records, 0U);
}

TEST(MissionStore, MissionPathThatIsAFileIsAnError) {
  test::TempDir dir;
  const auto file = dir.path() / "plain";
  testing::writeBytes(file, {1, 2, 3});
  auto a = MissionStore::open(file, gridConfig());
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().message.find("is not a directory"), std::string::npos) << a.error().message;
  auto b = MissionStore::open(file / "mission", gridConfig());
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("cannot create mission directory"), std::string::npos) << b.error().message;
  EXPECT_EQ(testing::readBytes(file), (std::vector<std::uint8_t>{1, 2, 3}));
}

// A parent directory without write permission. Root ignores permission bits, so the attempt runs in a
// child process that first drops to the unprivileged uid/gid 65534 ("nobody") when run as root.
TEST(MissionStore, MissionDirectoryWithoutWritePermissionIsAnError) {
  test::TempDir dir;
  const auto locked = dir.path() / "locked";
  std::filesystem::create_directory(locked);
  ASSERT_EQ(::chmod(dir.path().c_str(), 0755), 0);
  ASSERT_EQ(::chmod(locked.c_str(), 0555), 0);
  const auto existing = dir.path() / "existing";  // a mission whose directory became read-only
  ASSERT_TRUE(MissionStore::open(existing, gridConfig()).ok());
  ASSERT_EQ(::chmod(existing.c_str(), 0555), 0);
  ASSERT_EQ(::chmod((existing / MissionStore::kJournalFile).c_str(), 0444), 0);
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::close(fds[0]);
    if (::geteuid() == 0 && (::setgid(65534) != 0 || ::setuid(65534) != 0)) ::_exit(2);
    std::string messages;
    for (const auto& path : {locked / "mission", existing}) {
      auto store = MissionStore::open(path, gridConfig());
      messages += store.ok() ? std::string("opened\n") : store.error().message + "\n";
    }
    const ssize_t n = ::write(fds[1], messages.data(), messages.size());
    ::_exit(n == static_cast<ssize_t>(messages.size()) ? 0 : 3);
  }
  ::close(fds[1]);
  std::string messages;
  char buffer[512];
  for (ssize_t n; (n = ::read(fds[0], buffer, sizeof buffer)) > 0;)
    messages.append(buffer, static_cast<std::size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ::chmod(locked.c_str(), 0755);
  ::chmod(existing.c_str(), 0755);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child status " << status;
  EXPECT_NE(messages.find("cannot create mission directory " + (locked / "mission").string()), std::string::npos)
      << messages;
  EXPECT_NE(messages.find("cannot open " + (existing / MissionStore::kJournalFile).string() + " for appending"),
            std::string::npos)
      << messages;
  EXPECT_EQ(messages.find("opened"), std::string::npos) << messages;
}

TEST(MissionStore, MissingOrCorruptSubmapFileIsAnErrorNamingIt) {
  test::TempDir dir;
  const auto mission = dir.path() / "mission";
  {
    auto store = MissionStore::open(mission, gridConfig());
    ASSERT_TRUE(store.ok());
    writeMission(*store.value());
  }
  const auto ot = mission / "submaps" / SubmapStore::fileName(1);
  const auto good = testing::readBytes(ot);
  const auto journal_before = testing::readBytes(mission / MissionStore::kJournalFile);

  auto damaged = good;
  damaged[damaged.size() / 2] ^= 0x01;
  testing::writeBytes(ot, damaged);
  auto corrupt = MissionStore::open(mission, gridConfig());
  ASSERT_FALSE(corrupt.ok());
  EXPECT_NE(corrupt.error().message.find("000001.ot is corrupt"), std::string::npos) << corrupt.error().message;

  std::filesystem::remove(ot);
  auto missing = MissionStore::open(mission, gridConfig());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("cannot open submap file"), std::string::npos) << missing.error().message;
  EXPECT_NE(missing.error().message.find("000001.ot"), std::string::npos);
  EXPECT_EQ(testing::readBytes(mission / MissionStore::kJournalFile), journal_before);

  // Restored, the mission opens again; a grid of another resolution is refused.
  testing::writeBytes(ot, good);
  ASSERT_TRUE(MissionStore::open(mission, gridConfig()).ok());
  map::GridConfig other = gridConfig();
  other.resolution_m = 0.1;
  auto wrong = MissionStore::open(mission, other);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("resolution"), std::string::npos) << wrong.error().message;
}

TEST(MissionStore, JournalNamingAnUnknownRecordTypeIsAnError) {
  test::TempDir dir;
  const auto mission = dir.path() / "mission";
  {
    auto store = MissionStore::open(mission, gridConfig());
    ASSERT_TRUE(store.ok());
    writeMission(*store.value());
  }
  const auto journal_path = mission / MissionStore::kJournalFile;
  auto bytes = testing::readBytes(journal_path);
  const std::size_t offset = bytes.size();
  const auto frame = encodeFrame(std::vector<std::uint8_t>{200, 0, 0});
  bytes.insert(bytes.end(), frame.begin(), frame.end());
  testing::writeBytes(journal_path, bytes);
  auto store = MissionStore::open(mission, gridConfig());
  ASSERT_FALSE(store.ok());
  EXPECT_NE(store.error().message.find("byte offset " + std::to_string(offset) + ": unknown record type 200"),
            std::string::npos)
      << store.error().message;
}

TEST(MissionStore, HooksOutOfOrderAreRefusedAndChangeNothing) {
  test::TempDir dir;
  auto store = MissionStore::open(dir.path() / "m", gridConfig());
  ASSERT_TRUE(store.ok());
  MissionStore& s = *store.value();
  auto wrong_index = s.onSubmapClosed(closedSubmap(1));
  ASSERT_FALSE(wrong_index.ok());
  EXPECT_NE(wrong_index.error().message.find("submap index 1, expected 0"), std::string::npos);
  slam::ClosedSubmap no_grid = closedSubmap(0);
  no_grid.grid.reset();
  EXPECT_FALSE(s.onSubmapClosed(no_grid).ok());
  std::vector<slam::LoopClosure> stray(1);
  EXPECT_FALSE(s.onClosures(stray).ok());
  slam::Vector6d nan = slam::Vector6d::Zero();
  nan(2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(s.onWaypoint(WaypointRecord{1, 0.0, 0.0, nan(2), 0.0}).ok());
  ASSERT_TRUE(s.onSubmapClosed(closedSubmap(0)).ok());
  EXPECT_FALSE(s.onSubmapClosed(closedSubmap(1)).ok());  // previous group not committed
  EXPECT_FALSE(s.onOptimized({{0, nan}}).ok());
  EXPECT_EQ(s.nextSubmapIndex(), 0);
  EXPECT_EQ(std::filesystem::file_size(dir.path() / "m" / MissionStore::kJournalFile), 0U);
}

void closeSubmap(MissionStore& store, std::int64_t k) {
  ASSERT_TRUE(store.onSubmapClosed(closedSubmap(k)).ok());
  ASSERT_TRUE(store.onClosures({}).ok());
  ASSERT_TRUE(store.onOptimized({{k, estimate(k, 0)}}).ok());
}

// The mission folder on a small tmpfs that fills up: mapping goes on (the hooks succeed), the fault and
// the pending submaps are reported, nothing in the journal names a missing or bad file (a copy of the
// folder taken while full resumes exactly the submap written before), and once space returns the
// pending submaps are written in order and a restart resumes all of them with identical grids.
TEST(MissionStore, AFullDiskKeepsSubmapsPendingAndWritesThemInOrderWhenSpaceReturns) {
  test::SmallTmpfs disk(1 << 20);
  if (!disk.mounted()) GTEST_SKIP() << "needs a tmpfs to fill: " << disk.error();
  const auto mission = disk.path() / "mission";
  {
    auto opened = MissionStore::open(mission, gridConfig());
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    MissionStore& store = *opened.value();
    closeSubmap(store, 0);
    ASSERT_FALSE(store.health().fault);
    ASSERT_TRUE(disk.fill());

    closeSubmap(store, 1);
    ASSERT_TRUE(store.onWaypoint(WaypointRecord{7, 1.0, 2.0, -3.0, 0.5}).ok());
    closeSubmap(store, 2);
    ASSERT_TRUE(store.onState(MissionStateRecord{9, MissionState::kReturning}).ok());
    StorageHealth full = store.retryPending();
    ASSERT_TRUE(full.fault.has_value());
    EXPECT_NE(full.fault->message.find("No space left on device"), std::string::npos) << full.fault->message;
    EXPECT_EQ(full.pending_submaps, 2u);
    EXPECT_EQ(full.pending_records, 2u);
    EXPECT_EQ(store.nextSubmapIndex(), 3);

    // What is on disk now resumes as it was before the disk filled.
    test::TempDir copy;
    std::filesystem::copy(mission, copy.path() / "m", std::filesystem::copy_options::recursive);
    MissionResume while_full;
    auto reopened = MissionStore::open(copy.path() / "m", gridConfig(), &while_full);
    ASSERT_TRUE(reopened.ok()) << reopened.error().message;
    EXPECT_EQ(while_full.pipeline.submaps.size(), 1u);
    EXPECT_EQ(while_full.uncommitted_records, 0u);
    EXPECT_FALSE(while_full.journal_tail.torn);

    disk.release();
    const StorageHealth freed = store.retryPending();
    EXPECT_FALSE(freed.fault.has_value()) << freed.fault->message;
    EXPECT_EQ(freed.pending_submaps, 0u);
    EXPECT_EQ(freed.pending_records, 0u);
  }
  MissionResume resume;
  auto reopened = MissionStore::open(mission, gridConfig(), &resume);
  ASSERT_TRUE(reopened.ok()) << reopened.error().message;
  ASSERT_EQ(resume.pipeline.submaps.size(), 3u);
  for (std::int64_t k = 0; k < 3; ++k) {
    const auto& got = resume.pipeline.submaps[static_cast<std::size_t>(k)];
    EXPECT_EQ(got.index, k);
    expectGridsEqual(*got.grid, *closedSubmap(k).grid);
    EXPECT_EQ(resume.pipeline.estimates[static_cast<std::size_t>(k)], estimate(k, 0));
  }
  ASSERT_TRUE(resume.state.has_value());
  EXPECT_EQ(resume.state->state, MissionState::kReturning);
  ASSERT_TRUE(resume.waypoint.has_value());
  EXPECT_EQ(resume.waypoint->stamp_ns, 7);
  EXPECT_EQ(resume.uncommitted_records, 0u);
}

}  // namespace
}  // namespace vog::mission
