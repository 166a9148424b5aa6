#pragma once
// Scripted survey trajectories for `vogsim survey`: waypoint lists in the world frame.

#include "vog/core/result.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/vehicle.hpp"

#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace vog::sim {

struct PathConfig {
  // Distance kept from the exploration box's sides (x, y) so the collision box stays inside it.
  double margin_m = 1.0;
  double lane_spacing_m = 2.0;  // lawnmower: distance between lanes
  double orbit_radius_m = 0.0;  // orbit: 0 = largest circle inside the box minus the margin
  int orbit_points = 36;        // orbit: waypoints per turn
  // z of the path (world frame); NaN = the start depth. Must lie inside the exploration box.
  double z_m = std::numeric_limits<double>::quiet_NaN();

  Status validate() const;
};

// Lanes along x at the path depth, alternating direction, heading along the lane (the vertical
// fan looks ahead); starts with the start pose.
Result<std::vector<Waypoint>> lawnmowerPath(const Scene& scene, const PathConfig& config);

// One full circle at the path depth around the box centre, heading to the centre (the fan sweeps
// the object in the middle); starts with the start pose.
Result<std::vector<Waypoint>> orbitPath(const Scene& scene, const PathConfig& config);

// A YAML file `waypoints: [{xyz: [x, y, z], yaw_deg: d}, ...]`; errors name file, line and key.
Result<std::vector<Waypoint>> loadWaypointFile(const std::filesystem::path& file);

}  // namespace vog::sim
