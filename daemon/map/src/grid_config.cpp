#include "vog/map/grid_config.hpp"

#include <string>

namespace vog::map {

const char* toString(Occupancy status) {
  switch (status) {
    case Occupancy::kFree: return "free";
    case Occupancy::kOccupied: return "occupied";
    case Occupancy::kUnknown: break;
  }
  return "unknown";
}

namespace {
bool inOpenUnit(double p) { return p > 0.0 && p < 1.0; }
std::string bad(const char* key, double value, const char* allowed) {
  return std::string("map.") + key + " = " + std::to_string(value) + " is out of range (allowed: " + allowed + ")";
}
}  // namespace

Status GridConfig::validate() const {
  if (!(resolution_m > 0.0) || !std::isfinite(resolution_m)) return Error{bad("resolution_m", resolution_m, "> 0")};
  if (!inOpenUnit(prob_hit) || prob_hit <= 0.5) return Error{bad("prob_hit", prob_hit, "(0.5, 1)")};
  if (!inOpenUnit(prob_miss) || prob_miss >= 0.5) return Error{bad("prob_miss", prob_miss, "(0, 0.5)")};
  if (!inOpenUnit(clamp_min) || clamp_min >= 0.5) return Error{bad("clamp_min", clamp_min, "(0, 0.5)")};
  if (!inOpenUnit(clamp_max) || clamp_max <= 0.5) return Error{bad("clamp_max", clamp_max, "(0.5, 1)")};
  if (!(occupancy_threshold > clamp_min && occupancy_threshold < clamp_max))
    return Error{bad("occupancy_threshold", occupancy_threshold, "(clamp_min, clamp_max)")};
  if (!(max_range_m > 0.0) || !std::isfinite(max_range_m)) return Error{bad("max_range_m", max_range_m, "> 0")};
  if (!(cloud_voxel_m == 0.0 || cloud_voxel_m >= resolution_m) || !std::isfinite(cloud_voxel_m))
    return Error{bad("cloud_voxel_m", cloud_voxel_m, "0 (= resolution_m) or >= resolution_m")};
  if (normal_neighbours < 3 || normal_neighbours > 100)
    return Error{bad("normal_neighbours", normal_neighbours, "[3, 100]")};
  // OctoMap addresses +-32768 voxels per axis; a ray must fit comfortably inside.
  if (max_range_m / resolution_m > 16000.0) return Error{bad("max_range_m", max_range_m, "< 16000 x resolution_m")};
  return {};
}

}  // namespace vog::map
