// vog-bench map: builds a synthetic VogMap (submaps of 100 sonar scans of 96 beams at 0.095 m on an
// orbit around a pier, ranges up to 5.6 m) and times merging and queries. Prints JSON.
#include "bench_cli.hpp"
#include "bench_registry.hpp"
#include "pier_submaps.hpp"
#include "synthetic_scene.hpp"

#include "vog/map/merge_worker.hpp"
#include "vog/map/merged_map.hpp"

#include <CLI/CLI.hpp>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <functional>
#include <filesystem>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <thread>

namespace {

using namespace vog;

struct MapBenchOptions {
  int submaps = 300;
  int scans = 100;
  int threads = 2;
  int merge_threads = 2;  // threads lent to the parallel merges (MergedMap::sync)
  std::uint64_t seed = 1;
  std::string out_dir;  // when set: the merged map (.bt, .ot) and the VogMap directory are written here
};

std::vector<map::SubmapEntry> buildSubmaps(const MapBenchOptions& opt, const map::GridConfig& config) {
  return vog::bench::buildPierSubmaps(config, opt.submaps, opt.scans, opt.threads, opt.seed);
}

// CPU seconds of the calling thread (a shared machine's wall clock also counts the other users' turns).
double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// A map operation the figures rely on: a failure ends the bench with its message (no figure of a
// merge that did not happen).
template <class R>
void orExit(const R& result) {
  if (result.ok()) return;
  std::fprintf(stderr, "vog-bench map: %s\n", result.error().message.c_str());
  std::exit(1);
}

template <class F>
double nsPerCall(int n, F&& f) {
  const bench::Stopwatch sw;
  for (int i = 0; i < n; ++i) f(i);
  return sw.seconds() * 1e9 / n;
}

}  // namespace

