// vog-bench sim: simulated sonar scans per second (96 beams x 5 sub-rays, Embree, one thread) on a
// shipped scene, medians over repeats. Target: >= 2000 scans/s, so a 156-submap mission
// of 15,600 scans simulates in seconds. Also reports scans/s with the 96 x 512 intensity frame.
// Run from the repository root (scene paths are relative to it) or pass --scene.
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include "vog/sim/sonar_model.hpp"
#include "vog/sim/world.hpp"

#include <CLI/CLI.hpp>

#include <iostream>
#include <random>

VOG_BENCH_COMMAND(sim, "Simulator: sonar scans/s (96 beams x 5 sub-rays, one core), target >= 2000") {
  std::string scene_file = "config/scenes/pilings.yaml";
  int scans = 2000;
  int repeats = 5;
  int sub_rays = 5;
  std::uint64_t seed = 1;
  bool json = false;
  CLI::App app{"vog-bench sim"};
  app.add_option("--scene", scene_file, "scene YAML file");
  app.add_option("--scans", scans, "scans per repeat")->check(CLI::Range(1, 1000000));
  app.add_option("--repeats", repeats, "timed repeats (median reported)")->check(CLI::Range(1, 1000));
  app.add_option("--sub-rays", sub_rays, "sub-rays per beam")->check(CLI::Range(1, 64));
  app.add_option("--seed", seed, "noise and pose seed");
  app.add_flag("--json", json, "print JSON (the only output format)");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;

  auto scene = vog::sim::loadScene(scene_file);
  if (!scene) {
    std::cerr << "sim bench: " << scene.error().message << "\n";
    return 1;
  }
  auto world = vog::sim::World::create(*scene);
  if (!world) {
    std::cerr << "sim bench: " << world.error().message << "\n";
    return 1;
  }
  vog::sim::SonarModelConfig cfg;
  cfg.sub_rays_per_beam = sub_rays;
  auto model = vog::sim::SonarModel::create(**world, cfg, seed);
  if (!model) {
    std::cerr << "sim bench: " << model.error().message << "\n";
    return 1;
  }

  // Vehicle poses spread over the exploration box, all headings (generated before timing).
  std::mt19937_64 rng(seed);
  const Eigen::AlignedBox3d& box = scene->bounds_world;
  std::vector<vog::geometry::Pose3> poses;
  while (poses.size() < static_cast<std::size_t>(scans)) {
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) p[k] = std::uniform_real_distribution<double>(box.min()[k], box.max()[k])(rng);
    const double yaw = std::uniform_real_distribution<double>(-3.14159, 3.14159)(rng);
    const auto T = vog::geometry::poseFromXyzRpy(p.x(), p.y(), p.z(), 0, 0, yaw);
    if (!(*world)->boxCollides(T, Eigen::Vector3d(0.5, 0.5, 0.25))) poses.push_back(T);
  }

  std::vector<double> rates, frame_rates;
  std::size_t returns = 0, beams = 0;
  for (int r = 0; r < repeats; ++r) {
    const vog::bench::Stopwatch clock;
    for (std::size_t i = 0; i < poses.size(); ++i) {
      const auto ping = model->ping(poses[i], static_cast<std::int64_t>(i), false);
      if (r == 0) {
        for (const float x : ping.scan.range_m) returns += std::isfinite(x) ? 1 : 0;
        beams += ping.scan.range_m.size();
      }
    }
    rates.push_back(static_cast<double>(poses.size()) / clock.seconds());
  }
  const std::size_t n_frames = std::min<std::size_t>(poses.size(), 500);
  for (int r = 0; r < repeats; ++r) {
    const vog::bench::Stopwatch clock;
    for (std::size_t i = 0; i < n_frames; ++i) (void)model->ping(poses[i], static_cast<std::int64_t>(i), true);
    frame_rates.push_back(static_cast<double>(n_frames) / clock.seconds());
  }

  vog::bench::JsonObject out;
  out.add("bench", std::string("sim"));
  out.add("scene", scene->name);
  out.add("beams", cfg.fan.n_beams);
  out.add("sub_rays_per_beam", sub_rays);
  out.add("scans_per_repeat", scans);
  out.add("repeats", repeats);
  out.add("return_fraction", beams > 0 ? static_cast<double>(returns) / static_cast<double>(beams) : 0.0);
  out.add("scans_per_s", vog::bench::median(rates));
  out.add("scans_per_s_with_frame", vog::bench::median(frame_rates));
  out.add("mission_15600_scans_s", 15600.0 / vog::bench::median(rates));
  out.add("target_scans_per_s", 2000.0);
  out.add("meets_target", std::string(vog::bench::median(rates) >= 2000.0 ? "yes" : "no"));
  std::cout << out.str() << "\n";
  (void)json;
  return 0;
}
