// vog-bench mission: autonomous exploration in closed loop (thesis 4.4-4.5), in lockstep simulated time.
// The simulator drives the vehicle and its sensors; every sonar scan goes to the mapping side, and
// after every map change the submap set goes to the merge thread (MergeWorker, thesis 4.5.5). The loop
// itself is vogd's: an explore::ExplorationController stepped once per simulation step (the initial
// spin, next-best-view plans on the newest published snapshot whenever the vehicle reached its
// waypoints, revisits, obstructions, the way home and the ending). Lockstep determinism: the bench waits for the merge
// thread (waitIdle) only at fixed points of simulated time: right before the next submission, right before each
// planning call and before the final evaluation. So the snapshot the planner sees depends only on the seed, while
// merging overlaps with simulation and mapping in between (merge_wait_ms_p95 says how long the
// planning side still waited). Modes (thesis Table 4.3):
//   baseline  one global OcTree built at raw odometry, Bircher-style planner (unconstrained sampling,
//             gain at the end point of an edge only);
//   vog       VOG-Map of submaps at raw odometry, the sonar planner (constrained sampling, gain swept
//             along each edge), no loop closures;
//   vog-lc    the same with degeneracy-aware loop closures (the map deforms and re-merges) and active
//             loop closure (slam::RevisitPolicy: after a stretch without a closure to the older map
//             the planner sends the vehicle back to an old view, NbvPlanner::requestRevisit); it also
//             scores the same run's submaps at their raw odometry poses (rmse_same_run_odometry: the
//             thesis's Fig. 4.12(b), the run of (c) with its loop closures unused).
// With --same-run-global-tree, vog and vog-lc also fuse the run's scans into one global OcTree at raw
// odometry, as the baseline does, and score it (rmse_same_run_global_tree): the two fusions compared on
// one path and one drift. It is left out of wall_s but shares the cores with the merge thread, so the
// timing fields of such a run are not the mission's alone.
// All three use the planner's global search (PlannerConfig::global_search) so that "complete" means
// the same in every mode; --global-search 0 gives Bircher's local rule. Its map update (a finalized
// copy of the global tree per planning call) is the baseline's "merge".
// The odometry noise is drawn in the world frame (OdometryNoiseConfig::world_frame_xy_noise): the three
// modes of one seed meet the same drift over time, so they are compared on one draw of the noise.
// The planner works in the estimated (map) frame; a waypoint reaches the simulated vehicle through the
// current navigation error, as a real controller steering on its own estimate would follow it.
// The reconstruction scored in every mode is the final map's occupied voxels (the merged map; the
// baseline's global tree), the product vogd serves as its cloud: the modes differ in how they fuse
// scans, so the comparison is between what each one delivers. Coverage reads the same map.
// Outputs one JSON object, and with --out the per-iteration CSVs that scripts/plot-mission draws, plus
// collisions.csv (every refused move: true and estimated pose, the map's and the scene's clearance),
// closures.csv (every accepted loop closure and its error against the truth, as vog-bench slam judges
// it) and coverage_points.csv (the observable points and whether the final map covers them).
// Timing fields (wall_s, wall_total_s, realtime_factor, cpu_s, *_ms_*) vary from run to run; all
// others depend only on the seed. wall_s is the mission's: simulation, mapping, merging and planning,
// without the evaluation (the observable set, the reference grid at true poses, coverage), which
// wall_total_s includes.
// Long missions: --path lawnmower replaces the exploration by a scripted survey through the same loop
// (simulator, mapping, merge thread, lockstep synchronisation): lanes along x (sim::lawnmowerPath),
// repeated until the submap budget is spent, each pass the reverse of the one before, looking across
// the lanes (+y on even passes, -y on odd ones), at one third of the box's height below its top for
// passes 0-1, two thirds for passes 2-3, and so on; so the same lanes are seen again with the same
// heading every other pass, where loop closures come from. Waypoints are given in the map frame and
// reach the vehicle one by one through the current navigation error. The planner still plans on the
// newest snapshot every --plan-every-s of simulated time (measured; its waypoints are not followed).
// --report-every K with --series FILE writes one JSON line per K closed submaps: memory (VmRSS,
// VmHWM), mapping time per closed submap (and its phases: graph, search, optimize, commit, build),
// pose-graph optimisation, merges (all, and those right after
// an accepted loop closure), planning, and the real-time factor, each over the last K submaps.
// --evaluate 0 skips the evaluation (observable set, reference grid at true poses, coverage, RMSE,
// closures against the truth), so that memory and time are the mission's own.
// Run from the repository root (scene paths are relative to it) or pass --scene.
#include "bench_cli.hpp"
#include "bench_registry.hpp"
#include "vog/eval/closures.hpp"
#include "vog/eval/reconstruction.hpp"

#include "vog/explore/exploration_controller.hpp"
#include "vog/map/merge_worker.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/map/voxel_key.hpp"
#include "vog/plan/nbv_planner.hpp"
#include "vog/sim/lockstep.hpp"
#include "vog/sim/paths.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/world.hpp"
#include "vog/slam/mapping_pipeline.hpp"
#include "vog/slam/revisit_policy.hpp"

#include <CLI/CLI.hpp>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

namespace {

using vog::geometry::Pose3;
namespace map = vog::map;
namespace explore = vog::explore;
namespace plan = vog::plan;
namespace sim = vog::sim;
namespace slam = vog::slam;

enum class Mode { kBaseline, kVog, kVogLc };

// Sonar scans waiting for the mapping side, with the truth beside them.
struct PendingScan {
  slam::ScanInput input;
  Pose3 T_true;
};

class ScanQueue final : public sim::SimulationSink {
 public:
  void scan(std::uint32_t /*scan_index*/, const sim::SonarPing& ping, const Pose3& T_true,
            const Pose3& T_odom) override {
    PendingScan p;
    p.input.T_world_vehicle_odom = T_odom;
    const Eigen::Vector3d rpy = vog::geometry::rpyFromRotation(T_odom.linear());
    p.input.z_roll_pitch = Eigen::Vector3d(T_odom.translation().z(), rpy.x(), rpy.y());
    p.input.scan = ping.scan;
    p.T_true = T_true;
    if (record_truth) T_true_by_stamp[ping.scan.stamp_ns] = T_true;
    pending.push_back(std::move(p));
  }
  void truth(const sim::VehicleState& /*state*/, const Pose3& T_odom) override { T_odom_now = T_odom; }

