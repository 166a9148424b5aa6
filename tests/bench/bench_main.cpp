// vog-bench: benchmarks that print JSON. `vog-bench SUBCOMMAND --help` for each one's options.
#include "bench_registry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

namespace vog::bench {

std::map<std::string, Command>& registry() {
  static std::map<std::string, Command> commands;
  return commands;
}

}  // namespace vog::bench

int main(int argc, char** argv) {
  auto& commands = vog::bench::registry();
  const std::string name = argc > 1 ? argv[1] : "";
  const auto it = commands.find(name);
  if (it == commands.end()) {
    std::fprintf(stderr, "usage: vog-bench SUBCOMMAND [options]\nsubcommands:\n");
    for (const auto& [n, c] : commands) std::fprintf(stderr, "  %-12s %s\n", n.c_str(), c.help.c_str());
    return name.empty() || name == "--help" ? 0 : 2;
  }
  std::vector<std::string> args(argv + 2, argv + argc);
  return it->second.run(args);
}
