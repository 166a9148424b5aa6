#pragma once
// vog-bench subcommands register themselves: each lives in its own file and declares
//   VOG_BENCH_COMMAND(map, "VOG-Map merge and query benchmark") { ... return exit code; }
// with `args` (the arguments after the subcommand name) in scope.

#include "vog/eval/figures.hpp"

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace vog::bench {

using CommandFn = int (*)(const std::vector<std::string>& args);

struct Command {
  std::string help;
  CommandFn run = nullptr;
};

std::map<std::string, Command>& registry();

struct Registrar {
  Registrar(const char* name, const char* help, CommandFn fn) { registry()[name] = Command{help, fn}; }
};

// The figures' JSON, medians and percentiles (eval/).
using eval::JsonObject;
using eval::median;
using eval::percentile;

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace vog::bench

#define VOG_BENCH_COMMAND(name, help)                                                          \
  static int vogBench_##name(const std::vector<std::string>& args);                            \
  static const ::vog::bench::Registrar vogBenchRegistrar_##name(#name, help, vogBench_##name); \
  static int vogBench_##name(const std::vector<std::string>& args)