  std::deque<PendingScan> pending;
  std::map<std::int64_t, Pose3> T_true_by_stamp;  // every scan's true pose (closures are judged by it)
  bool record_truth = true;                       // fill T_true_by_stamp (the evaluation's)
  Pose3 T_odom_now = Pose3::Identity();
};

Pose3 fromWaypoint(const Eigen::Vector3d& p, double yaw) {
  return vog::geometry::poseFromXyzRpy(p.x(), p.y(), p.z(), 0.0, 0.0, yaw);
}

// CPU time of the calling thread, s (the planner's own work, not the wait for a shared core).
double threadCpuS() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// CPU time of the whole process (all threads), s.
double processCpuS() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct IterationRow {
  int iteration = 0;
  double sim_s = 0.0;
  std::size_t n_submaps = 0;
  double plan_ms = 0.0;
  std::string status;
  double best_gain = 0.0;
  int tree_size = 0;
  double coverage = -1.0;     // computed every few iterations only
  double root_shift_m = 0.0;  // distance from the estimate to the tree's root (snapped to a safe voxel)
  bool global_goal = false;   // the planner's global search chose the goal
  int global_candidates = 0;
};

// A refused move: where the vehicle was and what the planner believed.
struct CollisionRow {
  double sim_s = 0.0;
  Pose3 T_true;
  Pose3 T_estimated;
  int plan_iteration = -1;  // the plan whose waypoints were being followed
  std::size_t closures = 0;
  bool estimate_safe = false;  // the estimate is a safe voxel of the planner's last grid
  // Nearest occupied voxel centre to the estimate in the planner's last map (map frame), and nearest
  // surface point to the true position (world): a map that agreed with the estimate would give about
  // the same clearance.
  double map_clearance_m = 0.0;
  double true_clearance_m = 0.0;
};

// Distance from p to the nearest occupied voxel centre of `snapshot` within reach_m (reach_m if none).
double nearestOccupiedM(const map::MergedMap& snapshot, const Eigen::Vector3d& p, double reach_m) {
  const double res = snapshot.resolution();
  const int n = static_cast<int>(std::ceil(reach_m / res));
  const map::VoxelKey c = map::pointToKey(p, 1.0 / res);
  double best = reach_m;
  for (int dz = -n; dz <= n; ++dz)
    for (int dy = -n; dy <= n; ++dy)
      for (int dx = -n; dx <= n; ++dx) {
        const map::VoxelKey k = c + map::VoxelKey(dx, dy, dz);
        const double d = (map::keyToCentre(k, res) - p).norm();
        if (d < best && snapshot.at(k).status == map::Occupancy::kOccupied) best = d;
      }
  return best;
}

struct MergeRow {
  double sim_s = 0.0;
  std::size_t n_submaps = 0;
  double merge_ms = 0.0;
  int remerged = 0;
  int deferred = 0;            // moves left to the set's next sync (MergeConfig::max_moves_per_sync)
  bool first_of_set = true;    // the first sync of its submitted set (the others finish deferred moves)
  bool after_closure = false;  // the set was submitted right after a loop closure was accepted
};

// The merges of the sets submitted right after a loop closure, from row `begin` on: each set's first
// sync (the submaps around the vehicle moved) and all its syncs together (the whole map moved).
struct MergesAfterClosure {
  std::vector<double> first_ms, whole_ms;
};
MergesAfterClosure mergesAfterClosure(const std::vector<MergeRow>& rows, std::size_t begin) {
  MergesAfterClosure m;
  for (std::size_t i = begin; i < rows.size(); ++i) {
    const MergeRow& r = rows[i];
    if (!r.after_closure) continue;
    if (r.first_of_set) {
      m.first_ms.push_back(r.merge_ms);
      m.whole_ms.push_back(r.merge_ms);
    } else if (!m.whole_ms.empty()) {
      m.whole_ms.back() += r.merge_ms;
    }
  }
  return m;
}

// A line of /proc/self/status in MB (VmRSS: resident now, VmHWM: its peak); NaN when absent.
double missionStatusMb(const std::string& key) {
  std::ifstream f("/proc/self/status");
  for (std::string line; std::getline(f, line);)
    if (line.rfind(key + ":", 0) == 0) return std::stod(line.substr(key.size() + 1)) / 1024.0;
  return std::nan("");
}

// A JsonObject on one line (a JSON Lines record).
std::string jsonLine(const vog::bench::JsonObject& object) {
  const std::string s = object.str();
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '\n') {
      out += s[i];
      continue;
    }
    while (i + 1 < s.size() && s[i + 1] == ' ') ++i;
    if (!out.empty() && out.back() == ',') out += ' ';
  }
  return out;
}

// Pass `pass` of the scripted survey (see the header comment), map frame: the lanes of
// sim::lawnmowerPath without its start pose, reversed on odd passes, looking across them.
vog::Result<std::vector<plan::Waypoint>> surveyPass(const sim::Scene& scene, sim::PathConfig lanes, int pass) {
  const double top_m = scene.bounds_world.max().z(), height_m = scene.bounds_world.sizes().z();
  lanes.z_m = top_m - height_m * ((pass / 2) % 2 == 0 ? 1.0 : 2.0) / 3.0;
  auto path = sim::lawnmowerPath(scene, lanes);
  if (!path) return path.error();
  std::vector<sim::Waypoint> w(path->begin() + 1, path->end());
  if (pass % 2 == 1) std::reverse(w.begin(), w.end());
  const double yaw_rad = (pass % 2 == 0 ? 0.5 : -0.5) * std::numbers::pi;
  std::vector<plan::Waypoint> out;
  for (const sim::Waypoint& p : w) out.push_back({p.xyz_world, yaw_rad});
  return out;
}

}  // namespace

