// The parts of vogd's daemon that own their own state, without their threads: the resumed source's
// alignment, the thread watchdog, the scan queue, the raw recorder's gate, the mapping stage and the
// API's reconstruction cloud.
#include "vog/app/mapping_stage.hpp"
#include "vog/app/raw_recorder.hpp"
#include "vog/app/replay.hpp"
#include "vog/app/reconstruction_cloud.hpp"
#include "vog/app/scan_queue.hpp"
#include "vog/app/scan_record.hpp"
#include "vog/app/source_alignment.hpp"
#include "vog/app/watchdog.hpp"

#include "small_tmpfs.hpp"
#include "synthetic_scene.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <thread>

namespace vog::app {
namespace {

using geometry::Pose3;

OdometrySample sample(std::int64_t stamp_ns, const Pose3& T) {
  OdometrySample s;
  s.stamp_ns = stamp_ns;
  s.T_odom_vehicle = T;
  return s;
}

void expectPosesNear(const Pose3& a, const Pose3& b, double tol = 1e-9) {
  EXPECT_LT((a.translation() - b.translation()).norm(), tol)
      << a.translation().transpose() << " vs " << b.translation().transpose();
  EXPECT_LT((a.linear() - b.linear()).norm(), tol);
}

TEST(SourceAlignment, ANewMissionChangesNothing) {
  SourceAlignment a;
  const Pose3 T = geometry::poseFromXyzRpy(1.0, 2.0, -3.0, 0.1, -0.05, 0.7);
  a.firstSample(sample(5, T), false);
  const OdometrySample s = a.align(sample(7, T));
  EXPECT_EQ(s.stamp_ns, 7);
  EXPECT_EQ(s.T_odom_vehicle.matrix(), T.matrix());
  slam::ScanInput scan;
  scan.scan.stamp_ns = 9;
  scan.T_world_vehicle_odom = T;
  EXPECT_EQ(a.align(scan).scan.stamp_ns, 9);
  EXPECT_EQ(a.align(scan).T_world_vehicle_odom.matrix(), T.matrix());
}

TEST(SourceAlignment, ARestartedSourceContinuesWhereTheVehicleWasAndAfterTheLastStamp) {
  // The old odometry frame sat at (2, -1) turned 0.4 rad in the map; the vehicle was held at
  // (3, 1, -2) heading 1.2 rad; the last mapped stamp was 500 s.
  const Pose3 T_map_oldodom = geometry::poseFromXyzRpy(2.0, -1.0, 0.0, 0.0, 0.0, 0.4);
  const Pose3 T_map_vehicle = geometry::poseFromXyzRpy(3.0, 1.0, -2.0, 0.0, 0.0, 1.2);
  const std::int64_t last_ns = 500'000'000'000;
  SourceAlignment a(T_map_vehicle, T_map_oldodom, last_ns);
  // The simulator restarts at its own origin and clock; depth, roll and pitch are measured.
  const Pose3 first = geometry::poseFromXyzRpy(0.0, 0.0, -2.1, 0.02, -0.01, 0.0);
  a.firstSample(sample(1'000'000'000, first), false);
  const OdometrySample s0 = a.align(sample(1'000'000'000, first));
  const Pose3 T_map_first = T_map_oldodom * s0.T_odom_vehicle;
  EXPECT_NEAR(T_map_first.translation().x(), 3.0, 1e-9);
  EXPECT_NEAR(T_map_first.translation().y(), 1.0, 1e-9);
  EXPECT_NEAR(T_map_first.translation().z(), -2.1, 1e-9);  // the measured depth, not the held one
  const Eigen::Vector3d rpy = geometry::rpyFromRotation(T_map_first.linear());
  EXPECT_NEAR(rpy.x(), 0.02, 1e-9);
  EXPECT_NEAR(rpy.y(), -0.01, 1e-9);
  EXPECT_NEAR(rpy.z(), 1.2, 1e-9);
  EXPECT_EQ(s0.stamp_ns, last_ns + 1'000'000'000);  // one second after the last mapped stamp
  // Later motion keeps its shape; scans get the same frame and clock.
  const Pose3 later = geometry::poseFromXyzRpy(1.5, 0.5, -2.0, 0.0, 0.0, 0.3);
  const OdometrySample s1 = a.align(sample(3'000'000'000, later));
  expectPosesNear(s0.T_odom_vehicle.inverse() * s1.T_odom_vehicle, first.inverse() * later);
  EXPECT_EQ(s1.stamp_ns - s0.stamp_ns, 2'000'000'000);
  slam::ScanInput scan;
  scan.scan.stamp_ns = 3'000'000'000;
  scan.T_world_vehicle_odom = later;
  const slam::ScanInput aligned = a.align(scan);
  EXPECT_EQ(aligned.scan.stamp_ns, s1.stamp_ns);
  expectPosesNear(aligned.T_world_vehicle_odom, s1.T_odom_vehicle);
  // Fixed at the first sample: another "first" sample changes nothing.
  a.firstSample(sample(0, later), false);
  expectPosesNear(a.align(sample(0, later)).T_odom_vehicle, s1.T_odom_vehicle);
}

TEST(SourceAlignment, APersistentFrameAndClockContinueAsTheyAre) {
  const Pose3 T_map_oldodom = geometry::poseFromXyzRpy(2.0, -1.0, 0.0, 0.0, 0.0, 0.4);
  const Pose3 T_map_vehicle = geometry::poseFromXyzRpy(3.0, 1.0, -2.0, 0.0, 0.0, 1.2);
  SourceAlignment a(T_map_vehicle, T_map_oldodom, 500);
  const Pose3 T = geometry::poseFromXyzRpy(0.5, 0.5, -2.0, 0.0, 0.0, 0.1);
  a.firstSample(sample(600, T), true);
  const OdometrySample s = a.align(sample(600, T));
  EXPECT_EQ(s.stamp_ns, 600);
  EXPECT_EQ(s.T_odom_vehicle.matrix(), T.matrix());
  EXPECT_EQ(a.stampOffsetNs(), 0);
}

TEST(Watchdog, AThreadThatStopsBeatingIsReportedOnceAndAliveAgainWhenItBeats) {
  using Clock = Watchdog::Clock;
  std::atomic<std::uint64_t> a{0}, b{0};
  const Clock::time_point t0{};
  Watchdog w(std::chrono::seconds(10));
  w.add(
      "mapping", [&] { return a.load(); }, t0);
  w.add(
      "planning", [&] { return b.load(); }, t0);
  // Both beat for 30 s.
  for (int s = 1; s <= 30; ++s) {
    ++a;
    ++b;
    const Watchdog::Check c = w.check(t0 + std::chrono::seconds(s));
    EXPECT_TRUE(c.alive);
    EXPECT_TRUE(c.newly_stalled.empty());
  }
  // The planning thread stops: alive until the limit, then stuck, reported once.
  int reports = 0;
  for (int s = 31; s <= 60; ++s) {
    ++a;
    const Watchdog::Check c = w.check(t0 + std::chrono::seconds(s));
    EXPECT_EQ(c.alive, s <= 40) << s;
    for (const std::string& name : c.newly_stalled) {
      EXPECT_EQ(name.rfind("planning", 0), 0u) << name;
      ++reports;
    }
  }
  EXPECT_EQ(reports, 1);
  // It beats again, then stalls again: reported again.
  ++b;
  EXPECT_TRUE(w.check(t0 + std::chrono::seconds(61)).alive);
  EXPECT_EQ(w.check(t0 + std::chrono::seconds(80)).newly_stalled.size(), 2u);  // both stopped now
}

QueuedScan scanAt(std::int64_t stamp_ns) {
  QueuedScan q;
  q.scan.scan.stamp_ns = stamp_ns;
  return q;
}

TEST(ScanQueue, ASourceWaitsWhileMappingIsBehindAndTheMapCatchesUpBeforeItIsDrained) {
  ScanQueue q(2);
  ASSERT_TRUE(q.push(scanAt(1)));
  ASSERT_TRUE(q.push(scanAt(2)));
  // Full: the third push waits until the mapping side takes one.
  auto third = std::async(std::launch::async, [&] { return q.push(scanAt(3)); });
  EXPECT_EQ(third.wait_for(std::chrono::milliseconds(100)), std::future_status::timeout);
  ASSERT_EQ(q.pop(std::chrono::milliseconds(100))->scan.scan.stamp_ns, 1);
  EXPECT_TRUE(third.get());
  // Drained only when every pushed scan is done, not merely popped.
  auto drained = std::async(std::launch::async, [&] { return q.waitDrained(); });
  EXPECT_EQ(q.pop(std::chrono::milliseconds(100))->scan.scan.stamp_ns, 2);
  EXPECT_EQ(q.pop(std::chrono::milliseconds(100))->scan.scan.stamp_ns, 3);
  EXPECT_FALSE(q.pop(std::chrono::milliseconds(10)).has_value());  // empty: a timeout
  q.done(true);
  q.done(false);
  EXPECT_EQ(drained.wait_for(std::chrono::milliseconds(100)), std::future_status::timeout);
  q.done(true);
  EXPECT_TRUE(drained.get());
  q.skipped();
  EXPECT_EQ(q.notMapped(), 2u);
}

TEST(ScanQueue, StopReleasesEveryWaiter) {
  ScanQueue q(1);
  ASSERT_TRUE(q.push(scanAt(1)));
  auto pusher = std::async(std::launch::async, [&] { return q.push(scanAt(2)); });
  auto drainer = std::async(std::launch::async, [&] { return q.waitDrained(); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  q.stop();
  EXPECT_FALSE(pusher.get());
  EXPECT_FALSE(drainer.get());
  EXPECT_FALSE(q.pop(std::chrono::milliseconds(10)).has_value());
  EXPECT_TRUE(q.stopped());
}

TEST(ScanQueue, CloseRefusesNewScansAndStillHandsOutTheQueuedOnes) {
  ScanQueue q(4);
  ASSERT_TRUE(q.push(scanAt(1)));
  ASSERT_TRUE(q.push(scanAt(2)));
  q.close();
  EXPECT_FALSE(q.push(scanAt(3)));
  EXPECT_FALSE(q.ended());
  EXPECT_EQ(q.pop(std::chrono::milliseconds(10))->scan.scan.stamp_ns, 1);
  EXPECT_EQ(q.pop(std::chrono::milliseconds(10))->scan.scan.stamp_ns, 2);
  EXPECT_TRUE(q.ended());
  // Closed and empty: pop returns at once, without waiting out its timeout.
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(q.pop(std::chrono::seconds(30)).has_value());
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(10));
  EXPECT_FALSE(q.stopped());
}

TEST(RawRecorder, TheMappingGateIsRecordedWhenItChangesBeforeTheInputsItGates) {
  test::TempDir dir("raw-recorder");
  const std::filesystem::path file = dir.path() / "raw.log";
  {
    RawRecorder r(mission::RawLog::open(file).value());
    const std::uint8_t bytes[3] = {1, 2, 3};
    for (const bool enabled : {false, false, true, true, false}) {
      r.gate(enabled, 10);
      r.record(7, 10, bytes);
    }
    r.sync();
    EXPECT_FALSE(r.health().fault.has_value());
  }
  const mission::RawLogContents contents = mission::readRawLog(file).value();
  std::vector<int> gates;  // gate records as 0/1, and -1 for each device record
  for (const mission::RawRecord& rec : contents.records)
    gates.push_back(rec.device_id == kMappingGateDeviceId ? rec.bytes.at(0) : -1);
  EXPECT_EQ(gates, (std::vector<int>{0, -1, -1, 1, -1, -1, 0, -1}));
}

// Recording off (the mission ended) keeps the records up to the gate record that closes the gate, and
// drops what comes after it until recording is on again.
TEST(RawRecorder, RecordingStopsAtTheClosedGateWhenTheMissionEnds) {
  test::TempDir dir("raw-recorder");
  const std::filesystem::path file = dir.path() / "raw.log";
  {
    RawRecorder r(mission::RawLog::open(file).value());
    const std::uint8_t bytes[1] = {5};
    r.gate(true, 1);
    r.record(7, 1, bytes);
    r.setRecording(false);
    r.record(7, 2, bytes);  // still mapped live: kept
    r.gate(false, 3);
    r.record(7, 3, bytes);  // after the end: dropped
    r.record(7, 4, bytes);
    EXPECT_FALSE(r.health().recording);
    r.setRecording(true);
    r.gate(true, 5);
    r.record(7, 5, bytes);
    r.sync();
  }
  const mission::RawLogContents contents = mission::readRawLog(file).value();
  std::vector<std::int64_t> stamps;
  for (const mission::RawRecord& rec : contents.records) stamps.push_back(rec.stamp_ns);
  EXPECT_EQ(stamps, (std::vector<std::int64_t>{1, 1, 2, 3, 5, 5}));
}

// A simulated recording under a small cap: scans 0-99 mapped, 100-199 outside the mission, 200-299
// mapped again. The oldest segments are dropped; a replay of what is left maps exactly the scans that
// were mapped live (every segment starts with the gate) and says how many segments were dropped.
TEST(RawRecorder, ACappedLogReplaysWhatIsLeftBehindTheSameGate) {
  test::TempDir dir("raw-capped");
  const std::filesystem::path mission_dir = dir.path() / "mission";
  std::filesystem::create_directories(mission_dir);
  VogdConfig config;
  config.source = Source::kSim;
  const test::SyntheticScene scene = test::SyntheticScene::pier();
  const std::vector<Pose3> orbit = test::orbitTrajectory(300, 5.5, -2.0);
  std::mt19937_64 rng(7);
  {
    RawRecorder raw(
        mission::RawLog::open(mission_dir / mission::MissionStore::kRawLogFile, mission::kMinRawLogBytes).value());
    for (int k = 0; k < 300; ++k) {
      slam::ScanInput scan;
      scan.T_world_vehicle_odom = orbit[static_cast<std::size_t>(k)];
      scan.z_roll_pitch = Eigen::Vector3d(orbit[static_cast<std::size_t>(k)].translation().z(), 0.0, 0.0);
      scan.scan = scene.scan(orbit[static_cast<std::size_t>(k)], config.mapping.builder.fan, 0.0, rng);
      scan.scan.stamp_ns = k;
      raw.gate(k < 100 || k >= 200, k);
      raw.record(kSimScanDeviceId, k, encodeScanRecord(scan));
    }
    raw.sync();
    EXPECT_GT(raw.health().dropped_segments, 0u);
  }
  const mission::RawLogContents left = mission::readRawLog(mission_dir / mission::MissionStore::kRawLogFile).value();
  ASSERT_GT(left.dropped_segments, 0u);
  std::vector<std::int64_t> scans;
  for (const mission::RawRecord& r : left.records)
    if (r.device_id == kSimScanDeviceId) scans.push_back(r.stamp_ns);
  ASSERT_FALSE(scans.empty());
  ASSERT_GT(scans.front(), 100) << "the test needs the gate's closing record dropped";
  ASSERT_LT(scans.front(), 200);
  auto stats = replayMission(config, mission_dir, dir.path() / "replay");
  ASSERT_TRUE(stats.ok()) << stats.error().message;
  EXPECT_EQ(stats->dropped_segments, left.dropped_segments);
  EXPECT_EQ(stats->scans, 100u);
  EXPECT_EQ(stats->not_mapped, static_cast<std::uint64_t>(200 - scans.front()));
}

// A pier survey of 25 scans in submaps of 10, through the mapping stage with the simulator's
// recording: outside the mission a scan is recorded only; every closed submap is on disk (its grid and
// its journal group) before the published state lists it; finish() stores the active submap.
TEST(MappingStage, ASubmapIsDurableBeforeItIsPublishedAndTheActiveOneIsStoredAtTheEnd) {
  test::TempDir dir("mapping-stage");
  slam::MappingPipelineConfig config;
  config.builder.max_scans = 10;
  auto store = mission::MissionStore::open(dir.path() / "mission", config.builder.grid).value();
  RawRecorder raw(mission::RawLog::open(dir.path() / "mission" / mission::MissionStore::kRawLogFile).value());
  auto merge = map::MergeWorker::create(config.builder.grid, map::MergeConfig{}).value();
  int published = 0;
  std::size_t stored_when_published = 0;
  auto stored = [&] {
    std::size_t n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir.path() / "mission" / "submaps"))
      n += e.is_regular_file() ? 1 : 0;
    return n;
  };
  MappingStage stage(true, slam::MappingPipeline::create(config).value(), *store, raw, *merge, [&] {
    ++published;
    stored_when_published = stored();
  });
  EXPECT_EQ(published, 1);  // the empty state
  EXPECT_TRUE(stage.state()->submaps.empty());

  const test::SyntheticScene scene = test::SyntheticScene::pier();
  const std::vector<Pose3> orbit = test::orbitTrajectory(30, 5.5, -2.0);
  std::mt19937_64 rng(7);
  for (int k = 0; k < 30; ++k) {
    QueuedScan item;
    item.scan.T_world_vehicle_odom = orbit[static_cast<std::size_t>(k)];
    item.scan.z_roll_pitch = Eigen::Vector3d(orbit[static_cast<std::size_t>(k)].translation().z(), 0.0, 0.0);
    item.scan.scan = scene.scan(orbit[static_cast<std::size_t>(k)], config.builder.fan, 0.0, rng);
    item.scan.scan.stamp_ns = (k + 1) * 200'000'000LL;
    item.T_world_vehicle_true = orbit[static_cast<std::size_t>(k)];
    const bool in_mission = k >= 5;  // the first five scans come before the mission starts
    auto mapped = stage.process(item, in_mission);
    ASSERT_TRUE(mapped.ok()) << mapped.error().message;
    EXPECT_EQ(*mapped, in_mission) << k;
    EXPECT_EQ(stored_when_published, stage.state()->submaps.size()) << "published before it was durable, scan " << k;
  }
  EXPECT_EQ(stage.state()->submaps.size(), 2u);  // 25 scans mapped: two full submaps, five in the active one
  const std::shared_ptr<const MappingState> before = stage.state();
  const slam::SubmapRecord& last = before->records.back();
  expectPosesNear(before->T_map_odom, last.T_world_base * last.T_world_base_odom.inverse());
  EXPECT_EQ(before->submaps.back().id, 1u);
  EXPECT_EQ(stage.rejectedScans(), 0u);

  stage.finish(true);
  EXPECT_EQ(stage.state()->submaps.size(), 3u);
  EXPECT_EQ(stored(), 3u);
  EXPECT_EQ(before->submaps.size(), 2u) << "a published state never changes";
  // The raw log: every scan and its truth, the gate closed for the first five and open after.
  const mission::RawLogContents log =
      mission::readRawLog(dir.path() / "mission" / mission::MissionStore::kRawLogFile).value();
  int scans = 0, truths = 0;
  std::vector<int> gates;
  for (const mission::RawRecord& r : log.records) {
    scans += r.device_id == kSimScanDeviceId ? 1 : 0;
    truths += r.device_id == kSimTruthDeviceId ? 1 : 0;
    if (r.device_id == kMappingGateDeviceId) gates.push_back(r.bytes.at(0));
  }
  EXPECT_EQ(scans, 30);
  EXPECT_EQ(truths, 30);
  EXPECT_EQ(gates, (std::vector<int>{0, 1}));
  ASSERT_TRUE(merge->waitIdle().ok());
  EXPECT_EQ(merge->snapshot()->submapCount(), 3u);
  merge->stop();
}

// The mission folder on a tmpfs that fills up: mapping goes on and publishes, the storage health entry
// says why and how many submaps wait, and once space returns retryStorage() writes them.
TEST(MappingStage, AFullDiskIsReportedInTheStorageHealthAndRetried) {
  test::SmallTmpfs disk(1 << 20);
  if (!disk.mounted()) GTEST_SKIP() << "needs a tmpfs to fill: " << disk.error();
  test::TempDir dir("mapping-stage-full");
  slam::MappingPipelineConfig config;
  config.builder.max_scans = 5;
  auto store = mission::MissionStore::open(disk.path() / "mission", config.builder.grid).value();
  RawRecorder raw(mission::RawLog::open(dir.path() / mission::MissionStore::kRawLogFile).value());
  auto merge = map::MergeWorker::create(config.builder.grid, map::MergeConfig{}).value();
  MappingStage stage(true, slam::MappingPipeline::create(config).value(), *store, raw, *merge, nullptr);
  ASSERT_TRUE(disk.fill());
  const test::SyntheticScene scene = test::SyntheticScene::pier();
  const std::vector<Pose3> orbit = test::orbitTrajectory(12, 5.5, -2.0);
  std::mt19937_64 rng(7);
  for (int k = 0; k < 12; ++k) {
    QueuedScan item;
    item.scan.T_world_vehicle_odom = orbit[static_cast<std::size_t>(k)];
    item.scan.z_roll_pitch = Eigen::Vector3d(orbit[static_cast<std::size_t>(k)].translation().z(), 0.0, 0.0);
    item.scan.scan = scene.scan(orbit[static_cast<std::size_t>(k)], config.builder.fan, 0.0, rng);
    item.scan.scan.stamp_ns = (k + 1) * 200'000'000LL;
    ASSERT_TRUE(stage.process(item, true).ok());
  }
  EXPECT_EQ(stage.state()->submaps.size(), 2u) << "mapping goes on in memory";
  const api::DeviceHealth full = stage.storageHealth();
  EXPECT_EQ(full.name, "storage");
  EXPECT_EQ(full.state, api::DeviceState::kDegraded);
  EXPECT_NE(full.detail.find("No space left on device (2 submaps pending)"), std::string::npos) << full.detail;
  disk.release();
  stage.retryStorage();
  const api::DeviceHealth freed = stage.storageHealth();
  EXPECT_EQ(freed.state, api::DeviceState::kOk) << freed.detail;
  EXPECT_EQ(store->health().pending_submaps, 0u);
  merge->stop();
  store.reset();
  mission::MissionResume resume;
  ASSERT_TRUE(mission::MissionStore::open(disk.path() / "mission", config.builder.grid, &resume).ok());
  EXPECT_EQ(resume.pipeline.submaps.size(), 2u);
}

// The cloud is the merged map's occupied voxel centres, built once per map version.
TEST(ReconstructionCloud, HoldsTheOccupiedVoxelCentresBuiltOnlyWhenAskedAndOncePerVersion) {
  map::GridConfig grid;
  auto merged = map::MergedMap::create(grid).value();
  auto local = map::LocalGrid::create(grid).value();
  const test::SyntheticScene scene = test::SyntheticScene::pier();
  std::mt19937_64 rng(3);
  const geometry::SonarFan fan;
  const std::vector<Pose3> orbit = test::orbitTrajectory(8, 5.5, -2.0);
  for (const Pose3& T : orbit)
    ASSERT_TRUE(local->insertScan(T * fan.T_vehicle_sensor, fan, scene.scan(T, fan, 0.0, rng)).ok());
  local->finalize();
  map::SubmapEntry entry;
  entry.grid = std::move(local);
  ASSERT_TRUE(merged->add(entry).ok());
  const auto snapshot = merged->snapshot();

  ReconstructionCloud cloud;
  cloud.update(snapshot);
  EXPECT_EQ(cloud.latest(), nullptr) << "nobody asked: nothing is built";
  cloud.update(nullptr);
  EXPECT_EQ(cloud.latest(), nullptr);
  cloud.update(snapshot);  // asked (by the latest() above)
  const auto a = cloud.latest();
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a->map_version, snapshot->version());
  std::size_t occupied = 0;
  const double res = snapshot->resolution();
  snapshot->forEachKnown([&](const map::VoxelKey& key, const map::VoxelValue& v) {
    if (v.status != map::Occupancy::kOccupied) return;
    ASSERT_LT(occupied, a->points.size());
    EXPECT_EQ(a->points[occupied].p_world_m, map::keyToCentre(key, res).cast<float>());
    ++occupied;
  });
  EXPECT_GT(occupied, 50u);
  EXPECT_EQ(a->points.size(), occupied);
  cloud.update(snapshot);
  EXPECT_EQ(cloud.latest(), a) << "the same version is not built twice";
  ASSERT_TRUE(merged->remove(0).ok());
  const auto newer = merged->snapshot();
  EXPECT_EQ(cloud.latest(), a) << "until the builder runs, the newest built cloud is served";
  cloud.update(newer);
  const auto b = cloud.latest();
  EXPECT_NE(b, a);
  EXPECT_EQ(b->map_version, newer->version());
  EXPECT_TRUE(b->points.empty());
}

}  // namespace
}  // namespace vog::app