VOG_BENCH_COMMAND(map, "VOG-Map: build, merge from scratch, incremental add, partial re-merge, queries") {
  MapBenchOptions opt;
  bool json = false;
  CLI::App app{"vog-bench map"};
  app.add_option("--submaps", opt.submaps, "number of submaps")->check(CLI::Range(2, 5000));
  app.add_option("--scans", opt.scans, "scans per submap")->check(CLI::Range(1, 10000));
  app.add_option("--threads", opt.threads, "threads used to build the submaps (not timed)")->check(CLI::Range(1, 64));
  app.add_option("--merge-threads", opt.merge_threads, "threads of the parallel merge figures")
      ->check(CLI::Range(1, 64));
  app.add_option("--seed", opt.seed, "noise seed");
  app.add_flag("--json", json, "print JSON (the only output format)");
  app.add_option("--out", opt.out_dir, "write merged.bt, merged.ot and the VogMap (vogmap/) to this directory");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;

  const map::GridConfig config;  // resolution 0.095 m
  const bench::Stopwatch build_clock;
  const auto entries = buildSubmaps(opt, config);
  const double build_s = build_clock.seconds();
  std::fprintf(stderr, "built %d submaps in %.1f s\n", opt.submaps, build_s);

  auto vog = map::VogMap::create(config).value();
  for (const auto& e : entries) orExit(vog->addSubmap(e.id, e.grid, e.T_world_submap));
  std::size_t leaves = 0;
  for (const auto& e : entries) leaves += e.grid->leafCount();

  // Merge from scratch, one submap at a time (each add is the incremental step of a growing map).
  std::vector<double> scratch_s;
  std::vector<double> scratch_cpu_s;
  std::vector<double> add_ms;
  std::unique_ptr<map::MergedMap> merged;
  for (int rep = 0; rep < 3; ++rep) {
    merged = map::MergedMap::create(config).value();
    const double cpu0 = threadCpuSeconds();
    const bench::Stopwatch sw;
    for (const auto& e : entries) {
      const bench::Stopwatch one;
      orExit(merged->add(e));
      if (rep == 0) add_ms.push_back(one.seconds() * 1e3);
    }
    scratch_s.push_back(sw.seconds());
    scratch_cpu_s.push_back(threadCpuSeconds() - cpu0);
  }

  // Merge from scratch in one sync() with threads: the same voxels as the serial merge.
  const map::MergeThreads threads = map::spawnMergeThreads(opt.merge_threads);
  std::vector<double> scratch_parallel_s;
  std::vector<double> scratch_parallel_cpu_s;  // all threads: over scratch_parallel_s, the cores it got
  bool parallel_identical = true;
  for (int rep = 0; rep < 3; ++rep) {
    auto parallel = map::MergedMap::create(config).value();
    const bench::Stopwatch sw;
    const std::clock_t cpu0 = std::clock();
    orExit(parallel->sync(entries, map::MergeConfig{}, {}, threads));
    scratch_parallel_cpu_s.push_back(static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC);
    scratch_parallel_s.push_back(sw.seconds());
    parallel_identical = parallel_identical && parallel->sameVoxels(*merged);
  }

  // The same merge with its tasks run one after the other, each timed in CPU seconds: the sum over the
  // parallel calls of their longest task is the wall time the merge takes on otherwise idle cores (a
  // shared machine does not give both threads a core); compare with merge_scratch_cpu_s, the serial
  // merge's CPU time.
  double ideal_s = 0.0;
  double task_sum_s = 0.0;
  {
    map::MergeThreads timed;
    timed.tasks = opt.merge_threads;
    timed.run = [&](const std::function<void(int)>& task) {
      double longest_s = 0.0;
      for (int t = 0; t < timed.tasks; ++t) {
        const double cpu0 = threadCpuSeconds();
        task(t);
        const double cpu_s = threadCpuSeconds() - cpu0;
        longest_s = std::max(longest_s, cpu_s);
        task_sum_s += cpu_s;
      }
      ideal_s += longest_s;
    };
    auto parallel = map::MergedMap::create(config).value();
    orExit(parallel->sync(entries, map::MergeConfig{}, {}, timed));
    parallel_identical = parallel_identical && parallel->sameVoxels(*merged);
  }

  // Every submap moved (a loop closure that bends the whole map): serial, then with threads.
  std::vector<double> remerge_all_ms;
  std::vector<double> remerge_all_parallel_ms;
  {
    std::vector<geometry::Pose3> moved_poses = vog->poses();
    const auto moveAll = [&](double dx) {
      for (auto& T : moved_poses) T = geometry::poseFromXyzRpy(dx, 0.5 * dx, 0.0, 0.0, 0.0, 0.5 * dx) * T;
      orExit(vog->deform(moved_poses));
      return vog->entries();
    };
    for (int rep = 0; rep < 2; ++rep) {
      const auto current = moveAll(0.02);
      const bench::Stopwatch sw;
      orExit(merged->sync(current, map::MergeConfig{}));
      remerge_all_ms.push_back(sw.seconds() * 1e3);
    }
    auto reference = map::MergedMap::create(config).value();
    for (int rep = 0; rep < 2; ++rep) {
      const auto current = moveAll(-0.02);
      const bench::Stopwatch sw;
      orExit(merged->sync(current, map::MergeConfig{}, {}, threads));
      remerge_all_parallel_ms.push_back(sw.seconds() * 1e3);
      if (rep == 1) {
        for (const auto& e : current) orExit(reference->add(e));
        parallel_identical = parallel_identical && reference->sameVoxels(*merged);
      }
    }
  }

  // Partial re-merge: 10 of N submaps moved (a loop closure), the rest unchanged.
  std::mt19937_64 rng(opt.seed);
  std::vector<double> remerge_ms;
  std::vector<double> snapshot_ms;
  for (int rep = 0; rep < 7; ++rep) {
    auto poses = vog->poses();
    std::uniform_int_distribution<std::size_t> pick(0, poses.size() - 1);
    std::uniform_real_distribution<double> u(-0.1, 0.1);
    for (int k = 0; k < 10; ++k) {
      auto& T = poses[pick(rng)];
      T = geometry::poseFromXyzRpy(u(rng), u(rng), 0.2 * u(rng), 0.0, 0.0, 0.2 * u(rng)) * T;
    }
    orExit(vog->deform(poses));
    const auto current = vog->entries();
    const bench::Stopwatch sw;
    orExit(merged->sync(current, map::MergeConfig{}));
    remerge_ms.push_back(sw.seconds() * 1e3);
    const bench::Stopwatch snap;
    const auto s = merged->snapshot();
    snapshot_ms.push_back(snap.seconds() * 1e3);
  }

  // A loop closure late in a long survey: a third of the submaps moved by a few millimetres (5-10 mm,
  // up to 0.5 mrad of yaw), as the pose graph moves them when one closure is added.
  std::vector<double> remerge_third_ms;
  for (int rep = 0; rep < 3; ++rep) {
    auto poses = vog->poses();
    std::uniform_real_distribution<double> mm(0.005, 0.010);
    std::uniform_real_distribution<double> angle(0.0, 2.0 * M_PI);
    std::uniform_real_distribution<double> yaw(-0.0005, 0.0005);
    for (std::size_t k = static_cast<std::size_t>(rep); k < poses.size(); k += 3) {
      const double d = mm(rng);
      const double a = angle(rng);
      poses[k] = geometry::poseFromXyzRpy(d * std::cos(a), d * std::sin(a), 0.0, 0.0, 0.0, yaw(rng)) * poses[k];
    }
    orExit(vog->deform(poses));
    const auto current = vog->entries();
    const bench::Stopwatch sw;
    orExit(merged->sync(current, map::MergeConfig{}, {}, threads));
    remerge_third_ms.push_back(sw.seconds() * 1e3);
  }

  // Queries at random points of the mapped region, and 5 m rays.
  const auto snap = merged->snapshot();
  std::uniform_real_distribution<double> uxy(-8.0, 8.0);
  std::uniform_real_distribution<double> uz(-4.0, 0.0);
  std::vector<Eigen::Vector3d> points(200000);
  for (auto& p : points) p = {uxy(rng), uxy(rng), uz(rng)};
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rays(4000);
  for (auto& [a, b] : rays) {
    a = {uxy(rng), uxy(rng), uz(rng)};
    Eigen::Vector3d d(uxy(rng), uxy(rng), 0.3 * uz(rng));
    b = a + 5.0 * d.normalized();
  }
  double sink = 0.0;
  std::vector<double> merged_ns;
  std::vector<double> seq_ns;
  std::vector<double> line_merged_us;
  std::vector<double> line_vog_us;
  for (int rep = 0; rep < 5; ++rep) {
    merged_ns.push_back(nsPerCall(static_cast<int>(points.size()),
                                  [&](int i) { sink += snap->query(points[static_cast<std::size_t>(i)]).log_odds; }));
    seq_ns.push_back(nsPerCall(2000, [&](int i) { sink += vog->query(points[static_cast<std::size_t>(i)]).log_odds; }));
    line_merged_us.push_back(1e-3 * nsPerCall(static_cast<int>(rays.size()), [&](int i) {
                               const auto& [a, b] = rays[static_cast<std::size_t>(i)];
                               sink += static_cast<double>(snap->lineQuery(a, b).size());
                             }));
    line_vog_us.push_back(1e-3 * nsPerCall(200, [&](int i) {
                            const auto& [a, b] = rays[static_cast<std::size_t>(i)];
                            sink += static_cast<double>(vog->lineQuery(a, b).size());
                          }));
  }

  if (!opt.out_dir.empty()) {
    const std::filesystem::path dir(opt.out_dir);
    for (const auto& status :
         {snap->writeBt(dir / "merged.bt"), snap->writeOt(dir / "merged.ot"), vog->save(dir / "vogmap")}) {
      if (!status.ok()) {
        std::fprintf(stderr, "vog-bench map: %s\n", status.error().message.c_str());
        return 1;
      }
    }
  }

  bench::JsonObject out;
  out.add("n_submaps", opt.submaps);
  out.add("scans_per_submap", opt.scans);
  out.add("resolution_m", config.resolution_m);
  out.add("build_s", build_s);
  out.add("leaves_per_submap", static_cast<double>(leaves) / opt.submaps);
  out.add("known_voxels", static_cast<std::int64_t>(snap->knownVoxelCount()));
  out.add("merge_scratch_s", bench::median(scratch_s));
  out.add("merge_scratch_cpu_s", bench::median(scratch_cpu_s));
  out.add("merge_add_ms", bench::median(add_ms));
  out.add("merge_add_ms_p95", bench::percentile(add_ms, 0.95));
  out.add("merge_threads", opt.merge_threads);
  out.add("merge_scratch_parallel_s", bench::median(scratch_parallel_s));
  out.add("merge_scratch_parallel_cpu_s", bench::median(scratch_parallel_cpu_s));
  out.add("merge_scratch_parallel_ideal_s", ideal_s);
  out.add("merge_scratch_task_sum_s", task_sum_s);
  out.add("remerge_all_ms", bench::median(remerge_all_ms));
  out.add("remerge_all_parallel_ms", bench::median(remerge_all_parallel_ms));
  out.add("parallel_identical", std::string(parallel_identical ? "true" : "false"));
  out.add("remerge_k10_ms", bench::median(remerge_ms));
  out.add("remerge_third_small_parallel_ms", bench::median(remerge_third_ms));
  out.add("snapshot_ms", bench::median(snapshot_ms));
  out.add("point_query_merged_ns", bench::median(merged_ns));
  out.add("point_query_sequential_ns", bench::median(seq_ns));
  out.add("line_query_merged_us", bench::median(line_merged_us));
  out.add("line_query_vog_us", bench::median(line_vog_us));
  out.add("merged_bytes_per_voxel", static_cast<double>(snap->memoryBytes()) /
                                        static_cast<double>(std::max<std::size_t>(1, snap->knownVoxelCount())));
  out.add("checksum", sink);
  std::printf("%s\n", out.str().c_str());
  return 0;
}
