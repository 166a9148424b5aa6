// The scoring of a mission folder vogd filled on its simulator (what vog-eval prints): on a mission
// without odometry noise the estimate is the truth, so the reconstruction error is at the voxel grids' floor and the
// estimated path is the true one; the figures agree with the folder; a folder that is not a simulated
// mission is refused with the reason.
#include "vog/app/daemon.hpp"
#include "vog/eval/mission_score.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <thread>

namespace vog::eval {
namespace {

app::VogdConfig simConfig(const std::string& extra) {
  const std::string text =
      "source: sim\n"
      "sim:\n  scene: scenes/pilings.yaml\n  seed: 5\n  speedup: 0\n" +
      extra +
      "mission:\n  box_min_m: [-6, -4, -4]\n  box_max_m: [6, 4, 0]\n"
      "  start_on_launch: true\n  max_submaps: 3\n"
      "api:\n  port: 0\n";
  return app::parseVogdConfig(text, "test.yaml", test::sourceDir() / "config").value();
}

// Runs vogd in-process until its mission is complete (budget of 3 submaps), then stops it.
void runMission(const app::VogdConfig& config, const std::filesystem::path& mission_dir) {
  app::DaemonOptions options;
  options.mission_dir = mission_dir;
  auto daemon = app::Daemon::create(config, options);
  ASSERT_TRUE(daemon.ok()) << daemon.error().message;
  Status result;
  std::thread runner([&] { result = (*daemon)->run(); });
  const auto t0 = std::chrono::steady_clock::now();
  while ((*daemon)->status().mission_state != api::MissionState::kComplete &&
         std::chrono::steady_clock::now() - t0 < std::chrono::seconds(180))
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ((*daemon)->status().mission_state, api::MissionState::kComplete);
  (*daemon)->requestStop();
  runner.join();
  EXPECT_TRUE(result.ok()) << result.error().message;
}

std::size_t countLines(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

TEST(MissionScore, AMissionWithoutOdometryNoiseScoresAsItsOwnTruth) {
  test::TempDir dir("vog-eval-test");
  const app::VogdConfig config = simConfig("  odometry_noise_scale: 0\n");
  runMission(config, dir.path() / "mission");
  auto score = scoreSimulatedMission(config, dir.path() / "mission", dir.path() / "plots");
  ASSERT_TRUE(score.ok()) << score.error().message;

  std::size_t stored = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path() / "mission" / "submaps"))
    stored += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(score->n_submaps, stored);
  EXPECT_GE(score->n_submaps, 3u);
  EXPECT_EQ(score->scene, "pilings");
  // The map is built at the true poses (but for the depth sensor's noise): its occupied voxel centres
  // lie within a voxel of the reference's, the floor that the submaps' own voxel grids leave.
  const double res = config.mapping.builder.grid.resolution_m;
  EXPECT_LT(score->rmse_unaligned_m, res);
  EXPECT_LT(score->rmse_m, res);
  EXPECT_GT(score->coverage, 0.05);
  EXPECT_LE(score->coverage, 1.0);
  EXPECT_NEAR(score->coverage, score->coverage_unaligned, 0.02);
  EXPECT_GT(score->path_m, 0.1);
  EXPECT_GT(score->sim_s, 1.0);
  EXPECT_GT(score->plan_iterations, 0u);
  EXPECT_GT(score->observable_points, 1000u);

  // The plot files: the true and the estimated path agree, to the millimetre in x and y (z carries
  // the depth sensor's own noise, which the odometry's scale does not remove).
  std::ifstream path(dir.path() / "plots" / "path.csv");
  std::string line;
  std::getline(path, line);
  std::size_t rows = 0;
  while (std::getline(path, line)) {
    double v[6];
    char comma;
    std::istringstream row(line);
    row >> v[0] >> comma >> v[1] >> comma >> v[2] >> comma >> v[3] >> comma >> v[4] >> comma >> v[5];
    ASSERT_TRUE(row) << line;
    EXPECT_NEAR(v[0], v[3], 1e-3) << line;
    EXPECT_NEAR(v[1], v[4], 1e-3) << line;
    EXPECT_NEAR(v[2], v[5], 0.03) << line;
    ++rows;
  }
  EXPECT_GT(rows, 1u);
  EXPECT_GT(countLines(dir.path() / "plots" / "map_points.csv"), 1000u);
  EXPECT_EQ(countLines(dir.path() / "plots" / "iterations.csv"), countLines(dir.path() / "mission" / "iterations.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "plots" / "merges.csv"));
}

TEST(MissionScore, WhatIsNotASimulatedMissionIsRefusedWithTheReason) {
  test::TempDir dir("vog-eval-test");
  app::VogdConfig config = simConfig("");
  auto none = scoreSimulatedMission(config, dir.path());
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("holds no mission journal"), std::string::npos) << none.error().message;
  config.source = app::Source::kDevices;
  auto devices = scoreSimulatedMission(config, dir.path());
  ASSERT_FALSE(devices.ok());
  EXPECT_NE(devices.error().message.find("source: sim"), std::string::npos) << devices.error().message;
}

}  // namespace
}  // namespace vog::eval
