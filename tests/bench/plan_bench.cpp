// vog-bench plan: next-best-view planning on a many-submap merged map. Builds the synthetic pier map
// as `vog-bench map` does (submaps of 100 sonar scans on an orbit, 0.095 m, ranges up to 5.6 m), then
// times the traversability grid (full build, incremental update after one more submap) and the
// sonar gain of one RRT edge, and runs the planner receding-horizon style: plan, move to the first
// waypoint, merge the next submap, plan again. Prints JSON.
#include "bench_cli.hpp"
#include "bench_registry.hpp"
#include "pier_submaps.hpp"
#include "synthetic_scene.hpp"

#include "vog/map/merged_map.hpp"
#include "vog/plan/nbv_planner.hpp"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <ctime>
#include <numbers>
#include <random>
#include <thread>

namespace {

using namespace vog;

struct PlanBenchOptions {
  int submaps = 156;  // thesis Table 4.2 budget
  int scans = 100;
  int threads = 2;
  int plans = 40;
  std::uint64_t seed = 1;
};

std::vector<map::SubmapEntry> buildSubmaps(const PlanBenchOptions& opt, const map::GridConfig& config) {
  return vog::bench::buildPierSubmaps(config, opt.submaps, opt.scans, opt.threads, opt.seed);
}

// CPU time of the calling thread: on a shared machine wall time also counts other processes' turns.
double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

VOG_BENCH_COMMAND(plan, "NBV planner: plan time on a many-submap map, traversability build/update, gain per edge") {
  PlanBenchOptions opt;
  bool json = false;
  CLI::App app{"vog-bench plan"};
  app.add_option("--submaps", opt.submaps, "number of submaps")->check(CLI::Range(25, 5000));
  app.add_option("--scans", opt.scans, "scans per submap")->check(CLI::Range(1, 10000));
  app.add_option("--threads", opt.threads, "threads used to build the submaps (not timed)")->check(CLI::Range(1, 64));
  app.add_option("--plans", opt.plans, "timed planning iterations")->check(CLI::Range(1, 100000));
  app.add_option("--seed", opt.seed, "noise and planner seed");
  app.add_flag("--json", json, "print JSON (the only output format)");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;

  const map::GridConfig grid_config;
  const bench::Stopwatch build_clock;
  const auto entries = buildSubmaps(opt, grid_config);
  std::fprintf(stderr, "built %d submaps in %.1f s\n", opt.submaps, build_clock.seconds());

  plan::PlannerConfig config;
  config.box_min_world_m = {-9.0, -9.0, -4.5};
  config.box_max_world_m = {9.0, 9.0, 0.0};
  config.seed = opt.seed;
  const Eigen::AlignedBox3d box(config.box_min_world_m, config.box_max_world_m);

  // The map as the merge thread grows it; the last `held` submaps arrive during the planning loop.
  const int held = std::min(20, opt.submaps / 5);
  auto writer = map::MergedMap::create(grid_config).value();
  for (int s = 0; s < opt.submaps - held; ++s) (void)writer->add(entries[static_cast<std::size_t>(s)]);

  // Traversability: full build, then incremental update after one more submap (vs rebuild).
  const plan::Footprint checked_box = plan::anyHeadingFootprint(config.collision_box_m, config.clearance_m);
  std::vector<double> build_ms;
  std::vector<double> update_ms;
  std::vector<double> rebuild_ms;
  std::vector<double> stale_blocks;
  std::vector<double> closure_update_ms;
  std::vector<double> closure_settle_ms;
  std::vector<double> closure_blocks_read;
  std::vector<double> closure_blocks_stale;
  {
    auto probe = map::MergedMap::create(grid_config).value();
    for (int s = 0; s < opt.submaps - held; ++s) (void)probe->add(entries[static_cast<std::size_t>(s)]);
    for (int rep = 0; rep < 5; ++rep) {
      const auto before = probe->snapshot();
      const bench::Stopwatch sw;
      auto grid = plan::TraversabilityGrid::build(*before, box, checked_box).value();
      build_ms.push_back(sw.seconds() * 1e3);
      (void)probe->add(entries[static_cast<std::size_t>(opt.submaps - held + rep)]);
      const auto after = probe->snapshot();
      const bench::Stopwatch su;
      const auto stats = grid.update(*after).value();
      update_ms.push_back(su.seconds() * 1e3);
      stale_blocks.push_back(stats.blocks_stale);
      const bench::Stopwatch sr;
      const auto scratch = plan::TraversabilityGrid::build(*after, box, checked_box).value();
      rebuild_ms.push_back(sr.seconds() * 1e3);
      if (!grid.sameFlags(scratch)) {
        std::fprintf(stderr, "vog-bench plan: incremental traversability differs from a rebuild\n");
        return 1;
      }
    }
    // After a loop closure: a whole-graph solve moves every submap a little (here by up to 3 cm and
    // 0.3 deg, drawn from the seed), every block is re-merged, and most statuses stay.
    std::vector<map::SubmapEntry> moved(entries.begin(), entries.begin() + (opt.submaps - held + 5));
    std::mt19937_64 rng(opt.seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int rep = 0; rep < 3; ++rep) {
      const auto before = probe->snapshot();
      auto grid = plan::TraversabilityGrid::build(*before, box, checked_box).value();
      for (map::SubmapEntry& e : moved) {
        e.T_world_submap = geometry::poseFromXyzRpy(0.03 * u(rng), 0.03 * u(rng), 0.01 * u(rng), 0.0, 0.0,
                                                    geometry::deg2rad(0.3) * u(rng)) *
                           e.T_world_submap;
        e.T_submap_world = e.T_world_submap.inverse();
      }
      if (auto s = probe->sync(moved, map::MergeConfig{}); !s) {
        std::fprintf(stderr, "vog-bench plan: %s\n", s.error().message.c_str());
        return 1;
      }
      const auto after = probe->snapshot();
      const bench::Stopwatch su;
      const auto stats = grid.update(*after).value();
      closure_update_ms.push_back(su.seconds() * 1e3);
      // The safe flags the closure made stale, all recomputed (a plan recomputes those it reads).
      const bench::Stopwatch ss;
      (void)grid.safeCount();
      closure_settle_ms.push_back(ss.seconds() * 1e3);
      closure_blocks_read.push_back(static_cast<double>(stats.blocks_read));
      closure_blocks_stale.push_back(static_cast<double>(stats.blocks_stale));
      if (!grid.sameFlags(plan::TraversabilityGrid::build(*after, box, checked_box).value())) {
        std::fprintf(stderr, "vog-bench plan: traversability after a closure differs from a rebuild\n");
        return 1;
      }
    }
  }

  // Start: the first point a few metres inside the orbit where the collision box is in known free space.
  const auto first = writer->snapshot();
  const auto grid0 = plan::TraversabilityGrid::build(*first, box, checked_box).value();
  plan::Waypoint start;
  bool found = false;
  for (int k = 0; k < 720 && !found; ++k) {
    const double a = k * std::numbers::pi / 180.0;
    for (double r = 2.0; r <= 6.0 && !found; r += 0.1) {
      for (double z = -1.5; z >= -3.0 && !found; z -= 0.1) {
        const Eigen::Vector3d p(r * std::cos(a), r * std::sin(a), z);
        if (grid0.isSafe(p)) {
          start = {p, geometry::wrapAngle(a + std::numbers::pi)};
          found = true;
        }
      }
    }
  }
  if (!found) {
    std::fprintf(stderr, "vog-bench plan: no known-free start pose in the map\n");
    return 1;
  }

  // Gain of one RRT edge (2 m, heading change up to 90 deg) from the start region.
  std::vector<double> gain_us;
  std::vector<double> gain_cached_us;
  double gain_sum = 0.0;
  long rays = 0;
  {
    auto gain = plan::SonarGain::create(config, grid_config.resolution_m).value();
    std::mt19937_64 rng(opt.seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < 50; ++i) {
      const plan::Waypoint a{start.p_world, start.yaw_rad + u(rng)};
      const plan::Waypoint b{a.p_world + 2.0 * Eigen::Vector3d(u(rng), u(rng), 0.0).normalized(),
                             a.yaw_rad + 0.5 * std::numbers::pi * u(rng)};
      const bench::Stopwatch sw;
      const double g = gain.segmentGain(*first, a, b);
      gain_us.push_back(sw.seconds() * 1e6);
      const bench::Stopwatch sc;
      const double g_cached = gain.segmentGain(*first, a, b, &grid0);
      gain_cached_us.push_back(sc.seconds() * 1e6);
      if (g != g_cached) {
        std::fprintf(stderr, "vog-bench plan: cached gain %f differs from the map walk's %f\n", g_cached, g);
        return 1;
      }
      gain_sum += g;
    }
    rays = gain.stats().rays / 100;
  }

  // Receding horizon: plan, move to the first waypoint, merge the next held-back submap, plan again.
  auto planner = plan::NbvPlanner::create(config, start).value();
  std::vector<double> plan_ms;
  std::vector<double> plan_cpu_ms;
  std::vector<double> tree_sizes;
  int n_explore = 0;
  int n_complete = 0;
  int n_nopath = 0;
  plan::Waypoint current = start;
  int next_submap = opt.submaps - held;
  const bench::Stopwatch first_clock;
  (void)planner->plan(first, current);  // builds the traversability grid once
  const double first_plan_ms = first_clock.seconds() * 1e3;
  for (int i = 0; i < opt.plans; ++i) {
    if (next_submap < opt.submaps) (void)writer->add(entries[static_cast<std::size_t>(next_submap++)]);
    const auto snap = writer->snapshot();
    const double cpu0 = threadCpuSeconds();
    const bench::Stopwatch sw;
    const auto r = planner->plan(snap, current);
    plan_ms.push_back(sw.seconds() * 1e3);
    plan_cpu_ms.push_back((threadCpuSeconds() - cpu0) * 1e3);
    if (!r.ok()) {
      std::fprintf(stderr, "vog-bench plan: %s\n", r.error().message.c_str());
      return 1;
    }
    tree_sizes.push_back(r->tree_size);
    switch (r->status) {
      case plan::PlanStatus::kExplore:
        ++n_explore;
        current = r->waypoints.front();
        break;
      case plan::PlanStatus::kComplete:
      case plan::PlanStatus::kNearHome: ++n_complete; break;
      case plan::PlanStatus::kNoPath: ++n_nopath; break;
    }
  }

  bench::JsonObject out;
  out.add("n_submaps", opt.submaps);
  out.add("scans_per_submap", opt.scans);
  out.add("known_voxels", static_cast<std::int64_t>(writer->knownVoxelCount()));
  out.add("traversability_build_ms", bench::median(build_ms));
  out.add("traversability_update_ms", bench::median(update_ms));
  out.add("traversability_update_ms_p95", bench::percentile(update_ms, 0.95));
  out.add("traversability_rebuild_ms", bench::median(rebuild_ms));
  out.add("traversability_update_blocks", bench::median(stale_blocks));
  out.add("traversability_update_after_closure_ms", bench::median(closure_update_ms));
  out.add("traversability_settle_all_after_closure_ms", bench::median(closure_settle_ms));
  out.add("traversability_update_after_closure_blocks_read", bench::median(closure_blocks_read));
  out.add("traversability_update_after_closure_blocks_stale", bench::median(closure_blocks_stale));
  out.add("gain_us_per_edge", bench::median(gain_us));
  out.add("gain_cached_us_per_edge", bench::median(gain_cached_us));
  out.add("gain_rays_per_edge", static_cast<std::int64_t>(rays));
  out.add("gain_mean_voxels", gain_sum / 50.0);
  out.add("first_plan_ms", first_plan_ms);
  out.add("plans", opt.plans);
  out.add("plan_ms", bench::median(plan_ms));
  out.add("plan_ms_p95", bench::percentile(plan_ms, 0.95));
  out.add("plan_ms_max", bench::percentile(plan_ms, 1.0));
  out.add("plan_cpu_ms", bench::median(plan_cpu_ms));
  out.add("plan_cpu_ms_p95", bench::percentile(plan_cpu_ms, 0.95));
  out.add("tree_size_median", bench::median(tree_sizes));
  out.add("n_explore", n_explore);
  out.add("n_complete", n_complete);
  out.add("n_no_path", n_nopath);
  std::printf("%s\n", out.str().c_str());
  return 0;
}
