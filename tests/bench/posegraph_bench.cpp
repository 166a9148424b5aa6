// vog-bench posegraph: optimise a public g2o pose graph and report g2o's chi2 before and after
// through vogd's PoseGraph (targets: M3500 chi2 137.9129509, intel chi2 45.00469581 within 0.01%,
// M3500 solve <= 300 ms).
#include "bench_registry.hpp"

#include "vog/slam/g2o.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

VOG_BENCH_COMMAND(posegraph, "g2o pose-graph optimisation (chi2, iterations, solve time)") {
  CLI::App app{"vog-bench posegraph"};
  std::string g2o_path;
  std::string init = "file";
  bool json = false;
  app.add_option("--g2o", g2o_path, "g2o file (VERTEX_SE2/EDGE_SE2 or VERTEX_SE3:QUAT/EDGE_SE3:QUAT)")->required();
  app.add_option("--init", init,
                 "initial estimate: file (the file's vertices; for a file without VERTEX lines, a spanning tree), "
                 "odom (composed consecutive edges), tree (composed along a breadth-first spanning tree from the "
                 "fixed vertex) or chordal (2D: headings, then positions, by linear least squares over all edges)")
      ->check(CLI::IsMember({"file", "odom", "tree", "chordal"}));
  app.add_flag("--json", json, "print JSON (the only output format)");
  try {
    std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 consumes from the back
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  std::ifstream in(g2o_path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "posegraph: cannot open %s\n", g2o_path.c_str());
    return 1;
  }
  std::stringstream buffer;
  buffer << in.rdbuf();
  auto graph = vog::slam::parseG2o(buffer.str());
  if (!graph) {
    std::fprintf(stderr, "posegraph: %s: %s\n", g2o_path.c_str(), graph.error().message.c_str());
    return 1;
  }
  if (init != "file") {
    auto initialised = init == "odom"   ? vog::slam::initializeFromOdometry(*graph)
                       : init == "tree" ? vog::slam::initializeFromSpanningTree(*graph)
                                        : vog::slam::initializeChordal(*graph);
    if (!initialised) {
      std::fprintf(stderr, "posegraph: %s\n", initialised.error().message.c_str());
      return 1;
    }
    graph = std::move(initialised);
  }
  auto result = vog::slam::optimizeG2o(*graph);
  if (!result) {
    std::fprintf(stderr, "posegraph: %s\n", result.error().message.c_str());
    return 1;
  }
  vog::bench::JsonObject out;
  out.add("file", g2o_path);
  out.add("init", init);
  out.add("n_vertices", static_cast<std::int64_t>(graph->numVertices()));
  out.add("n_edges", static_cast<std::int64_t>(graph->numEdges()));
  out.add("chi2_initial", result->chi2_initial);
  out.add("chi2_final", result->chi2_final);
  out.add("iterations", result->iterations);
  out.add("solve_ms", result->solve_ms);
  out.add("converged", std::string(result->converged ? "true" : "false"));
  out.add("linear_solver", result->linear_solver);
  std::cout << out.str() << "\n";
  return 0;
}
