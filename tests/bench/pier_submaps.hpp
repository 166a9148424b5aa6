#pragma once
// The benchmarks' standard map: submaps of the synthetic pier built along an orbit (radius 5.5 m,
// depth -2 m, ranges to 5.6 m), each from its own seeded scan noise, built in parallel.
#include "vog/map/vog_map.hpp"

#include <cstdint>
#include <vector>

namespace vog::bench {

std::vector<map::SubmapEntry> buildPierSubmaps(const map::GridConfig& config, int submaps, int scans_per_submap,
                                               int threads, std::uint64_t seed);

}  // namespace vog::bench
