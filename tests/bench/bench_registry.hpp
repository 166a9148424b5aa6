#pragma once
// vog-bench subcommands register themselves: each lives in its own file and declares
//   VOG_BENCH_COMMAND(map, "VOG-Map merge and query benchmark") { ... return exit code; }
// with `args` (the arguments after the subcommand name) in scope.

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

// Insertion-ordered flat JSON object of numbers and strings, printed on one line per key.
class JsonObject {
 public:
  void add(const std::string& key, double value);
  void add(const std::string& key, std::int64_t value);
  void add(const std::string& key, int value) { add(key, static_cast<std::int64_t>(value)); }
  void add(const std::string& key, const std::string& value);
  std::string str() const;

 private:
  std::vector<std::pair<std::string, std::string>> fields_;
};

double median(std::vector<double> values);
double percentile(std::vector<double> values, double p);  // p in [0, 1]

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
