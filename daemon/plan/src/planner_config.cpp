#include "vog/plan/planner_config.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace vog::plan {

namespace {

std::string bad(const char* key, double value, const char* allowed) {
  std::ostringstream s;
  s << "plan." << key << " = " << value << " is out of range (allowed: " << allowed << ")";
  return s.str();
}

std::string badVector(const char* key, const Eigen::Vector3d& v, const char* allowed) {
  std::ostringstream s;
  s << "plan." << key << " = (" << v.x() << ", " << v.y() << ", " << v.z() << ") is out of range (allowed: " << allowed
    << ")";
  return s.str();
}

bool positiveFinite(double v) { return v > 0.0 && std::isfinite(v); }
bool nonNegativeFinite(double v) { return v >= 0.0 && std::isfinite(v); }

}  // namespace

Status PlannerConfig::validate() const {
  if (!box_min_world_m.allFinite()) return Error{badVector("box_min_world_m", box_min_world_m, "finite")};
  if (!box_max_world_m.allFinite()) return Error{badVector("box_max_world_m", box_max_world_m, "finite")};
  for (int i = 0; i < 3; ++i) {
    if (!(box_max_world_m[i] > box_min_world_m[i])) {
      std::ostringstream s;
      s << "plan.box_max_world_m = (" << box_max_world_m.transpose() << ") must exceed plan.box_min_world_m = ("
        << box_min_world_m.transpose() << ") on every axis: the exploration box has zero volume";
      return Error{s.str()};
    }
  }
  if (!collision_box_m.allFinite() || (collision_box_m.array() <= 0.0).any())
    return Error{badVector("collision_box_m", collision_box_m, "> 0 on every axis")};
  if (!nonNegativeFinite(clearance_m) || clearance_m > 5.0) return Error{bad("clearance_m", clearance_m, "[0, 5]")};
  if (!positiveFinite(planner_range_m)) return Error{bad("planner_range_m", planner_range_m, "> 0")};
  if (!nonNegativeFinite(lambda)) return Error{bad("lambda", lambda, ">= 0")};
  if (!nonNegativeFinite(root_tolerance_m)) return Error{bad("root_tolerance_m", root_tolerance_m, ">= 0")};
  if (!nonNegativeFinite(recovery_radius_m)) return Error{bad("recovery_radius_m", recovery_radius_m, ">= 0")};
  if (!nonNegativeFinite(assume_free_radius_m)) return Error{bad("assume_free_radius_m", assume_free_radius_m, ">= 0")};
  if (!positiveFinite(max_edge_m)) return Error{bad("max_edge_m", max_edge_m, "> 0")};
  if (n_max < 1 || n_max > 100000) return Error{bad("n_max", n_max, "[1, 100000]")};
  if (n_tol < n_max || n_tol > 100000) return Error{bad("n_tol", n_tol, "[n_max, 100000]")};
  if (max_samples < n_tol || max_samples > 10000000) return Error{bad("max_samples", max_samples, "[n_tol, 1e7]")};
  if (!(max_heading_change_rad > 0.0 && max_heading_change_rad <= std::numbers::pi))
    return Error{bad("max_heading_change_rad", max_heading_change_rad, "(0, pi]")};
  if (!positiveFinite(v_max_mps)) return Error{bad("v_max_mps", v_max_mps, "> 0")};
  if (!positiveFinite(yaw_rate_radps)) return Error{bad("yaw_rate_radps", yaw_rate_radps, "> 0")};
  if (!(xy_sample_share >= 0.0 && xy_sample_share <= 1.0))
    return Error{bad("xy_sample_share", xy_sample_share, "[0, 1]")};
  if (!nonNegativeFinite(gain_unknown)) return Error{bad("gain_unknown", gain_unknown, ">= 0")};
  if (!nonNegativeFinite(gain_free)) return Error{bad("gain_free", gain_free, ">= 0")};
  if (!nonNegativeFinite(gain_occupied)) return Error{bad("gain_occupied", gain_occupied, ">= 0")};
  if (!nonNegativeFinite(gain_threshold)) return Error{bad("gain_threshold", gain_threshold, ">= 0")};
  if (!positiveFinite(global_spacing_m)) return Error{bad("global_spacing_m", global_spacing_m, "> 0")};
  if (!nonNegativeFinite(obstruction_retreat_m) || obstruction_retreat_m > 5.0)
    return Error{bad("obstruction_retreat_m", obstruction_retreat_m, "[0, 5]")};
  if (!nonNegativeFinite(global_min_gain)) return Error{bad("global_min_gain", global_min_gain, ">= 0")};
  if (global_max_candidates < 1 || global_max_candidates > 1000000)
    return Error{bad("global_max_candidates", global_max_candidates, "[1, 1e6]")};
  if (Status s = fan.validate(); !s.ok()) return Error{"plan." + s.error().message};
  return {};
}

}  // namespace vog::plan
