#pragma once
// What the vog-bench subcommands share: command-line parsing with CLI11, the API benches' secret.

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

}  // namespace vog::bench
