// vogsim: the simulator's command line.
//   vogsim render --scene S --out DIR     ground truth cloud (PLY), observable subset, top view (PNG)
//   vogsim survey --scene S --path lawnmower|orbit|file.yaml --seed N --out DIR
//   vogsim vehicle --scene S [--seed N] [--speedup X] ...   the vehicle behind mock devices
// Formats: sim/README.md.

#include "vehicle_command.hpp"
#include "vog/sim/paths.hpp"
#include "vog/sim/render.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/survey.hpp"
#include "vog/sim/world.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>

namespace {

using vog::sim::World;

std::unique_ptr<World> loadWorld(const std::string& scene_file) {
  auto scene = vog::sim::loadScene(scene_file);
  if (!scene) {
    spdlog::error("{}", scene.error().message);
    return nullptr;
  }
  auto world = World::create(*scene);
  if (!world) {
    spdlog::error("{}", world.error().message);
    return nullptr;
  }
  return std::move(world).value();
}

int runRender(const std::string& scene_file, const std::filesystem::path& out, double spacing_m, double px_per_m,
              bool observable, double viewpoint_spacing_m, double max_range_m) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto world = loadWorld(scene_file);
  if (!world) return 2;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) {
    spdlog::error("cannot create {}: {}", out.string(), ec.message());
    return 2;
  }
  const vog::geometry::PointCloud cloud = world->sampleSurface(spacing_m, 1);
  if (auto st = vog::sim::writePly(out / "ground_truth.ply", cloud); !st) {
    spdlog::error("{}", st.error().message);
    return 2;
  }
  spdlog::info("ground_truth.ply: {} points at {} m spacing", cloud.size(), spacing_m);
  if (auto st = vog::sim::writePng(out / "top_view.png", vog::sim::renderTopView(*world, cloud, px_per_m)); !st) {
    spdlog::error("{}", st.error().message);
    return 2;
  }
  spdlog::info("top_view.png written");
  if (observable) {
    vog::sim::ObservableConfig oc;
    oc.viewpoint_spacing_m = viewpoint_spacing_m;
    oc.max_range_m = max_range_m;
    auto obs = vog::sim::observablePoints(*world, cloud, oc);
    if (!obs) {
      spdlog::error("{}", obs.error().message);
      return 2;
    }
    if (auto st = vog::sim::writePly(out / "observable.ply", obs->points); !st) {
      spdlog::error("{}", st.error().message);
      return 2;
    }
    spdlog::info("observable.ply: {} of {} points observable from {} collision-free viewpoints", obs->points.size(),
                 cloud.size(), obs->n_viewpoints);
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  spdlog::info("render done in {:.2f} s", s);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vogsim: simulated world, vehicle and sensors for VOG"};
  app.require_subcommand(1);

  std::string scene_file;
  std::string out_dir;

  auto* render =
      app.add_subcommand("render", "Export the scene's ground-truth cloud (PLY), observable subset and top view (PNG)");
  double spacing_m = 0.05, px_per_m = 40.0, viewpoint_spacing_m = 0.5, max_range_m = 11.0;
  bool no_observable = false;
  render->add_option("--scene", scene_file, "Scene YAML file")->required()->check(CLI::ExistingFile);
  render->add_option("--out", out_dir, "Output directory")->required();
  render->add_option("--spacing", spacing_m, "Ground-truth point spacing, m")->check(CLI::Range(0.005, 10.0));
  render->add_option("--px-per-m", px_per_m, "Top view pixels per metre")->check(CLI::Range(1.0, 400.0));
  render->add_option("--viewpoint-spacing", viewpoint_spacing_m, "Observable set: vehicle position grid, m")
      ->check(CLI::Range(0.05, 10.0));
  render->add_option("--max-range", max_range_m, "Observable set: sonar maximum range, m")
      ->check(CLI::Range(0.1, 1000.0));
  render->add_flag("--no-observable", no_observable, "Skip the observable set");

  auto* survey = app.add_subcommand("survey", "Drive a scripted path and record every sensor stream and ground truth");
  std::string path_name = "lawnmower";
  std::string profile = "eq41";
  vog::sim::SurveyConfig sc;
  vog::sim::PathConfig pc;
  survey->add_option("--scene", scene_file, "Scene YAML file")->required()->check(CLI::ExistingFile);
  survey->add_option("--path", path_name, "lawnmower | orbit | waypoint YAML file")->required();
  survey->add_option("--seed", sc.seed, "Random seed")->required();
  survey->add_option("--out", out_dir, "Output directory")->required();
  survey->add_option("--noise-profile", profile, "Odometry noise: eq41 (thesis Eq. 4.1, literal) | random_walk");
  survey->add_option("--odom-rate", sc.odometry.rate_hz, "Odometry step (and simulation) rate, Hz");
  survey->add_option("--sonar-rate", sc.sonar_rate_hz, "Sonar scans per second");
  survey->add_option("--frame-every", sc.frame_every, "Record the intensity frame of every n-th scan (0 = none)");
  survey->add_option("--max-duration", sc.max_duration_s, "Simulated time limit, s");
  survey->add_option("--lane-spacing", pc.lane_spacing_m, "Lawnmower lane spacing, m");
  survey->add_option("--orbit-radius", pc.orbit_radius_m, "Orbit radius, m (0 = largest that fits)");
  survey->add_option("--margin", pc.margin_m, "Distance kept from the box sides, m");
  survey->add_option("--depth-z", pc.z_m, "z of lawnmower/orbit paths, m (default: start z)");

  vogsim::VehicleCommand vehicle(app);

  CLI11_PARSE(app, argc, argv);

  if (vehicle.parsed()) return vehicle.run();
  if (render->parsed()) {
    return runRender(scene_file, out_dir, spacing_m, px_per_m, !no_observable, viewpoint_spacing_m, max_range_m);
  }

  auto prof = vog::sim::parseOdometryNoiseProfile(profile);
  if (!prof) {
    spdlog::error("{}", prof.error().message);
    return 2;
  }
  sc.odometry.profile = *prof;
  const auto world = loadWorld(scene_file);
  if (!world) return 2;
  vog::Result<std::vector<vog::sim::Waypoint>> wps = vog::Error{"unset"};
  if (path_name == "lawnmower") {
    wps = vog::sim::lawnmowerPath(world->scene(), pc);
  } else if (path_name == "orbit") {
    wps = vog::sim::orbitPath(world->scene(), pc);
  } else {
    wps = vog::sim::loadWaypointFile(path_name);
  }
  if (!wps) {
    spdlog::error("{}", wps.error().message);
    return 2;
  }
  const auto t0 = std::chrono::steady_clock::now();
  auto sum = vog::sim::runSurvey(*world, *wps, sc, path_name, out_dir);
  if (!sum) {
    spdlog::error("{}", sum.error().message);
    return 2;
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  spdlog::info(
      "survey: {} scans, {} frames, {:.1f} s simulated in {:.2f} s, path {:.1f} m, {} waypoints reached, "
      "{} skipped, {} refused moves; written to {}",
      sum->n_scans, sum->n_frames, sum->duration_s, wall_s, sum->path_length_m, sum->waypoints_reached,
      sum->waypoints_skipped, sum->collisions_refused, out_dir);
  return 0;
}
