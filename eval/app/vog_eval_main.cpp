// vog-eval: scores a mission folder that vogd filled on its simulator against the simulator's ground
// truth (vog/eval/mission_score.hpp) and prints the figures as JSON. scripts/demo scores its run with it.
#include "vog/app/vogd_config.hpp"
#include "vog/eval/mission_score.hpp"

#include <CLI/CLI.hpp>

#include <iostream>
#include <string>

int main(int argc, char** argv) {
  std::string config_file, mission_dir, plot_dir;
  CLI::App app{"vog-eval: score a simulated vogd mission against the simulator's ground truth (JSON on stdout)"};
  app.add_option("--config", config_file, "the vogd configuration the mission ran with (source: sim)")->required();
  app.add_option("--mission", mission_dir, "the mission folder")->required();
  app.add_option("--out", plot_dir,
                 "write iterations.csv, merges.csv, path.csv, map_points.csv for scripts/plot-mission");
  CLI11_PARSE(app, argc, argv);
  auto config = vog::app::loadVogdConfig(config_file);
  if (!config) {
    std::cerr << "vog-eval: " << config.error().message << "\n";
    return 1;
  }
  auto score = vog::eval::scoreSimulatedMission(*config, mission_dir, plot_dir);
  if (!score) {
    std::cerr << "vog-eval: " << score.error().message << "\n";
    return 1;
  }
  std::cout << vog::eval::toJson(*score).str() << "\n";
  return 0;
}
