#pragma once
// Occupancy parameters shared by every grid of one VOG-Map (thesis Eq. 3.2-3.5). Defaults are OctoMap's
// (Hornung 2013) and the thesis's resolution (Table 4.2).

#include "vog/core/result.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace vog::map {

enum class Occupancy : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

const char* toString(Occupancy status);

inline double logOdds(double probability) { return std::log(probability / (1.0 - probability)); }

// The log-odds bounds of a GridConfig, computed once: clamping (Eq. 3.4) and classification of a
// known voxel (occupied when above the occupancy threshold, as OctoMap's isNodeOccupied).
struct LogOddsBounds {
  double min = 0.0;
  double max = 0.0;
  double occupied = 0.0;

  // std::min/max (single instructions, where fmin/fmax are library calls); NaN clamps to max as with fmin/fmax.
  double clamp(double l) const { return std::max(min, std::min(max, l)); }
  Occupancy classify(double l) const { return l > occupied ? Occupancy::kOccupied : Occupancy::kFree; }
};

struct GridConfig {
  double resolution_m = 0.095;  // thesis Table 4.2
  double prob_hit = 0.7;        // OctoMap default
  double prob_miss = 0.4;       // OctoMap default
  double clamp_min = 0.1192;    // OctoMap default clamping thresholds
  double clamp_max = 0.971;
  double occupancy_threshold = 0.5;  // occupied when P > threshold
  double max_range_m = 11.0;         // beams integrate up to here; thesis Table 4.2 sensor d_max
  // Downsampling of the cached occupied cloud (ICP input); 0 = the resolution. A profiling sonar sees
  // little of an object per submap, so registration needs every occupied voxel it has.
  double cloud_voxel_m = 0.0;
  int normal_neighbours = 10;  // neighbours for the PCA normal of each cloud point

  // Names the first bad key and value, or is ok.
  Status validate() const;

  double cloudVoxelM() const { return cloud_voxel_m > 0.0 ? cloud_voxel_m : resolution_m; }
  LogOddsBounds bounds() const { return {logOdds(clamp_min), logOdds(clamp_max), logOdds(occupancy_threshold)}; }
};

}  // namespace vog::map
