// vog-bench candidates: the loop-closure candidate search for each new submap of a long survey, the
// linear gate (findLoopCandidatesOf, every earlier submap tested) against the CandidateIndex the mapping
// pipeline keeps, on the footprints of a lawnmower survey repeated over one area (the harbour box's
// 66 x 16 m: lanes 4 m apart, a submap every 3 m, each pass over the same lanes). After each new submap
// every earlier pose moves by centimetres (a whole-graph solve) and every 25th submap by decimetres (a
// closure that bends the trajectory), as the index is updated in the pipeline. Both searches must give
// the same candidates (checked for every submap); the figures are their median times over the submaps
// of a window ending at 150 and at the last submap.
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include "vog/slam/loop_candidates.hpp"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <random>
#include <vector>

namespace {

using vog::geometry::Pose3;
using vog::slam::SubmapFootprint;

// Submap k of the survey: lanes along x, alternating direction, passes repeated over the same lanes.
SubmapFootprint surveyFootprint(std::int64_t k, std::mt19937_64& rng) {
  constexpr int kPerLane = 22, kLanes = 4;
  const int lane = static_cast<int>(k / kPerLane) % kLanes;
  const int along = static_cast<int>(k % kPerLane);
  const bool forward = (k / kPerLane) % 2 == 0;
  const double x = forward ? 3.0 * along : 63.0 - 3.0 * along;
  std::normal_distribution<double> jitter(0.0, 0.3);
  SubmapFootprint f;
  f.index = k;
  f.T_world_submap = vog::geometry::poseFromXyzRpy(x + jitter(rng), 4.0 * lane + jitter(rng), -2.0, 0.0, 0.0,
                                                   forward ? 0.0 : std::numbers::pi);
  // The sonar's view to the side and ahead of the track over 3 m of it.
  f.aabb_min_submap = Eigen::Vector3d(-1.0, 0.5, -5.0);
  f.aabb_max_submap = Eigen::Vector3d(4.0, 9.0, 0.0);
  f.centroid_submap = Eigen::Vector3d(1.5 + jitter(rng), 4.5 + jitter(rng), -2.5);
  f.n_points = 2000;
  return f;
}

double medianOf(std::vector<double> v) { return v.empty() ? 0.0 : vog::bench::median(std::move(v)); }

}  // namespace

VOG_BENCH_COMMAND(candidates, "loop-closure candidate search per new submap: linear gate vs CandidateIndex") {
  CLI::App app{"vog-bench candidates"};
  int n = 1000;
  int window = 50;
  std::uint64_t seed = 1;
  bool json = false;
  app.add_option("--submaps", n, "submaps of the survey")->check(CLI::Range(160, 1'000'000));
  app.add_option("--window", window, "submaps in each median's window")->check(CLI::Range(1, 150));
  app.add_option("--seed", seed, "random seed of the footprints and moves");
  app.add_flag("--json", json, "print JSON (the only output format)");
  if (auto exit = vog::bench::parseArgs(app, args)) return *exit;

  vog::slam::CandidateConfig gate;
  auto index = vog::slam::CandidateIndex::create(gate);
  if (!index) {
    std::fprintf(stderr, "candidates: %s\n", index.error().message.c_str());
    return 1;
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<SubmapFootprint> all;
  std::vector<double> linear_us, index_us, update_us, found;
  const auto us_since = [](std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  };
  for (std::int64_t k = 0; k < n; ++k) {
    const SubmapFootprint newest = surveyFootprint(k, rng);
    all.push_back(newest);
    auto t0 = std::chrono::steady_clock::now();
    const auto expected = vog::slam::findLoopCandidatesOf(all, all.size() - 1, gate);
    linear_us.push_back(us_since(t0));
    all.pop_back();
    t0 = std::chrono::steady_clock::now();
    const auto mine = index->candidatesOf(newest);
    index_us.push_back(us_since(t0));
    if (!expected || !mine || *expected != *mine) {
      std::fprintf(stderr, "candidates: submap %lld: the index and the linear search differ\n",
                   static_cast<long long>(k));
      return 1;
    }
    found.push_back(static_cast<double>(mine->size()));
    // The solve after it moves every pose; what the pipeline then updates.
    const double scale = k % 25 == 24 ? 0.3 : 0.02;
    t0 = std::chrono::steady_clock::now();
    for (std::size_t j = 0; j < all.size(); ++j) {
      const Pose3 delta =
          vog::geometry::poseFromXyzRpy(scale * unit(rng), scale * unit(rng), 0.0, 0.0, 0.0, 0.05 * scale * unit(rng));
      all[j].T_world_submap = delta * all[j].T_world_submap;
      if (vog::Status s = index->setPose(j, all[j].T_world_submap); !s.ok()) {
        std::fprintf(stderr, "candidates: %s\n", s.error().message.c_str());
        return 1;
      }
    }
    if (vog::Status s = index->add(newest); !s.ok()) {
      std::fprintf(stderr, "candidates: %s\n", s.error().message.c_str());
      return 1;
    }
    update_us.push_back(us_since(t0));
    all.push_back(newest);
  }
  const auto windowed = [&](const std::vector<double>& v, int end) {
    return medianOf(std::vector<double>(v.begin() + (end - window), v.begin() + end));
  };
  vog::bench::JsonObject out;
  out.add("submaps", n);
  out.add("window", window);
  out.add("candidates_median_at_150", windowed(found, 150));
  out.add("candidates_median_at_end", windowed(found, n));
  out.add("linear_us_median_at_150", windowed(linear_us, 150));
  out.add("linear_us_median_at_end", windowed(linear_us, n));
  out.add("index_us_median_at_150", windowed(index_us, 150));
  out.add("index_us_median_at_end", windowed(index_us, n));
  out.add("index_update_us_median_at_150", windowed(update_us, 150));
  out.add("index_update_us_median_at_end", windowed(update_us, n));
  out.add("linear_growth", windowed(linear_us, n) / windowed(linear_us, 150));
  out.add("index_growth", windowed(index_us, n) / windowed(index_us, 150));
  out.add("linear_over_index_at_end", windowed(linear_us, n) / windowed(index_us, n));
  (void)json;
  std::cout << out.str() << "\n";
  return 0;
}
