#pragma once
// Scores a mission that vogd ran on its simulator (`source: sim`) against the simulator's ground
// truth, with the figures of `vog-bench mission`: coverage of the observable surface,
// reconstruction RMSE (occupied voxels of the final map against the same scans at their true poses,
// after a rigid alignment and without), path length, submaps, loop closures, and the planning and
// merge times vogd recorded. Reads only the mission folder (journal, submaps, raw log with the truth
// records, iterations.csv, merges.csv) and the configuration the mission ran with.

#include "vog/app/vogd_config.hpp"
#include "vog/core/result.hpp"
#include "vog/eval/figures.hpp"

#include <cstddef>
#include <filesystem>
#include <string>

namespace vog::eval {

struct MissionScore {
  std::string scene;
  double coverage = 0.0;            // aligned as the RMSE
  double coverage_unaligned = 0.0;  // as mapped
  double rmse_m = 0.0;
  double rmse_unaligned_m = 0.0;
  double path_m = 0.0;  // the true path's length
  std::size_t n_submaps = 0;
  std::size_t n_closures = 0;
  double sim_s = 0.0;  // simulated time from the first scan to the last
  std::size_t plan_iterations = 0;
  double plan_ms_p50 = 0.0;
  double plan_ms_p95 = 0.0;
  double plan_ms_max = 0.0;
  double merge_ms_p95 = 0.0;
  std::size_t observable_points = 0;
};

// Errors (naming what) when the configuration is not a simulator's, the folder holds no mission or
// no truth records, or a file cannot be read. With `plot_dir` not empty, writes there the CSVs that
// scripts/plot-mission draws: iterations.csv (coverage filled in every 10 submaps), merges.csv,
// path.csv (true and estimated, once per second, with the final poses) and map_points.csv.
Result<MissionScore> scoreSimulatedMission(const app::VogdConfig& config, const std::filesystem::path& mission_dir,
                                           const std::filesystem::path& plot_dir = {});

// The score as `vog-eval --json` prints it.
JsonObject toJson(const MissionScore& score);

}  // namespace vog::eval
