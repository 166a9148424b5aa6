// vog-bench persist: cost of mission persistence on the mapping thread. Runs the mapping
// pipeline over the drifting synthetic orbit of the slam tests with a MissionStore attached and reports
// the time to persist one closed submap (its .ot written atomically + the journal group fsync'ed), the
// journal and .ot sizes, the time to reopen the mission and restore the pipeline, and the latency of a
// single waypoint append + fsync. Uses a fresh directory under the system temp dir unless --dir is given.
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include "../unit/slam/pipeline_fixture.hpp"
#include "vog/mission/mission_store.hpp"
#include "vog/slam/mapping_pipeline.hpp"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iostream>

VOG_BENCH_COMMAND(persist, "mission persistence: submap group persist time, journal size, reopen + restore time") {
  CLI::App app{"vog-bench persist"};
  int n_scans = 760;
  std::string dir_arg;
  app.add_option("--scans", n_scans, "scans of the synthetic orbit (two laps = 760)")->check(CLI::Range(50, 5000));
  app.add_option("--dir", dir_arg, "mission directory to create (must not exist); default: a temp dir, removed");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;
  namespace fs = std::filesystem;
  const bool temp = dir_arg.empty();
  const fs::path dir =
      temp ? fs::temp_directory_path() / ("vog-bench-persist-" + std::to_string(::getpid())) : fs::path(dir_arg);
  if (fs::exists(dir)) {
    std::fprintf(stderr, "persist: %s already exists\n", dir.c_str());
    return 1;
  }

  using namespace vog;
  slam::MappingPipelineConfig config;
  config.builder.grid.resolution_m = 0.1;
  config.builder.max_scans = 40;
  config.builder.odometry_cov_x_m2_per_s = 0.0003;
  config.builder.odometry_cov_y_m2_per_s = 0.0003;
  config.builder.odometry_cov_yaw_rad2_per_s = 1e-5;
  config.loop_closer.mode = slam::LoopClosureMode::kDegenerate;
  config.loop_closer.point_to_plane.max_correspondence_distance_m = 0.5;
  const auto run = slam::testing::makeRun(n_scans, 2, 0.0003, geometry::deg2rad(0.02), 42);

  bench::JsonObject out;
  std::vector<double> persist_ms;
  std::vector<double> waypoint_ms;
  {
    auto store = mission::MissionStore::open(dir, config.builder.grid);
    auto pipeline = slam::MappingPipeline::create(config);
    if (!store || !pipeline) {
      std::fprintf(stderr, "persist: %s\n", (!store ? store.error() : pipeline.error()).message.c_str());
      return 1;
    }
    for (std::size_t k = 0; k <= run.inputs.size(); ++k) {
      auto u = k < run.inputs.size() ? pipeline.value()->feed(run.inputs[k]) : pipeline.value()->finish();
      if (!u) {
        std::fprintf(stderr, "persist: mapping: %s\n", u.error().message.c_str());
        return 1;
      }
      if (!u->closed) continue;
      bench::Stopwatch sw;
      if (Status s = store.value()->onUpdate(*pipeline.value(), u.value()); !s.ok()) {
        std::fprintf(stderr, "persist: %s\n", s.error().message.c_str());
        return 1;
      }
      persist_ms.push_back(1e3 * sw.seconds());
    }
    for (int i = 0; i < 50; ++i) {
      bench::Stopwatch sw;
      if (!store.value()->onWaypoint({i, 1.0, 2.0, -3.0, 0.5}).ok() || !store.value()->sync().ok()) return 1;
      waypoint_ms.push_back(1e3 * sw.seconds());
    }
    out.add("submaps", static_cast<std::int64_t>(pipeline.value()->submaps().size()));
    out.add("closures", static_cast<std::int64_t>(pipeline.value()->closures().size()));
  }
  std::uintmax_t ot_bytes = 0;
  for (const auto& e : fs::directory_iterator(dir / "submaps")) ot_bytes += e.file_size();
  out.add("journal_bytes", static_cast<std::int64_t>(fs::file_size(dir / mission::MissionStore::kJournalFile)));
  out.add("ot_bytes_total", static_cast<std::int64_t>(ot_bytes));
  out.add("persist_submap_ms_median", bench::median(persist_ms));
  out.add("persist_submap_ms_max", bench::percentile(persist_ms, 1.0));
  out.add("waypoint_append_fsync_ms_median", bench::median(waypoint_ms));

  bench::Stopwatch sw;
  mission::MissionResume resume;
  auto reopened = mission::MissionStore::open(dir, config.builder.grid, &resume);
  if (!reopened) {
    std::fprintf(stderr, "persist: reopen: %s\n", reopened.error().message.c_str());
    return 1;
  }
  const double open_ms = 1e3 * sw.seconds();
  auto restored = slam::MappingPipeline::restore(config, resume.pipeline);
  if (!restored) {
    std::fprintf(stderr, "persist: restore: %s\n", restored.error().message.c_str());
    return 1;
  }
  out.add("reopen_ms", open_ms);
  out.add("reopen_and_restore_ms", 1e3 * sw.seconds());
  reopened.value().reset();
  if (temp) fs::remove_all(dir);
  std::cout << out.str() << "\n";
  return 0;
}