VOG_BENCH_COMMAND(mission, "Closed-loop exploration in lockstep: coverage, RMSE, planning and merge times") {
  std::string scene_file = "config/scenes/propeller.yaml";
  std::string mode_name = "vog-lc";
  std::uint64_t seed = 1;
  int submap_budget = 156;  // thesis Table 4.2
  double sensor_range_m = vog::geometry::SonarFan{}.max_range_m;
  double scan_rate_hz = sim::LockstepConfig{}.sonar_rate_hz;
  double odometry_noise_scale = 0.25;  // the simulated odometry: a quarter of the thesis Eq. 4.1 rates
  double max_sim_s = 7200.0;
  int coverage_every = 10;
  std::string out_dir;
  bool json = false;
  bool obstruction_feedback = true;
  bool same_run_global_tree = false;
  bool evaluate = true;
  std::string path_name;  // empty: exploration
  sim::PathConfig lanes;
  double plan_every_s = 10.0;
  int report_every = 0;
  std::string series_file;
  slam::MappingPipelineConfig mc;   // library defaults; the options below override a few
  explore::ExplorationConfig loop;  // the same (vogd's loop); revisits with vog-lc only
  plan::PlannerConfig& pc = loop.planner;
  slam::RevisitConfig& revisit_config = loop.revisit;
  CLI::App app{"vog-bench mission"};
  app.add_option("--scene", scene_file, "scene YAML file");
  app.add_option("--mode", mode_name, "baseline | vog | vog-lc");
  app.add_option("--seed", seed, "simulation and planner seed");
  app.add_option("--submaps,--max-submaps", submap_budget, "submap budget (thesis Table 4.2: 156)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--max-sim-s", max_sim_s, "simulated time limit, s")->check(CLI::Range(1.0, 1e7));
  app.add_option("--coverage-every", coverage_every, "compute coverage every n planning iterations")
      ->check(CLI::Range(1, 100000));
  app.add_option("--out", out_dir, "directory for iterations.csv, merges.csv, path.csv, map_points.csv");
  app.add_option("--global-search", pc.global_search,
                 "planner's global search when the local tree finds no gain (1/0)");
  app.add_option("--global-min-gain", pc.global_min_gain, "planner: gain a global-search view needs to become a goal");
  app.add_option("--sensor-range", sensor_range_m,
                 "sonar maximum range d_max^sensor, m (thesis Table 4.2: 11; 4.4: 5.63)")
      ->check(CLI::Range(1.0, 50.0));
  app.add_option("--odometry-noise-scale", odometry_noise_scale,
                 "factor on the thesis Eq. 4.1 rates of the simulated odometry's random walk")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--scan-rate", scan_rate_hz, "sonar scans per second FPS_sensor (thesis Table 4.2: 5; 4.4: 10)")
      ->check(CLI::Range(0.5, 50.0));
  app.add_option("--planner-range", pc.planner_range_m, "planner: d_max^planner, m (thesis Table 4.2: 5; 4.4: 5.63)");
  app.add_option("--lambda", pc.lambda, "planner: gain discount per metre of path (thesis Table 4.2: 0.5; 4.4: 0)");
  app.add_option("--max-edge", pc.max_edge_m, "planner: RRT max edge length, m (thesis Table 4.2: 2; 4.4: 1)");
  app.add_option("--clearance", pc.clearance_m, "planner: clearance between the collision box and non-free space, m");
  app.add_option("--obstruction-feedback", obstruction_feedback,
                 "report a refused move to the planner, which backs the vehicle off the way it came (1/0)");
  app.add_option("--revisit-after-s", revisit_config.after_s,
                 "vog-lc: revisit an old view after this long without an anchoring closure, s (0: off)");
  app.add_option("--revisit-span-s", revisit_config.anchor_span_s,
                 "vog-lc: a closure anchors when its submaps started this far apart, s");
  vog::bench::addLoopClosureOptions(app, mc);
  app.add_option("--graph-function-tolerance", mc.graph.function_tolerance,
                 "mapping: the pose graph solver's relative cost change that ends it");
  app.add_option("--graph-max-iterations", mc.graph.max_iterations,
                 "mapping: at most this many Levenberg-Marquardt iterations per pose-graph solve")
      ->check(CLI::Range(1, 100'000));
  vog::bench::addSparseBackendOption(app, mc.graph.sparse_backend,
                                     "mapping: the pose graph's sparse Cholesky, eigen or suitesparse");
  vog::bench::addLinearSolverOption(
      app, mc.graph.linear_solver,
      "mapping: each pose-graph solver step, cholesky (exact) or cg (odometry-preconditioned)");
  app.add_option("--graph-attitude-from-absolute", mc.graph.attitude_from_absolute,
                 "mapping: hold each submap's depth and attitude at its absolute factor; solve x, y, yaw (1/0)");
  app.add_flag("--optimize-closed-loop-only", mc.optimize_closed_loop_only,
               "mapping: after a closure optimise only the loop it closes, not the whole pose graph");
  app.add_option("--local-optimization-nodes", mc.local_optimization_nodes,
                 "mapping: in a graph of more nodes, a solve frees only this many around the new submap (0: never)")
      ->check(CLI::Range(0, 1'000'000));
  app.add_option("--full-optimization-every", mc.full_optimization_every,
                 "mapping: with --local-optimization-nodes, solve the whole graph every this-many-th submap")
      ->check(CLI::Range(1, 1'000'000));
  app.add_flag("--same-run-global-tree", same_run_global_tree,
               "vog / vog-lc: also score the run's scans fused into one global tree at raw odometry");
  map::MergeConfig merge_config;
  app.add_option("--remerge-translation-m", merge_config.remerge_translation_m,
                 "merge: a submap is re-merged when its pose moved more than this since it was merged, m")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option_function<double>(
      "--remerge-rotation-deg", [&](double deg) { merge_config.remerge_rotation_rad = vog::geometry::deg2rad(deg); },
      "merge: ... or turned more than this, deg");
  app.add_option("--merge-max-moves", merge_config.max_moves_per_sync,
                 "merge: moved submaps re-merged per merge, nearest the newest submap first (0: all)")
      ->check(CLI::Range(0, 1'000'000));
  app.add_option("--path", path_name,
                 "lawnmower: a scripted survey, repeated until the submap budget is spent, instead of the exploration");
  app.add_option("--lane-spacing", lanes.lane_spacing_m, "--path lawnmower: distance between lanes, m")
      ->check(CLI::Range(0.1, 100.0));
  app.add_option("--lane-margin", lanes.margin_m, "--path lawnmower: lanes' distance from the box's sides, m")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("--plan-every-s", plan_every_s,
                 "--path lawnmower: plan on the newest snapshot this often (simulated s; timed, not followed)")
      ->check(CLI::Range(0.1, 1e6));
  app.add_option("--report-every", report_every, "write a --series row every K closed submaps (0: none)")
      ->check(CLI::Range(0, 100000));
  app.add_option("--series", series_file, "JSON Lines file for the --report-every rows");
  app.add_option("--evaluate", evaluate,
                 "score the run against the truth (observable set, reference grid, coverage, RMSE, closures) (1/0)");
  app.add_flag("--json", json, "print JSON (the only output format)");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;
  auto fail = [](const std::string& message) {
    std::cerr << "mission bench: " << message << "\n";
    return 1;
  };
  Mode mode;
  if (mode_name == "baseline") {
    mode = Mode::kBaseline;
  } else if (mode_name == "vog") {
    mode = Mode::kVog;
  } else if (mode_name == "vog-lc") {
    mode = Mode::kVogLc;
  } else {
    return fail("--mode must be baseline, vog or vog-lc, got '" + mode_name + "'");
  }
  if (same_run_global_tree && mode == Mode::kBaseline)
    return fail("--same-run-global-tree compares a VOG mode's map with one global tree; the baseline is that tree");
  if (same_run_global_tree && !evaluate) return fail("--same-run-global-tree is part of the evaluation (--evaluate 1)");
  if (!path_name.empty() && path_name != "lawnmower") return fail("--path must be lawnmower, got '" + path_name + "'");
  const bool scripted = !path_name.empty();
  if ((report_every > 0) != !series_file.empty()) return fail("--report-every and --series go together");
  if (report_every > 0 && mode == Mode::kBaseline)
    return fail("--report-every reports the mapping pipeline's submaps: vog or vog-lc");

  auto scene = sim::loadScene(scene_file);
  if (!scene) return fail(scene.error().message);
  auto world_r = sim::World::create(*scene);
  if (!world_r) return fail(world_r.error().message);
  const sim::World& world = **world_r;
  const vog::bench::Stopwatch total;

  // Ground truth for coverage: surface points observable from a collision-free position in the box.
  vog::geometry::SonarFan observing_fan;
  observing_fan.max_range_m = sensor_range_m;
  const sim::ObservableConfig oc = sim::ObservableConfig::ofFan(observing_fan);
  vog::geometry::PointCloud surface;
  std::optional<sim::ObservableResult> observable;
  if (evaluate) {
    surface = world.sampleSurface(0.05, seed);
    auto o = sim::observablePoints(world, world.sampleSurface(0.1, seed), oc);
    if (!o) return fail(o.error().message);
    observable = std::move(o).value();
  }

  // Simulation: thesis Eq. 4.1 rates as a random walk, by default at a quarter of them (as vog-bench slam).
  sim::LockstepConfig sc;
  sc.seed = seed;
  sc.frame_every = 0;
  sc.sonar_rate_hz = scan_rate_hz;
  sc.sonar.fan.max_range_m = sensor_range_m;
  sc.odometry.profile = sim::OdometryNoiseProfile::kRandomWalk;
  sc.odometry.sigma2_x_m2ps *= odometry_noise_scale;
  sc.odometry.sigma2_y_m2ps *= odometry_noise_scale;
  sc.odometry.sigma2_yaw_rad2ps *= odometry_noise_scale;
  sc.odometry.world_frame_xy_noise = true;
  auto sim_r = sim::LockstepSimulation::create(world, sc);
  if (!sim_r) return fail(sim_r.error().message);
  sim::LockstepSimulation& simulation = *sim_r;

  // Mapping: library defaults.
  mc.loop_closures = mode == Mode::kVogLc;
  mc.loop_closer.mode = slam::LoopClosureMode::kDegenerate;
  mc.builder.fan.max_range_m = sensor_range_m;
  auto pipeline_r = slam::MappingPipeline::create(mc);
  if (!pipeline_r) return fail(pipeline_r.error().message);
  slam::MappingPipeline& pipeline = **pipeline_r;
  const map::GridConfig& grid_config = mc.builder.grid;
  const vog::geometry::SonarFan& fan = mc.builder.fan;
  auto worker_r = map::MergeWorker::create(grid_config, merge_config);
  if (!worker_r) return fail(worker_r.error().message);
  map::MergeWorker& worker = **worker_r;
  // The snapshot published at the last synchronisation point (see the header comment).
  std::shared_ptr<const map::MergedMap> published;
  // Merge sequence -> simulated time of submission, and whether a loop closure preceded it.
  struct Submission {
    double sim_s = 0.0;
    bool after_closure = false;
  };
  std::map<std::uint64_t, Submission> submitted;
  std::uint64_t last_merged_sequence = 0;  // of the newest MergeRecord taken (sequences start at 1)
  // Baseline: one global grid in the world frame at raw odometry.
  auto global_r = map::LocalGrid::create(grid_config);
  if (!global_r) return fail(global_r.error().message);
  map::LocalGrid& global = **global_r;
  std::shared_ptr<const map::MergedMap> baseline_snapshot;
  std::size_t baseline_scans = 0;
  // Reference reconstruction: every scan at its true pose.
  auto truth_r = map::LocalGrid::create(grid_config);
  if (!truth_r) return fail(truth_r.error().message);
  map::LocalGrid& truth_grid = **truth_r;
  std::ofstream series;
  if (!series_file.empty()) {
    if (const auto dir = std::filesystem::path(series_file).parent_path(); !dir.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(dir, ec);
    }
    series.open(series_file);
    if (!series) return fail("cannot write " + series_file);
  }

  pc.box_min_world_m = scene->bounds_world.min();
  pc.box_max_world_m = scene->bounds_world.max();
  pc.seed = seed;
  pc.fan = fan;
  if (mode == Mode::kBaseline) {
    pc.constrained_sampling = false;
    pc.gain_along_edge = false;
  }
  loop.max_submaps = submap_budget;
  loop.revisits = mode == Mode::kVogLc;  // active loop closure
  auto controller_r = explore::ExplorationController::create(loop);
  if (!controller_r) return fail(controller_r.error().message);
  explore::ExplorationController& controller = *controller_r;
  // The scripted survey's planner: its plans are timed on the newest snapshot, never followed.
  std::unique_ptr<plan::NbvPlanner> survey_planner;
  if (scripted) {
    const Pose3& T_start = scene->T_world_start;
    auto p = plan::NbvPlanner::create(pc, {T_start.translation(), vog::geometry::yawOf(T_start.linear())});
    if (!p) return fail(p.error().message);
    survey_planner = std::move(p).value();
  }
  auto planner = [&]() -> const plan::NbvPlanner* { return scripted ? survey_planner.get() : controller.planner(); };

  std::vector<IterationRow> iterations;
  std::vector<CollisionRow> collision_rows;
  std::vector<MergeRow> merges;
  std::vector<double> plan_ms_all, plan_cpu_ms_all, merge_ms_all, merge_wait_ms_all;
  std::vector<std::pair<Pose3, Pose3>> path_samples;  // (true, estimated) once per second
  // The true base pose of every closed submap, from the scans fed since the last close.
  std::map<std::int64_t, Pose3> open_truth;  // stamp -> true pose
  std::map<std::int64_t, Pose3> base_truth;  // submap -> true pose of its base scan
  double evaluation_s = 0.0;                 // spent inside the mission loop on the evaluation (not the mission's time)
  // For the --series rows: feed() time per closed submap, and every optimisation's solve time.
  // feed() runs on this thread: its CPU time too (the wall time includes waiting for a shared core).
  std::vector<double> mapping_ms_per_submap, mapping_cpu_ms_per_submap, optimize_ms_all, optimize_iterations_all;
  double mapping_s_open = 0.0, mapping_cpu_s_open = 0.0;  // feed() time since the last closed submap
  // Per closed submap, where process() spent it (graph, search, optimize, commit) and the rest of
  // feed() (building the submap from its scans).
  std::map<std::string, std::vector<double>> mapping_phase_ms;  // phase name -> ms per closed submap
  bool series_row_due = false;                                  // a multiple of --report-every submaps was just closed
  ScanQueue queue;
  queue.record_truth = evaluate;
  auto simS = [&] { return 1e-9 * static_cast<double>(simulation.stampNs()); };
  auto nSubmaps = [&] {
    return mode == Mode::kBaseline ? baseline_scans / static_cast<std::size_t>(mc.builder.max_scans)
                                   : pipeline.submaps().size();
  };

  // The estimated pose: odometry since the newest submap's base, composed onto its optimised pose.
  auto estimatedPose = [&]() -> Pose3 {
    if (mode == Mode::kBaseline || pipeline.submaps().empty()) return queue.T_odom_now;
    const slam::SubmapRecord& r = pipeline.submaps().back();
    return r.T_world_base * r.T_world_base_odom.inverse() * queue.T_odom_now;
  };

  // Waits for the merge thread, publishes its snapshot to the planner and collects its timings.
  auto syncMerges = [&]() -> vog::Status {
    if (auto st = worker.waitIdle(); !st) return st;
    published = worker.snapshot();
    for (const map::MergeRecord& r : worker.takeRecords()) {
      merge_ms_all.push_back(r.merge_ms);
      const auto it = submitted.find(r.sequence);
      const Submission at = it == submitted.end() ? Submission{} : it->second;
      submitted.erase(submitted.begin(), it);  // the sets before it are done (or were replaced)
      const bool first = r.sequence != last_merged_sequence;
      merges.push_back(
          {at.sim_s, r.n_submaps, r.merge_ms, r.stats.remerged, r.stats.deferred, first, at.after_closure});
      last_merged_sequence = r.sequence;
    }
    return {};
  };

  vog::Status mapping_error;
  auto processScans = [&] {
    while (!queue.pending.empty()) {
      PendingScan p = std::move(queue.pending.front());
      queue.pending.pop_front();
      if (evaluate) {
        const vog::bench::Stopwatch reference_insert;
        const auto inserted = truth_grid.insertScan(p.T_true * fan.T_vehicle_sensor, fan, p.input.scan);
        evaluation_s += reference_insert.seconds();
        if (!inserted) {
          mapping_error = inserted;
          return;
        }
      }
      auto intoGlobalTree = [&] {
        return global.insertScan(p.input.T_world_vehicle_odom * fan.T_vehicle_sensor, fan, p.input.scan);
      };
      if (mode == Mode::kBaseline) {  // the baseline's map
        if (auto st = intoGlobalTree(); !st) {
          mapping_error = st;
          return;
        }
        ++baseline_scans;
        continue;
      }
      if (same_run_global_tree) {  // the same-run comparison (evaluation, outside the mission's time)
        const vog::bench::Stopwatch global_insert;
        if (auto st = intoGlobalTree(); !st) {
          mapping_error = st;
          return;
        }
        evaluation_s += global_insert.seconds();
      }
      open_truth.emplace(p.input.scan.stamp_ns, p.T_true);
      const vog::bench::Stopwatch feed_time;
      const double feed_cpu0 = threadCpuS();
      auto u = pipeline.feed(p.input);
      mapping_s_open += feed_time.seconds();
      mapping_cpu_s_open += threadCpuS() - feed_cpu0;
      if (!u) {
        mapping_error = u.error();
        return;
      }
      if (u->optimized) {
        optimize_ms_all.push_back(u->optimize.solve_ms);
        optimize_iterations_all.push_back(u->optimize.iterations);
      }
      if (u->closed_submap) {
        if (auto it = open_truth.find(u->closed->first_stamp_ns); it != open_truth.end())
          base_truth.emplace(*u->closed_submap, it->second);
        open_truth.erase(open_truth.begin(), open_truth.lower_bound(p.input.scan.stamp_ns));
        mapping_ms_per_submap.push_back(1e3 * mapping_s_open);
        const slam::MappingPhaseTimes& t = u->phase_times;
        const double process_ms = t.graph_ms + t.search_ms + t.optimize_ms + t.commit_ms;
        for (const auto& [name, ms] : {std::pair{"graph", t.graph_ms},
                                       {"search", t.search_ms},
                                       {"optimize", t.optimize_ms},
                                       {"commit", t.commit_ms},
                                       {"build", 1e3 * mapping_s_open - process_ms}})
          mapping_phase_ms[name].push_back(ms);
        mapping_cpu_ms_per_submap.push_back(1e3 * mapping_cpu_s_open);
        mapping_s_open = mapping_cpu_s_open = 0.0;
        if (report_every > 0 && pipeline.submaps().size() % static_cast<std::size_t>(report_every) == 0)
          series_row_due = true;
      }
      if (!u->closed_submap && u->moved.empty()) continue;
      if (auto st = syncMerges(); !st) {
        mapping_error = st;
        return;
      }
      submitted[worker.submit(pipeline.map().entries())] = {simS(), !u->closures.empty()};
    }
  };

  // The map the planner sees. Baseline: a finalized copy of the global grid (its cost is the
  // baseline's map update, counted as a merge).
  auto snapshot = [&]() -> vog::Result<std::shared_ptr<const map::MergedMap>> {
    if (mode != Mode::kBaseline) {
      // A fixed point in simulated time (the vehicle reached its waypoint): the merge submitted
      // since the last one has overlapped with the simulation; the wait is recorded.
      const vog::bench::Stopwatch w;
      if (auto st = syncMerges(); !st) return st.error();
      merge_wait_ms_all.push_back(1e3 * w.seconds());
      return published;  // null until the first submap is merged: the controller waits
    }
    const vog::bench::Stopwatch w;
    auto copy = map::LocalGrid::fromTree(grid_config, std::make_unique<octomap::OcTree>(global.tree()));
    if (!copy) return copy.error();
    auto m = map::MergedMap::create(grid_config);
    if (!m) return m.error();
    map::SubmapEntry e;
    e.id = 0;
    e.grid = std::shared_ptr<const map::LocalGrid>(std::move(copy).value());
    if (auto st = (*m)->add(e); !st) return st.error();
    const double ms = 1e3 * w.seconds();
    merge_ms_all.push_back(ms);
    merges.push_back({simS(), nSubmaps(), ms, 0, 0, true, false});
    baseline_snapshot = (*m)->snapshot();
    return baseline_snapshot;
  };

  // Sends planner waypoints (map frame) to the vehicle (true frame) through the current navigation error.
  auto sendWaypoints = [&](const std::vector<plan::Waypoint>& wps) -> vog::Status {
    const Pose3 T_correction = simulation.vehicle().state().T_world_vehicle() * estimatedPose().inverse();
    std::vector<sim::Waypoint> out;
    for (const plan::Waypoint& w : wps) {
      const Pose3 T = T_correction * fromWaypoint(w.p_world, w.yaw_rad);
      out.push_back({T.translation(), vog::geometry::yawOf(T.linear())});
    }
    return simulation.vehicle().setWaypoints(std::move(out));
  };

  // One planning iteration's figures (iterations.csv), from either loop.
  auto recordPlan = [&](const plan::PlanResult& r, double ms, double cpu_ms, const map::MergedMap* planned_on) {
    plan_cpu_ms_all.push_back(cpu_ms);
    plan_ms_all.push_back(ms);
    IterationRow row;
    row.iteration = static_cast<int>(iterations.size());
    row.sim_s = simS();
    row.n_submaps = nSubmaps();
    row.plan_ms = ms;
    row.status = plan::toString(r.status);
    row.best_gain = r.best_gain;
    row.tree_size = r.tree_size;
    row.global_goal = r.global_goal;
    row.global_candidates = r.global_candidates;
    if (const auto& tree = planner()->lastTree(); !tree.empty())
      row.root_shift_m = (tree.front().w.p_world - estimatedPose().translation()).norm();
    if (evaluate && planned_on != nullptr && row.iteration % coverage_every == 0) {
      const vog::bench::Stopwatch coverage_time;
      row.coverage = vog::eval::coverageOf(*planned_on, observable->points.points, 2 * grid_config.resolution_m);
      evaluation_s += coverage_time.seconds();
    }
    iterations.push_back(row);
  };

  const vog::bench::Stopwatch mission;
  // Where the previous --series row ended in each list, and when.
  struct SeriesMark {
    std::size_t mapping = 0, optimize = 0, merges = 0, plans = 0;
    double sim_s = 0.0, wall_s = 0.0, cpu_s = 0.0;
  };
  SeriesMark mark;
  // One --series row: the figures of the submaps closed since the previous row (see the header comment).
  auto writeSeriesRow = [&]() -> vog::Status {
    if (auto st = syncMerges(); !st) return st;  // a fixed point of simulated time: the row sees its merges
    const double sim_s = simS(), wall_s = mission.seconds() - evaluation_s, cpu_s = processCpuS();
    auto since = [](const std::vector<double>& v, std::size_t from) {
      return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(from), v.end());
    };
    const std::vector<double> mapping_ms = since(mapping_ms_per_submap, mark.mapping);
    const std::vector<double> optimize_ms = since(optimize_ms_all, mark.optimize);
    const std::vector<double> optimize_iterations = since(optimize_iterations_all, mark.optimize);
    const std::vector<double> mapping_cpu_ms = since(mapping_cpu_ms_per_submap, mark.mapping);
    const std::vector<double> plan_ms = since(plan_ms_all, mark.plans);
    const std::vector<double> plan_cpu_ms = since(plan_cpu_ms_all, mark.plans);
    std::vector<double> merge_ms;
    for (std::size_t i = mark.merges; i < merges.size(); ++i) merge_ms.push_back(merges[i].merge_ms);
    const MergesAfterClosure after_closure = mergesAfterClosure(merges, mark.merges);
    vog::bench::JsonObject row;
    row.add("submaps", static_cast<std::int64_t>(nSubmaps()));
    row.add("sim_s", sim_s);
    row.add("wall_s", wall_s);
    row.add("cpu_s", cpu_s);  // all threads: on a shared machine wall time includes waiting for a core
    row.add("rss_mb", missionStatusMb("VmRSS"));
    row.add("hwm_mb", missionStatusMb("VmHWM"));
    row.add("mapping_ms_median", vog::bench::median(mapping_ms));
    row.add("mapping_ms_max", vog::bench::percentile(mapping_ms, 1.0));
    row.add("mapping_cpu_ms_median", vog::bench::median(mapping_cpu_ms));
    for (const auto& [name, ms] : mapping_phase_ms)
      row.add("mapping_" + name + "_ms_median", vog::bench::median(since(ms, mark.mapping)));
    row.add("optimizations", static_cast<std::int64_t>(optimize_ms.size()));
    row.add("optimize_ms_median", vog::bench::median(optimize_ms));
    row.add("optimize_ms_max", vog::bench::percentile(optimize_ms, 1.0));
    row.add("optimize_iterations_median", vog::bench::median(optimize_iterations));
    row.add("closures", static_cast<std::int64_t>(pipeline.closures().size()));
    row.add("merges", static_cast<std::int64_t>(merge_ms.size()));
    row.add("merge_ms_p95", vog::bench::percentile(merge_ms, 0.95));
    row.add("merge_ms_max", vog::bench::percentile(merge_ms, 1.0));
    row.add("merges_after_closure", static_cast<std::int64_t>(after_closure.first_ms.size()));
    row.add("merge_after_closure_ms_p95", vog::bench::percentile(after_closure.first_ms, 0.95));
    row.add("merge_after_closure_ms_max", vog::bench::percentile(after_closure.first_ms, 1.0));
    row.add("merge_after_closure_whole_ms_p95", vog::bench::percentile(after_closure.whole_ms, 0.95));
    row.add("merge_after_closure_whole_ms_max", vog::bench::percentile(after_closure.whole_ms, 1.0));
    row.add("plans", static_cast<std::int64_t>(plan_ms.size()));
    row.add("plan_ms_p95", vog::bench::percentile(plan_ms, 0.95));
    row.add("plan_ms_max", vog::bench::percentile(plan_ms, 1.0));
    row.add("plan_cpu_ms_p95", vog::bench::percentile(plan_cpu_ms, 0.95));
    row.add("realtime_factor", (sim_s - mark.sim_s) / (wall_s - mark.wall_s));
    row.add("realtime_factor_total", sim_s / wall_s);
    row.add("realtime_factor_cpu", (sim_s - mark.sim_s) / (cpu_s - mark.cpu_s));
    series << jsonLine(row) << '\n' << std::flush;
    if (!series) return vog::Error{"error while writing " + series_file};
    mark = {
        mapping_ms_per_submap.size(), optimize_ms_all.size(), merges.size(), plan_ms_all.size(), sim_s, wall_s, cpu_s};
    return {};
  };

  simulation.start(queue);
  // vogd's loop (ExplorationController) from the scene's start, at simulated time 0; the estimate
  // is the truth there.
  if (!scripted) {
    if (auto st = controller.start(scene->T_world_start,
                                   vog::mission::Box{scene->bounds_world.min(), scene->bounds_world.max()},
                                   simulation.stampNs(), true);
        !st)
      return fail(st.error().message);
  }
  // The scripted survey: the waypoints of the current pass still to send (map frame).
  std::deque<plan::Waypoint> survey;
  int survey_passes = 0;
  std::int64_t next_plan_ns = 0;
  std::uint64_t plan_errors = 0;
  std::string last_plan_error;
  std::string end_reason = "budget";
  std::int64_t next_path_sample_ns = 0;
  std::uint64_t collisions = 0;
  std::vector<slam::ClosurePair> closure_pairs;  // pipeline.closures() as pairs, for revisits
  while (true) {
    const sim::StepResult step = simulation.step(queue);
    processScans();
    if (!mapping_error.ok()) return fail("mapping: " + mapping_error.error().message);
    if (series_row_due) {
      series_row_due = false;
      if (auto st = writeSeriesRow(); !st) return fail(st.error().message);
    }
    if (simulation.stampNs() >= next_path_sample_ns) {
      path_samples.emplace_back(simulation.vehicle().state().T_world_vehicle(), estimatedPose());
      next_path_sample_ns += 1'000'000'000;
    }
    explore::StepInput in;
    if (step.status == sim::MotionStatus::kBlocked) {
      const plan::TraversabilityGrid* g = planner() != nullptr ? planner()->traversability() : nullptr;
      CollisionRow c{simS(),
                     simulation.vehicle().state().T_world_vehicle(),
                     estimatedPose(),
                     static_cast<int>(iterations.size()) - 1,
                     pipeline.closures().size(),
                     g != nullptr && g->isSafe(estimatedPose().translation())};
      const auto& last_map = mode == Mode::kBaseline ? baseline_snapshot : published;
      if (last_map) c.map_clearance_m = nearestOccupiedM(*last_map, c.T_estimated.translation(), 2.0);
      c.true_clearance_m = evaluate ? 2.0 : std::nan("");
      for (const Eigen::Vector3d& q : surface.points)
        c.true_clearance_m = std::min(c.true_clearance_m, (q - c.T_true.translation()).norm());
      collision_rows.push_back(c);
      ++collisions;  // the planner sent the vehicle into the scene; it was stopped short
      // The vehicle reports where it was stopped and where it was going (its estimate, as the
      // daemon's sources do); the vehicle holds.
      if (const auto next = simulation.vehicle().nextWaypoint(); next && obstruction_feedback) {
        const Pose3 T_map_true = estimatedPose() * c.T_true.inverse();
        in.obstruction = explore::Obstruction{c.T_estimated.translation(), T_map_true * next->xyz_world};
      }
      if (auto st = simulation.vehicle().setWaypoints({}); !st) return fail(st.error().message);
    }
    if (simS() >= max_sim_s) {
      end_reason = "time_limit";
      break;
    }
    if (scripted) {
      if (nSubmaps() >= static_cast<std::size_t>(submap_budget)) break;  // "budget"
      if (simulation.stampNs() >= next_plan_ns) {
        next_plan_ns += static_cast<std::int64_t>(std::llround(plan_every_s * 1e9));
        auto snap = snapshot();
        if (!snap) return fail(snap.error().message);
        if (*snap) {
          const Pose3 T = estimatedPose();
          const vog::bench::Stopwatch w;
          const double cpu0 = threadCpuS();
          auto r = survey_planner->plan(*snap, {T.translation(), vog::geometry::yawOf(T.linear())});
          const double ms = 1e3 * w.seconds(), cpu_ms = 1e3 * (threadCpuS() - cpu0);
          if (r) {
            recordPlan(*r, ms, cpu_ms, snap->get());
          } else {  // e.g. the estimate left the box: counted, the survey goes on
            ++plan_errors;
            last_plan_error = r.error().message;
          }
        }
      }
      if (simulation.vehicle().waypointsLeft() == 0) {
        if (survey.empty()) {
          auto pass = surveyPass(*scene, lanes, survey_passes++);
          if (!pass) return fail(pass.error().message);
          survey.assign(pass->begin(), pass->end());
        }
        if (auto st = sendWaypoints({survey.front()}); !st) return fail(st.error().message);
        survey.pop_front();
      }
      continue;
    }
    in.stamp_ns = simulation.stampNs();
    in.T_world_vehicle = estimatedPose();
    in.vehicle_idle = simulation.vehicle().waypointsLeft() == 0;
    in.n_submaps = nSubmaps();
    // The map is fetched (merges synchronised, or the baseline's copy made) only when the step plans;
    // that time is the map update's, not the plan's.
    std::shared_ptr<const map::MergedMap> planned_on;
    double map_s = 0.0, map_cpu_s = 0.0;
    in.map = [&]() -> vog::Result<std::shared_ptr<const map::MergedMap>> {
      const vog::bench::Stopwatch fetch;
      const double cpu = threadCpuS();
      auto snap = snapshot();
      map_s += fetch.seconds();
      map_cpu_s += threadCpuS() - cpu;
      if (snap) planned_on = *snap;
      return snap;
    };
    if (mode == Mode::kVogLc && in.vehicle_idle) {
      if (closure_pairs.size() != pipeline.closures().size()) closure_pairs = slam::closurePairs(pipeline.closures());
      in.submaps = &pipeline.submaps();
      in.closures = &closure_pairs;
    }
    const vog::bench::Stopwatch w;
    const double cpu0 = threadCpuS();
    auto out = controller.step(in);
    const double ms = 1e3 * (w.seconds() - map_s);
    if (!out) return fail("exploration: " + out.error().message);
    if (out->plan) recordPlan(*out->plan, ms, 1e3 * (threadCpuS() - cpu0 - map_cpu_s), planned_on.get());
    if (controller.ending() != explore::Ending::kNone) {
      // The ending's word; with its reason when the vehicle did not come home.
      const bool home =
          controller.ending() == explore::Ending::kComplete || controller.ending() == explore::Ending::kBudget;
      end_reason = home ? explore::toString(controller.ending()) : controller.summary();
      break;
    }
    if (out->waypoints)
      if (auto st = sendWaypoints(*out->waypoints); !st) return fail(st.error().message);
  }
  // Final map and evaluation.
  if (mode != Mode::kBaseline) {
    auto u = pipeline.finish();
    if (!u) return fail(u.error().message);
    if (auto st = syncMerges(); !st) return fail(st.error().message);
    worker.submit(pipeline.map().entries());
    if (auto st = syncMerges(); !st) return fail(st.error().message);
  }
  auto final_snap = snapshot();
  if (!final_snap) return fail(final_snap.error().message);
  const double mission_wall_s = mission.seconds() - evaluation_s;
  // The reconstruction is the final map's occupied voxels in every mode: what vogd serves as its cloud.
  std::vector<Eigen::Vector3d> estimate;
  vog::eval::appendOccupiedCentres(**final_snap, estimate);
  // The evaluation against the truth (--evaluate 1).
  struct ClosureRow {
    const slam::LoopClosure* closure;
    vog::eval::ClosureError error;
    double correction_m;        // how far the registration moved the relative pose from its prior
    slam::Vector6d difference;  // registration - truth, (x, y, z, roll, pitch, yaw) in the older submap's frame
    double from_true_yaw_rad;   // the older submap's true heading in the world
  };
  std::vector<ClosureRow> closure_rows;
  std::int64_t closures_wrong = 0;               // of the closures switched on at the end
  std::int64_t closures_switched_off_wrong = 0;  // of those switched off (consistency re-check)
  std::optional<double> rmse, rmse_unaligned, rmse_same_run_odometry, rmse_same_run_global_tree, coverage,
      coverage_unaligned;
  std::vector<Eigen::Vector3d> observable_in_map;
  std::vector<bool> covered_flags;
  if (evaluate) {
    truth_grid.finalize();
    const vog::eval::ReferenceReconstruction reference(truth_grid);
    auto error = vog::eval::reconstructionError(estimate, reference);
    if (!error) return fail(error.error().message);
    rmse = error->rmse_m;
    rmse_unaligned = error->rmse_unaligned_m;
    // Thesis Fig. 4.12(b): the same run's submaps at their raw odometry poses, loop closures unused.
    if (mode == Mode::kVogLc) {
      auto odometry_map = map::MergedMap::create(grid_config);
      if (!odometry_map) return fail(odometry_map.error().message);
      const std::vector<map::SubmapEntry> entries = pipeline.map().entries();
      for (std::size_t k = 0; k < entries.size(); ++k) {
        map::SubmapEntry e = entries[k];
        e.T_world_submap = pipeline.submaps()[k].T_world_base_odom;
        e.T_submap_world = e.T_world_submap.inverse();
        if (auto st = (*odometry_map)->add(e); !st) return fail(st.error().message);
      }
      std::vector<Eigen::Vector3d> points;
      vog::eval::appendOccupiedCentres(**odometry_map, points);
      auto e = vog::eval::reconstructionError(points, reference);
      if (!e) return fail(e.error().message);
      rmse_same_run_odometry = e->rmse_m;
    }
    // The same run's scans in one global tree at raw odometry: the baseline's fusion on this run's path.
    if (mode != Mode::kBaseline && same_run_global_tree) {
      global.finalize();
      std::vector<Eigen::Vector3d> points;
      vog::eval::appendOccupiedCentres(global, Pose3::Identity(), points);
      auto e = vog::eval::reconstructionError(points, reference);
      if (!e) return fail(e.error().message);
      rmse_same_run_global_tree = e->rmse_m;
    }
    // Final coverage after the same rigid alignment as the RMSE (the map lives in the estimated frame):
    // the observable points are mapped into it.
    const Pose3 T_estimate_reference = error->T_reference_estimate.inverse();
    for (const Eigen::Vector3d& p : observable->points.points) observable_in_map.push_back(T_estimate_reference * p);
    // Every accepted closure against the truth (the true relative pose of the two base scans), as
    // vog-bench slam judges them: wrong when off by more than 0.2 m or 2 deg in what it asserts.
    for (const slam::LoopClosure& lc : pipeline.closures()) {
      auto trueBase = [&](std::int64_t index) {
        return queue.T_true_by_stamp.at(pipeline.submaps()[static_cast<std::size_t>(index)].first_stamp_ns);
      };
      const Pose3 T_true = trueBase(lc.from).inverse() * trueBase(lc.to);
      const vog::eval::ClosureError e = vog::eval::closureError(lc, T_true);
      (lc.active ? closures_wrong : closures_switched_off_wrong) += e.wrong ? 1 : 0;
      closure_rows.push_back({&lc, e, (lc.T_from_to.translation() - lc.T_from_to_prior.translation()).norm(),
                              slam::xyzRpyDifference(slam::toXyzRpy(lc.T_from_to), slam::toXyzRpy(T_true)),
                              geometry::yawOf(trueBase(lc.from).linear())});
    }
    coverage = vog::eval::coverageOf(**final_snap, observable_in_map, 2 * grid_config.resolution_m, &covered_flags);
    coverage_unaligned = vog::eval::coverageOf(**final_snap, observable->points.points, 2 * grid_config.resolution_m);
    if (!iterations.empty()) iterations.back().coverage = *coverage_unaligned;
  }

  if (!out_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    if (ec) return fail("cannot create " + out_dir + ": " + ec.message());
    std::ofstream it(std::filesystem::path(out_dir) / "iterations.csv");
    it << "iteration,sim_s,n_submaps,plan_ms,status,best_gain,tree_size,root_shift_m,global_goal,global_candidates,"
          "coverage\n";
    for (const IterationRow& r : iterations) {
      it << r.iteration << ',' << r.sim_s << ',' << r.n_submaps << ',' << r.plan_ms << ',' << r.status << ','
         << r.best_gain << ',' << r.tree_size << ',' << r.root_shift_m << ',' << (r.global_goal ? 1 : 0) << ','
         << r.global_candidates << ',';
      if (r.coverage >= 0.0) it << r.coverage;
      it << '\n';
    }
    std::ofstream co(std::filesystem::path(out_dir) / "collisions.csv");
    co << "sim_s,true_x_m,true_y_m,true_z_m,true_yaw_rad,est_x_m,est_y_m,est_z_m,est_yaw_rad,plan_iteration,closures,"
          "estimate_safe,map_clearance_m,true_clearance_m\n";
    for (const CollisionRow& r : collision_rows) {
      const Eigen::Vector3d a = r.T_true.translation(), b = r.T_estimated.translation();
      co << r.sim_s << ',' << a.x() << ',' << a.y() << ',' << a.z() << ',' << vog::geometry::yawOf(r.T_true.linear())
         << ',' << b.x() << ',' << b.y() << ',' << b.z() << ',' << vog::geometry::yawOf(r.T_estimated.linear()) << ','
         << r.plan_iteration << ',' << r.closures << ',' << (r.estimate_safe ? 1 : 0) << ',' << r.map_clearance_m << ','
         << r.true_clearance_m << '\n';
    }
    // Observable points (in the map frame, after the alignment) and whether the final map covers them;
    // the closures against the truth. Both are the evaluation's.
    std::ofstream cp, cl;
    if (evaluate) {
      cp.open(std::filesystem::path(out_dir) / "coverage_points.csv");
      cp << "x_m,y_m,z_m,covered\n";
      for (std::size_t i = 0; i < observable_in_map.size(); ++i) {
        const Eigen::Vector3d& p = observable_in_map[i];
        cp << p.x() << ',' << p.y() << ',' << p.z() << ',' << (covered_flags[i] ? 1 : 0) << '\n';
      }
      cl.open(std::filesystem::path(out_dir) / "closures.csv");
      // directions: the factor's rows over (x, y, yaw), '|' between rows; dx, dy, dyaw: the whole
      // registration's difference from the truth, asserted or not.
      cl << "from,to,rank,fitness_m2,correction_m,error_m,error_deg,wrong,directions,dx_m,dy_m,dyaw_deg,from_true_yaw_"
            "deg,active\n";
      for (const ClosureRow& r : closure_rows) {
        cl << r.closure->from << ',' << r.closure->to << ',' << r.closure->factor.rank() << ','
           << r.closure->icp.fitness_m2 << ',' << r.correction_m << ',' << r.error.translation_m << ','
           << r.error.rotation_rad * 180.0 / std::numbers::pi << ',' << (r.error.wrong ? 1 : 0) << ',';
        const Eigen::MatrixXd& V = r.closure->factor.V_u;
        for (Eigen::Index k = 0; k < V.rows(); ++k) {
          cl << (k > 0 ? "|" : "") << std::fixed << std::setprecision(3) << V(k, slam::kX) << ' ' << V(k, slam::kY)
             << ' ' << V(k, slam::kYaw) << std::defaultfloat << std::setprecision(6);
        }
        cl << ',' << r.difference(slam::kX) << ',' << r.difference(slam::kY) << ','
           << r.difference(slam::kYaw) * 180.0 / std::numbers::pi << ','
           << r.from_true_yaw_rad * 180.0 / std::numbers::pi << ',' << (r.closure->active ? 1 : 0) << '\n';
      }
    }
    std::ofstream mg(std::filesystem::path(out_dir) / "merges.csv");
    mg << "sim_s,n_submaps,merge_ms,remerged,deferred,first_of_set,after_closure\n";
    for (const MergeRow& r : merges)
      mg << r.sim_s << ',' << r.n_submaps << ',' << r.merge_ms << ',' << r.remerged << ',' << r.deferred << ','
         << (r.first_of_set ? 1 : 0) << ',' << (r.after_closure ? 1 : 0) << '\n';
    std::ofstream pa(std::filesystem::path(out_dir) / "path.csv");
    pa << "true_x_m,true_y_m,true_z_m,est_x_m,est_y_m,est_z_m\n";
    for (const auto& [T_true, T_est] : path_samples) {
      const Eigen::Vector3d a = T_true.translation(), b = T_est.translation();
      pa << a.x() << ',' << a.y() << ',' << a.z() << ',' << b.x() << ',' << b.y() << ',' << b.z() << '\n';
    }
    std::ofstream mp(std::filesystem::path(out_dir) / "map_points.csv");
    mp << "x_m,y_m,z_m\n";
    for (const Eigen::Vector3d& p : estimate) mp << p.x() << ',' << p.y() << ',' << p.z() << '\n';
    for (const std::ofstream* f : {&it, &mg, &pa, &mp, &co, &cp, &cl})
      if (!*f && (evaluate || (f != &cp && f != &cl))) return fail("error while writing the CSV files in " + out_dir);
  }

  const double path_m = simulation.pathLengthM();
  vog::bench::JsonObject out;
  out.add("scene", scene->name);
  out.add("mode", mode_name);
  out.add("seed", static_cast<std::int64_t>(seed));
  out.add("path", scripted ? path_name : "exploration");
  out.add("end", end_reason);
  if (evaluate) {
    out.add("coverage", *coverage);
    out.add("coverage_unaligned", *coverage_unaligned);
    out.add("rmse", *rmse);
    out.add("rmse_unaligned", *rmse_unaligned);
  }
  if (rmse_same_run_odometry) out.add("rmse_same_run_odometry", *rmse_same_run_odometry);
  if (rmse_same_run_global_tree) out.add("rmse_same_run_global_tree", *rmse_same_run_global_tree);
  out.add("path_m", path_m);
  out.add("n_submaps", static_cast<std::int64_t>(nSubmaps()));
  const auto active_closures = std::count_if(pipeline.closures().begin(), pipeline.closures().end(),
                                             [](const slam::LoopClosure& c) { return c.active; });
  out.add("closures", static_cast<std::int64_t>(active_closures));
  out.add("closures_switched_off", static_cast<std::int64_t>(pipeline.closures().size()) - active_closures);
  // Submap base poses against the truth (no alignment: both start at the true pose), final
  // estimates and raw odometry.
  {
    double se = 0.0, se_odom = 0.0;
    std::size_t n = 0;
    for (const slam::SubmapRecord& r : pipeline.submaps()) {
      const auto it = base_truth.find(r.index);
      if (it == base_truth.end()) continue;
      se += (r.T_world_base.translation() - it->second.translation()).squaredNorm();
      se_odom += (r.T_world_base_odom.translation() - it->second.translation()).squaredNorm();
      ++n;
    }
    if (n > 0) {
      out.add("base_pose_rmse_m", std::sqrt(se / static_cast<double>(n)));
      out.add("base_pose_rmse_odometry_m", std::sqrt(se_odom / static_cast<double>(n)));
    }
  }
  // Loop-closure attempts and why the others were rejected (the reasons of LoopCloser).
  const slam::LoopCloseStats& lc = pipeline.loopStats();
  if (evaluate) {
    out.add("closures_wrong", closures_wrong);
    out.add("closures_switched_off_wrong", closures_switched_off_wrong);
  }
  out.add("closures_tried", static_cast<std::int64_t>(lc.tried));
  out.add("closures_skipped_heading", static_cast<std::int64_t>(lc.skipped_heading));
  out.add("closures_skipped_budget", static_cast<std::int64_t>(lc.skipped_budget));
  out.add("closures_skipped_revisits", static_cast<std::int64_t>(lc.skipped_revisits));
  out.add("closure_directions_ambiguous", static_cast<std::int64_t>(lc.ambiguous_directions));
  std::string reasons;
  for (const auto& [reason, n] : lc.rejected_by_reason)
    reasons += (reasons.empty() ? "" : "; ") + reason + ": " + std::to_string(n);
  out.add("closures_rejected", reasons);
  out.add("sim_s", simS());
  out.add("wall_s", mission_wall_s);
  out.add("wall_total_s", total.seconds());
  out.add("realtime_factor", simS() / mission_wall_s);
  // With a shared machine the wall time includes waiting for a core: CPU time of all threads too.
  out.add("cpu_s", processCpuS());
  out.add("realtime_factor_cpu", simS() / processCpuS());
  out.add("plan_iterations", static_cast<std::int64_t>(plan_ms_all.size()));
  out.add(
      "plan_ms_mean", plan_ms_all.empty() ? 0.0 : [&] {
        double s = 0.0;
        for (double v : plan_ms_all) s += v;
        return s / static_cast<double>(plan_ms_all.size());
      }());
  out.add("plan_ms_p95", plan_ms_all.empty() ? 0.0 : vog::bench::percentile(plan_ms_all, 0.95));
  out.add("plan_ms_max", plan_ms_all.empty() ? 0.0 : vog::bench::percentile(plan_ms_all, 1.0));
  out.add("plan_cpu_ms_p95", plan_cpu_ms_all.empty() ? 0.0 : vog::bench::percentile(plan_cpu_ms_all, 0.95));
  out.add("plan_global_searches",
          static_cast<std::int64_t>(std::count_if(iterations.begin(), iterations.end(),
                                                  [](const IterationRow& r) { return r.global_candidates > 0; })));
  out.add("merge_ms_p95", merge_ms_all.empty() ? 0.0 : vog::bench::percentile(merge_ms_all, 0.95));
  const MergesAfterClosure after_closure = mergesAfterClosure(merges, 0);
  out.add("merge_after_closure_ms_p95",
          after_closure.first_ms.empty() ? 0.0 : vog::bench::percentile(after_closure.first_ms, 0.95));
  out.add("merge_after_closure_whole_ms_p95",
          after_closure.whole_ms.empty() ? 0.0 : vog::bench::percentile(after_closure.whole_ms, 0.95));
  out.add("merge_wait_ms_p95", merge_wait_ms_all.empty() ? 0.0 : vog::bench::percentile(merge_wait_ms_all, 0.95));
  out.add("collisions", static_cast<std::int64_t>(collisions));
  out.add("revisits", static_cast<std::int64_t>(controller.revisits()));
  if (scripted) {
    out.add("survey_passes", survey_passes);
    out.add("plan_errors", static_cast<std::int64_t>(plan_errors));
    if (!last_plan_error.empty()) out.add("last_plan_error", last_plan_error);
  }
  if (evaluate) out.add("observable_points", static_cast<std::int64_t>(observable->points.size()));
  out.add("rss_mb", missionStatusMb("VmRSS"));
  out.add("hwm_mb", missionStatusMb("VmHWM"));
  std::cout << out.str();
  return 0;
}
