#pragma once
// Command-line parsing of a vog-bench subcommand with CLI11.

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

namespace vog::bench {

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
