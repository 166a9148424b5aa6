// vog-console's mirror against a real vogd (in-process, the simulator in lockstep, loop closures on):
// at the same graph version the console's merged map holds the same sums and counts as vogd's merged
// map, every closed submap is fetched exactly once, and after a dropped link it reconnects and
// catches up without fetching again what it holds.
#include "vog/app/daemon.hpp"
#include "vog/client/api_client.hpp"
#include "vog/console/console.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <thread>

namespace vog::console {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

bool waitUntil(const std::function<bool()>& done, double timeout_s) {
  const auto t0 = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - t0).count() < timeout_s) {
    if (done()) return true;
    std::this_thread::sleep_for(50ms);
  }
  return done();
}

struct RunningDaemon {
  explicit RunningDaemon(std::unique_ptr<app::Daemon> d) : daemon(std::move(d)) {
    thread = std::thread([this] { result = daemon->run(); });
  }
  ~RunningDaemon() {
    daemon->requestStop();
    thread.join();
  }
  std::unique_ptr<app::Daemon> daemon;
  std::thread thread;
  Status result;
};

TEST(ConsoleMirror, EqualsVogdsMergedMapAtTheSameGraphVersionThroughADroppedLink) {
  test::TempDir dir("console-mirror");
  // Re-merge tolerance 0: vogd's merged map is its submaps at exactly their current poses.
  const std::string text =
      "source: sim\n"
      "sim:\n  scene: scenes/pilings.yaml\n  seed: 2\n  speedup: 0\n"
      "mission:\n  box_min_m: [-6, -4, -4]\n  box_max_m: [6, 4, 0]\n  start_on_launch: true\n  max_submaps: 24\n"
      "merge:\n  remerge_translation_m: 0\n  remerge_rotation_deg: 0\n"
      "api:\n  port: 0\n";
  const app::VogdConfig config = app::parseVogdConfig(text, "test.yaml", test::sourceDir() / "config").value();
  app::DaemonOptions options;
  options.mission_dir = dir.path() / "mission";
  options.port_file = dir.path() / "port";
  RunningDaemon run(app::Daemon::create(config, options).value());
  std::uint16_t port = 0;
  ASSERT_TRUE(waitUntil(
      [&] {
        std::ifstream in(*options.port_file);
        int p = 0;
        if (in >> p && p > 0) port = static_cast<std::uint16_t>(p);
        return port != 0;
      },
      10.0));

  ConsoleConfig cc;
  cc.port = port;
  cc.no_secret_why = "no --secret-file";
  cc.web.port = 0;
  cc.web.web_root = dir.path();
  cc.reconnect_min = 200ms;
  cc.reconnect_max = 400ms;
  auto console = Console::start(cc).value();

  // A dropped link while the mission maps: the console reconnects.
  ASSERT_TRUE(waitUntil([&] { return console->view().submaps >= 3; }, 120.0)) << "the first submaps";
  console->dropLink();
  ASSERT_TRUE(waitUntil([&] { return console->view().reconnects >= 1 && console->view().connected; }, 20.0));

  auto status = client::ApiClient::connect("127.0.0.1", port).value();
  ASSERT_TRUE(waitUntil(
      [&] {
        auto s = status->status();
        return s.ok() &&
               (s->mission_state == api::MissionState::kComplete || s->mission_state == api::MissionState::kAborted);
      },
      180.0));
  // Settled: vogd's graph no longer changes, its merge has taken the last one, the console holds it.
  std::shared_ptr<const api::GraphState> graph;
  ASSERT_TRUE(waitUntil(
      [&] {
        auto before = run.daemon->graph();
        std::this_thread::sleep_for(300ms);
        graph = run.daemon->graph();
        return graph && graph == before;
      },
      60.0));
  ASSERT_TRUE(waitUntil(
      [&] {
        const MirrorView v = console->view();
        return v.graph_version == graph->version && v.complete;
      },
      60.0))
      << "console at graph " << console->view().graph_version << ", vogd at " << graph->version;
  const MirrorView v = console->view();
  ASSERT_TRUE(v.merged);
  ASSERT_TRUE(waitUntil([&] { return run.daemon->mapSnapshot()->submapCount() == graph->submaps.size(); }, 30.0));
  const auto vogd_map = run.daemon->mapSnapshot();
  EXPECT_TRUE(v.merged->sameVoxels(*vogd_map));
  EXPECT_EQ(v.merged->knownVoxelCount(), vogd_map->knownVoxelCount());
  EXPECT_GT(v.occupied, 1000u);
  EXPECT_EQ(v.submaps, graph->submaps.size());
  EXPECT_EQ(v.submaps_fetched, graph->submaps.size()) << "each submap fetched once, none again after the drop";
  EXPECT_GE(graph->submaps.size(), 10u);
  EXPECT_FALSE(graph->closures.empty()) << "the mission closed loops (the poses moved)";

  // The occupied count the pages are told is the mirror's own.
  std::size_t occupied = 0;
  v.merged->forEachKnown([&](const map::VoxelKey&, const map::VoxelValue& value) {
    occupied += value.status == map::Occupancy::kOccupied ? 1 : 0;
  });
  EXPECT_EQ(v.occupied, occupied);
  console->stop();
}

}  // namespace
}  // namespace vog::console
