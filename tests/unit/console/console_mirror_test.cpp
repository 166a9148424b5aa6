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
  // Settled. A mission that has ended still maps the scans queued before its end, so "complete" is not
  // the last graph: wait until vogd's graph stays put, the console holds that version and vogd's merge
  // has taken it. The console's map at a fixed version never changes, and vogd's map converges to the
  // merge of that version, so the comparison is retried until then.
  std::shared_ptr<const api::GraphState> graph;
  std::shared_ptr<const map::MergedMap> vogd_map;
  MirrorView v;
  const bool settled = waitUntil(
      [&] {
        graph = run.daemon->graph();
        std::this_thread::sleep_for(300ms);
        if (!graph || run.daemon->graph() != graph) return false;
        v = console->view();
        vogd_map = run.daemon->mapSnapshot();
        return v.graph_version == graph->version && v.complete && v.merged && vogd_map &&
               vogd_map->submapCount() == graph->submaps.size() && v.merged->sameVoxels(*vogd_map);
      },
      120.0);
  ASSERT_TRUE(graph && vogd_map && v.merged);
  EXPECT_TRUE(settled) << "console at graph " << v.graph_version << (v.complete ? " (complete)" : "") << ", vogd at "
                       << graph->version << " with " << graph->submaps.size() << " submaps, its merged map holds "
                       << vogd_map->submapCount();
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
