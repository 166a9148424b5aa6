#pragma once
// What the vog-bench subcommands share: command-line parsing with CLI11, the API benches' secret.

#include <CLI/CLI.hpp>

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

}  // namespace vog::bench
