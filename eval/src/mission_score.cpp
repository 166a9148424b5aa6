#include "vog/eval/mission_score.hpp"

#include "vog/eval/figures.hpp"
#include "vog/eval/reconstruction.hpp"

#include "vog/app/scan_record.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/mission/mission_store.hpp"
#include "vog/mission/raw_log.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/world.hpp"
#include "vog/slam/mapping_pipeline.hpp"

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace vog::eval {

namespace fs = std::filesystem;
using geometry::Pose3;

namespace {

std::vector<std::vector<std::string>> readCsv(const fs::path& file) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    if (!line.empty() && line.back() == ',') cells.emplace_back();
    rows.push_back(std::move(cells));
  }
  return rows;
}

}  // namespace

Result<MissionScore> scoreSimulatedMission(const app::VogdConfig& config, const fs::path& mission_dir,
                                           const fs::path& plot_dir) {
  auto fail = [](const std::string& message) { return Error{"evaluate: " + message}; };
  if (config.source != app::Source::kSim) return fail("the mission must have run on the simulator (source: sim)");
  if (!fs::exists(mission_dir / mission::MissionStore::kJournalFile))
    return fail(mission_dir.string() + " holds no mission journal");
  const map::GridConfig& grid = config.mapping.builder.grid;
  const geometry::SonarFan& fan = config.mapping.builder.fan;

  // The final map: every committed submap at its final estimate.
  mission::MissionResume resume;
  auto store = mission::MissionStore::open(mission_dir, grid, &resume);
  if (!store) return fail(store.error().message);
  auto pipeline = slam::MappingPipeline::restore(config.mapping, resume.pipeline);
  if (!pipeline) return fail(pipeline.error().message);
  const auto entries = (*pipeline)->map().entries();
  const auto& records = (*pipeline)->submaps();

  // Ground truth: the raw log's scans at their true poses; the estimated path from the same scans.
  auto raw = mission::readRawLog(mission_dir / mission::MissionStore::kRawLogFile);
  if (!raw) return fail(raw.error().message);
  std::map<std::int64_t, Pose3> truth;
  std::vector<slam::ScanInput> scans;
  for (const mission::RawRecord& r : raw->records) {
    if (r.device_id == app::kSimTruthDeviceId) {
      auto t = app::decodeTruthRecord(r.bytes);
      if (!t) return fail(t.error().message);
      truth[t->stamp_ns] = t->T_world_vehicle;
    } else if (r.device_id == app::kSimScanDeviceId) {
      auto s = app::decodeScanRecord(r.bytes);
      if (!s) return fail(s.error().message);
      scans.push_back(std::move(s).value());
    }
  }
  if (truth.empty()) return fail("the raw log holds no truth records");
  auto truth_r = map::LocalGrid::create(grid);
  if (!truth_r) return fail(truth_r.error().message);
  map::LocalGrid& truth_grid = **truth_r;
  std::vector<std::pair<Pose3, Pose3>> path;  // (true, estimated), once per second
  std::int64_t next_sample_ns = 0;
  std::size_t submap = 0;
  double path_m = 0.0;
  std::optional<Eigen::Vector3d> last_true;
  for (const slam::ScanInput& s : scans) {
    const auto t = truth.find(s.scan.stamp_ns);
    if (t == truth.end()) continue;
    if (auto st = truth_grid.insertScan(t->second * fan.T_vehicle_sensor, fan, s.scan); !st)
      return fail(st.error().message);
    if (last_true) path_m += (t->second.translation() - *last_true).norm();
    last_true = t->second.translation();
    while (submap + 1 < records.size() && s.scan.stamp_ns > records[submap].last_stamp_ns) ++submap;
    if (!records.empty() && s.scan.stamp_ns >= next_sample_ns) {
      const slam::SubmapRecord& r = records[submap];
      path.emplace_back(t->second, r.T_world_base * r.T_world_base_odom.inverse() * s.T_world_vehicle_odom);
      next_sample_ns = s.scan.stamp_ns + 1'000'000'000;
    }
  }
  truth_grid.finalize();
  const ReferenceReconstruction reference(truth_grid);
  // The final map, with a snapshot after every 10th submap for the coverage over time (snapshots
  // share blocks copy-on-write).
  auto merged = map::MergedMap::create(grid);
  if (!merged) return fail(merged.error().message);
  std::map<std::size_t, std::shared_ptr<const map::MergedMap>> snapshot_at;  // n_submaps -> map
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (auto st = (*merged)->add(entries[i]); !st) return fail(st.error().message);
    if ((i + 1) % 10 == 0 || i + 1 == entries.size()) snapshot_at[i + 1] = (*merged)->snapshot();
  }
  // The reconstruction: the final map's occupied voxels (what vogd serves as its cloud).
  std::vector<Eigen::Vector3d> estimate;
  appendOccupiedCentres(**merged, estimate);
  auto error = reconstructionError(estimate, reference);
  if (!error) return fail(error.error().message);

  // Coverage of the observable surface, aligned as the RMSE, after every 10th submap and at the end.
  auto scene = sim::loadScene(config.sim.scene);
  if (!scene) return fail(scene.error().message);
  auto world = sim::World::create(*scene);
  if (!world) return fail(world.error().message);
  auto observable = sim::observablePoints(**world, (*world)->sampleSurface(0.1, config.sim.seed), {});
  if (!observable) return fail(observable.error().message);
  std::vector<Eigen::Vector3d> observable_in_map;
  for (const Eigen::Vector3d& p : observable->points.points)
    observable_in_map.push_back(error->T_reference_estimate.inverse() * p);
  std::map<std::size_t, double> coverage_at;  // n_submaps -> coverage
  for (const auto& [n, snapshot] : snapshot_at)
    coverage_at[n] = coverageOf(*snapshot, observable_in_map, 2 * grid.resolution_m);
  const double coverage = coverage_at.empty() ? 0.0 : coverage_at.rbegin()->second;
  const double coverage_unaligned = coverageOf(**merged, observable->points.points, 2 * grid.resolution_m);

  // vogd's own telemetry.
  auto iterations = readCsv(mission_dir / "iterations.csv");
  auto merges = readCsv(mission_dir / "merges.csv");
  std::vector<double> plan_ms, merge_ms;
  for (std::size_t i = 1; i < iterations.size(); ++i)
    if (iterations[i].size() >= 4) plan_ms.push_back(std::stod(iterations[i][3]));
  for (std::size_t i = 1; i < merges.size(); ++i)
    if (merges[i].size() >= 3) merge_ms.push_back(std::stod(merges[i][2]));

  if (!plot_dir.empty()) {
    std::error_code ec;
    fs::create_directories(plot_dir, ec);
    if (ec) return fail("cannot create " + plot_dir.string() + ": " + ec.message());
    std::ofstream it(plot_dir / "iterations.csv");
    std::size_t filled_up_to = 0;
    for (std::size_t i = 0; i < iterations.size(); ++i) {
      std::vector<std::string> row = iterations[i];
      if (i > 0 && row.size() >= 8) {
        const std::size_t n = static_cast<std::size_t>(std::stoul(row[2]));
        // The coverage of the first n submaps, on the first row that had them.
        for (const auto& [k, c] : coverage_at)
          if (k <= n && k > filled_up_to) {
            row[7] = std::to_string(c);
            filled_up_to = k;
          }
      }
      for (std::size_t c = 0; c < row.size(); ++c) it << (c ? "," : "") << row[c];
      it << '\n';
    }
    fs::copy_file(mission_dir / "merges.csv", plot_dir / "merges.csv", fs::copy_options::overwrite_existing, ec);
    std::ofstream pa(plot_dir / "path.csv");
    pa << "true_x_m,true_y_m,true_z_m,est_x_m,est_y_m,est_z_m\n";
    for (const auto& [T_true, T_est] : path) {
      const Eigen::Vector3d a = T_true.translation(), b = T_est.translation();
      pa << a.x() << ',' << a.y() << ',' << a.z() << ',' << b.x() << ',' << b.y() << ',' << b.z() << '\n';
    }
    std::ofstream mp(plot_dir / "map_points.csv");
    mp << "x_m,y_m,z_m\n";
    for (const Eigen::Vector3d& p : estimate) mp << p.x() << ',' << p.y() << ',' << p.z() << '\n';
    if (ec || !it || !pa || !mp) return fail("error while writing the CSV files in " + plot_dir.string());
  }

  MissionScore out;
  out.scene = scene->name;
  out.coverage = coverage;
  out.coverage_unaligned = coverage_unaligned;
  out.rmse_m = error->rmse_m;
  out.rmse_unaligned_m = error->rmse_unaligned_m;
  out.path_m = path_m;
  out.n_submaps = entries.size();
  out.n_closures = (*pipeline)->closures().size();
  out.sim_s = 1e-9 * static_cast<double>(scans.empty() ? 0 : scans.back().scan.stamp_ns - scans.front().scan.stamp_ns);
  out.plan_iterations = plan_ms.size();
  out.plan_ms_p50 = plan_ms.empty() ? 0.0 : median(plan_ms);
  out.plan_ms_p95 = plan_ms.empty() ? 0.0 : percentile(plan_ms, 0.95);
  out.plan_ms_max = plan_ms.empty() ? 0.0 : percentile(plan_ms, 1.0);
  out.merge_ms_p95 = merge_ms.empty() ? 0.0 : percentile(merge_ms, 0.95);
  out.observable_points = observable->points.size();
  return out;
}

JsonObject toJson(const MissionScore& score) {
  JsonObject out;
  out.add("scene", score.scene);
  out.add("coverage", score.coverage);
  out.add("coverage_unaligned", score.coverage_unaligned);
  out.add("rmse", score.rmse_m);
  out.add("rmse_unaligned", score.rmse_unaligned_m);
  out.add("path_m", score.path_m);
  out.add("n_submaps", static_cast<std::int64_t>(score.n_submaps));
  out.add("closures", static_cast<std::int64_t>(score.n_closures));
  out.add("sim_s", score.sim_s);
  out.add("plan_iterations", static_cast<std::int64_t>(score.plan_iterations));
  out.add("plan_ms_p50", score.plan_ms_p50);
  out.add("plan_ms_p95", score.plan_ms_p95);
  out.add("plan_ms_max", score.plan_ms_max);
  out.add("merge_ms_p95", score.merge_ms_p95);
  out.add("observable_points", static_cast<std::int64_t>(score.observable_points));
  return out;
}

}  // namespace vog::eval
