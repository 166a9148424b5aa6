#pragma once
// The mission's telemetry next to its journal: iterations.csv (one row per planning iteration) and
// merges.csv (one row per merge), with the columns of `vog-bench mission --out`, so
// scripts/plot-mission draws a vogd mission as it draws a bench run. Appended to across restarts.
//
// Lifecycle: open() in the mission folder; plan() from the planning thread, merge() from the main
// thread (each file has one writer).

#include "vog/core/result.hpp"
#include "vog/map/merge_worker.hpp"
#include "vog/plan/nbv_planner.hpp"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>

namespace vog::app {

class TelemetryFiles {
 public:
  static Result<std::unique_ptr<TelemetryFiles>> open(const std::filesystem::path& mission_dir);

  // A planning iteration at stamp_ns on a map of n_submaps that took `ms`. Planning thread.
  void plan(std::int64_t stamp_ns, std::size_t n_submaps, double ms, const plan::PlanResult& result);
  // A merge, seen at stamp_ns. Main thread.
  void merge(std::int64_t stamp_ns, const map::MergeRecord& record);

 private:
  TelemetryFiles() = default;
  std::ofstream plans_;     // planning thread
  int plan_iteration_ = 0;  // planning thread
  std::ofstream merges_;    // main thread
};

}  // namespace vog::app
