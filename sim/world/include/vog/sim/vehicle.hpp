#pragma once
// HAUV kinematics (thesis 4.1, 4.4.1): holonomic in x, y, z and yaw, no roll or pitch, speed and
// yaw-rate limits from thesis Table 4.2. Follows a waypoint list; a move that would make the
// collision box touch the scene is refused and reported, so the vehicle never passes through.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/sim/world.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

namespace vog::sim {

struct VehicleConfig {
  double max_speed_mps = 0.25;                     // thesis Table 4.2, v_max
  double max_yaw_rate_radps = 0.15;                // thesis Table 4.2, psi
  Eigen::Vector3d collision_box_m{1.0, 1.0, 0.5};  // thesis Table 4.2 (full extents x, y, z)
  // A waypoint is reached exactly, unless a collision stops the vehicle within this distance and
  // heading error of it: then it counts as reached, not blocked.
  double position_tolerance_m = 0.02;
  double yaw_tolerance_rad = 0.01;
  // Longest translation between two collision checks. Smaller than every box extent, so the
  // checked boxes overlap and no surface can slip between two of them (the gaps between
  // consecutive boxes are at most this long).
  double max_check_step_m = 0.01;

  Status validate() const;
};

struct Waypoint {
  Eigen::Vector3d xyz_world = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
};

struct VehicleState {
  std::int64_t stamp_ns = 0;
  Eigen::Vector3d xyz_world = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
  Eigen::Vector3d velocity_world_mps = Eigen::Vector3d::Zero();  // over the last step
  double yaw_rate_radps = 0.0;                                   // over the last step

  geometry::Pose3 T_world_vehicle() const;
};

enum class MotionStatus {
  kIdle,     // no waypoint
  kMoving,   // following the front waypoint
  kReached,  // reached a waypoint during the last step (it was removed from the list)
  kBlocked,  // the last step was refused because it would collide; the vehicle did not move
};

const char* toString(MotionStatus status);

struct StepResult {
  MotionStatus status = MotionStatus::kIdle;
  int waypoints_reached = 0;
};

// Lifecycle: create() checks the start pose is collision-free; then setWaypoints()/step() in any
// order. Invariants: the collision box at the current pose never touches the scene; roll and pitch
// are zero; stamp_ns only grows. Borrows the World, which must outlive it.
class VehicleModel {
 public:
  static Result<VehicleModel> create(const World& world, const VehicleConfig& config,
                                     const Eigen::Vector3d& start_xyz_world, double start_yaw_rad,
                                     std::int64_t start_stamp_ns);

  // Replaces the waypoint list (clears a blocked state). Errors on non-finite waypoints.
  Status setWaypoints(std::vector<Waypoint> waypoints);
  // Drops the front waypoint (a caller's answer to kBlocked).
  void skipWaypoint();

  // Advances simulated time by dt_ns (> 0). Motion toward the front waypoint at up to the speed
  // and yaw-rate limits, in collision-checked sub-steps.
  StepResult step(std::int64_t dt_ns);

  const VehicleState& state() const { return state_; }
  const VehicleConfig& config() const { return config_; }
  std::size_t waypointsLeft() const { return waypoints_.size(); }
  // The waypoint being followed (the front of the list), if any.
  std::optional<Waypoint> nextWaypoint() const {
    return waypoints_.empty() ? std::nullopt : std::optional<Waypoint>(waypoints_.front());
  }
  bool blocked() const { return blocked_; }
  // Number of refused moves so far.
  std::uint64_t collisionCount() const { return collisions_; }
  // True when the collision box at this pose touches the scene.
  bool collidesAt(const Eigen::Vector3d& xyz_world, double yaw_rad) const;

 private:
  VehicleModel(const World& world, const VehicleConfig& config) : world_(&world), config_(config) {}

  const World* world_;
  VehicleConfig config_;
  VehicleState state_;
  std::deque<Waypoint> waypoints_;
  bool blocked_ = false;
  std::uint64_t collisions_ = 0;
};

}  // namespace vog::sim
