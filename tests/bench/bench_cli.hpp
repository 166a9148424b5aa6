#pragma once
// What the vog-bench subcommands share: command-line parsing with CLI11, the API benches' secret.

#include "vog/geometry/sonar.hpp"
#include "vog/slam/mapping_pipeline.hpp"
#include "vog/slam/pose_graph.hpp"

#include <CLI/CLI.hpp>

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace vog::bench {

// The operator secret the API and daemon benches configure their server with and authenticate with.
inline constexpr const char* kOperatorSecret = "bench-operator-secret-0123";

// Parses the arguments after the subcommand name. Returns the exit code when parsing ends the run
// (--help, or an error CLI11 has printed), nullopt to go on. CLI11 takes a vector last-first.
inline std::optional<int> parseArgs(CLI::App& app, const std::vector<std::string>& args) {
  try {
    app.parse(std::vector<std::string>(args.rbegin(), args.rend()));
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return std::nullopt;
}

// --sparse-backend eigen|suitesparse: the pose graph's sparse Cholesky (PoseGraphConfig::sparse_backend).
inline void addSparseBackendOption(CLI::App& app, slam::SparseBackend& field, const std::string& description) {
  app.add_option("--sparse-backend", field, description)
      ->transform(CLI::CheckedTransformer(std::map<std::string, slam::SparseBackend>{
          {"eigen", slam::SparseBackend::kEigen}, {"suitesparse", slam::SparseBackend::kSuiteSparse}}));
}

// --graph-linear-solver cholesky|cg: each solver step (PoseGraphConfig::linear_solver).
inline void addLinearSolverOption(CLI::App& app, slam::LinearSolver& field, const std::string& description) {
  app.add_option("--graph-linear-solver", field, description)
      ->transform(CLI::CheckedTransformer(std::map<std::string, slam::LinearSolver>{
          {"cholesky", slam::LinearSolver::kSparseCholesky}, {"cg", slam::LinearSolver::kChainPreconditionedCg}}));
}

// The loop closer's acceptance and checks (--lc-*), shared by the benches that run a MappingPipeline.
inline void addLoopClosureOptions(CLI::App& app, slam::MappingPipelineConfig& mc) {
  slam::LoopCloserConfig& lc = mc.loop_closer;
  const auto degrees = [](double& field_rad) {
    return [&field_rad](double deg) { field_rad = geometry::deg2rad(deg); };
  };
  app.add_option("--lc-max-fitness", lc.acceptance.max_fitness_m2, "loop closures: ICP fitness bound, m^2");
  app.add_option("--lc-min-overlap", lc.min_overlap_fraction,
                 "loop closures: share of the source cloud with a correspondence at the result");
  app.add_option_function<double>("--lc-max-yaw-disagreement-deg", degrees(lc.max_yaw_disagreement_rad),
                                  "loop closures: largest yaw difference between a registration and its prior, deg");
  app.add_option_function<double>("--lc-max-heading-deg", degrees(lc.max_heading_difference_rad),
                                  "loop closures: viewing-direction gate, deg");
  app.add_option_function<double>(
      "--lc-max-normal-angle-deg", degrees(lc.point_to_plane.max_normal_angle_rad),
      "loop closures: largest angle between corresponding points' normals, deg (default 45; 180: no check)");
  app.add_option("--lc-normal-search-neighbours", lc.point_to_plane.normal_search_neighbours,
                 "loop closures: with the normals check, the nearest agreeing of this many nearest target points (1: "
                 "the nearest only)");
  app.add_option("--lc-noise-floor", lc.point_to_plane.normal_noise_floor,
                 "loop closures: take the information the normals' noise adds along a direction off it before the "
                 "well-conditioned rule (1/0)");
  app.add_option("--lc-odometry-yaw-sigmas", lc.odometry_yaw_sigmas,
                 "loop closures: largest difference between a registration's yaw and the odometry's, in standard "
                 "deviations of the heading drift between the two submaps and the registration's 0.5 deg (0: off)");
  app.add_option("--lc-probe-steps", lc.point_to_plane.probe_steps,
                 "loop closures: shifts per side of the unique-optimum probe (0: no probe, the default; 3 measured)");
  app.add_option("--lc-probe-min-cost-points", lc.point_to_plane.min_probe_cost_points,
                 "loop closures: correspondences' worth of cost every probe shift must add");
  app.add_option("--lc-max-revisits", lc.max_revisits,
                 "loop closures: register the candidates of at most this many revisits of the place, the oldest and "
                 "the newest (0: all)");
  app.add_option("--lc-max-registrations", lc.max_registrations,
                 "loop closures: at most this many registrations per new submap, the nearest candidates (0: all)")
      ->check(CLI::Range(0, 100'000));
  app.add_option(
      "--lc-consistency", mc.consistency_confidence,
      "loop closures: confidence of the consistency check before insertion (0: off, the default; 0.999 measured)");
  app.add_option("--lc-recheck", mc.consistency_recheck,
                 "loop closures: check every accepted closure again after each solve, switching the inconsistent "
                 "off (1/0; needs --lc-consistency)");
}

}  // namespace vog::bench
