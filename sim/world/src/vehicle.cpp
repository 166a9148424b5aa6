#include "vog/sim/vehicle.hpp"

#include <algorithm>
#include <cmath>

namespace vog::sim {

Status VehicleConfig::validate() const {
  auto bad = [](const std::string& key, double v, const std::string& rule) {
    return Error{"vehicle." + key + " must be " + rule + ", got " + std::to_string(v)};
  };
  if (!(max_speed_mps > 0.0) || !std::isfinite(max_speed_mps))
    return bad("max_speed_mps", max_speed_mps, "finite and > 0");
  if (!(max_yaw_rate_radps > 0.0) || !std::isfinite(max_yaw_rate_radps))
    return bad("max_yaw_rate_radps", max_yaw_rate_radps, "finite and > 0");
  for (int i = 0; i < 3; ++i)
    if (!(collision_box_m[i] > 0.0) || !std::isfinite(collision_box_m[i]))
      return bad("collision_box_m[" + std::to_string(i) + "]", collision_box_m[i], "finite and > 0");
  if (!(position_tolerance_m > 0.0)) return bad("position_tolerance_m", position_tolerance_m, "> 0");
  if (!(yaw_tolerance_rad > 0.0)) return bad("yaw_tolerance_rad", yaw_tolerance_rad, "> 0");
  if (!(max_check_step_m > 0.0) || !(max_check_step_m < collision_box_m.minCoeff()))
    return bad("max_check_step_m", max_check_step_m, "> 0 and smaller than the smallest collision box extent");
  return {};
}

geometry::Pose3 VehicleState::T_world_vehicle() const {
  return geometry::poseFromXyzRpy(xyz_world.x(), xyz_world.y(), xyz_world.z(), 0.0, 0.0, yaw_rad);
}

const char* toString(MotionStatus status) {
  switch (status) {
    case MotionStatus::kIdle: return "idle";
    case MotionStatus::kMoving: return "moving";
    case MotionStatus::kReached: return "reached";
    case MotionStatus::kBlocked: return "blocked";
  }
  return "unknown";
}

Result<VehicleModel> VehicleModel::create(const World& world, const VehicleConfig& config,
                                          const Eigen::Vector3d& start_xyz_world, double start_yaw_rad,
                                          std::int64_t start_stamp_ns) {
  if (auto st = config.validate(); !st) return st.error();
  if (!start_xyz_world.allFinite() || !std::isfinite(start_yaw_rad)) return Error{"vehicle start pose is not finite"};
  VehicleModel v(world, config);
  v.state_.stamp_ns = start_stamp_ns;
  v.state_.xyz_world = start_xyz_world;
  v.state_.yaw_rad = geometry::wrapAngle(start_yaw_rad);
  if (v.collidesAt(start_xyz_world, start_yaw_rad))
    return Error{"vehicle start pose (" + std::to_string(start_xyz_world.x()) + ", " +
                 std::to_string(start_xyz_world.y()) + ", " + std::to_string(start_xyz_world.z()) +
                 ") collides with the scene"};
  return v;
}

bool VehicleModel::collidesAt(const Eigen::Vector3d& xyz_world, double yaw_rad) const {
  const geometry::Pose3 T = geometry::poseFromXyzRpy(xyz_world.x(), xyz_world.y(), xyz_world.z(), 0, 0, yaw_rad);
  return world_->boxCollides(T, 0.5 * config_.collision_box_m);
}

Status VehicleModel::setWaypoints(std::vector<Waypoint> waypoints) {
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    if (!waypoints[i].xyz_world.allFinite() || !std::isfinite(waypoints[i].yaw_rad))
      return Error{"waypoint " + std::to_string(i) + " is not finite"};
  }
  waypoints_.assign(waypoints.begin(), waypoints.end());
  blocked_ = false;
  return {};
}

void VehicleModel::skipWaypoint() {
  if (!waypoints_.empty()) waypoints_.pop_front();
  blocked_ = false;
}

StepResult VehicleModel::step(std::int64_t dt_ns) {
  StepResult result;
  if (dt_ns <= 0) return result;
  const double dt_s = static_cast<double>(dt_ns) * 1e-9;
  const Eigen::Vector3d xyz0 = state_.xyz_world;
  const double yaw0 = state_.yaw_rad;
  double time_left_s = blocked_ ? 0.0 : dt_s;  // a blocked vehicle waits for new orders
  const double corner_radius_m = 0.5 * config_.collision_box_m.head<2>().norm();

  // Reach as many waypoints as the step allows, each leg at the limits, checked in sub-steps.
  while (time_left_s > 0.0 && !waypoints_.empty()) {
    const Waypoint& wp = waypoints_.front();
    const Eigen::Vector3d delta = wp.xyz_world - state_.xyz_world;
    const double dist = delta.norm();
    const double dyaw = geometry::wrapAngle(wp.yaw_rad - state_.yaw_rad);
    // Translation and rotation run together; the leg takes as long as the slower of the two.
    const double t_move = dist / config_.max_speed_mps;
    const double t_turn = std::abs(dyaw) / config_.max_yaw_rate_radps;
    const double t_leg = std::max(t_move, t_turn);
    const double t = std::min(time_left_s, t_leg);
    const double frac = t_leg > 0.0 ? t / t_leg : 1.0;
    const Eigen::Vector3d move = delta * frac;
    const double turn = dyaw * frac;
    // Sub-steps bound both the translation and the arc of the box's corners by max_check_step_m.
    const double sweep_m = std::max(move.norm(), std::abs(turn) * corner_radius_m);
    const int n_sub = std::max(1, static_cast<int>(std::ceil(sweep_m / config_.max_check_step_m)));
    bool refused = false;
    for (int k = 0; k < n_sub; ++k) {
      const Eigen::Vector3d p = state_.xyz_world + move * (1.0 / n_sub);
      const double y = geometry::wrapAngle(state_.yaw_rad + turn / n_sub);
      if (collidesAt(p, y)) {
        refused = true;
        break;
      }
      state_.xyz_world = p;
      state_.yaw_rad = y;
    }
    if (refused) {
      ++collisions_;
      // Close enough to the goal counts as reached: the waypoint may touch an obstacle.
      const Eigen::Vector3d left = wp.xyz_world - state_.xyz_world;
      if (left.norm() <= config_.position_tolerance_m &&
          std::abs(geometry::wrapAngle(wp.yaw_rad - state_.yaw_rad)) <= config_.yaw_tolerance_rad) {
        waypoints_.pop_front();
        ++result.waypoints_reached;
        continue;
      }
      blocked_ = true;
      break;
    }
    time_left_s -= t;
    if (frac >= 1.0) {
      // Land exactly on the waypoint (sub-steps accumulate rounding).
      if (!collidesAt(wp.xyz_world, wp.yaw_rad)) {
        state_.xyz_world = wp.xyz_world;
        state_.yaw_rad = geometry::wrapAngle(wp.yaw_rad);
      }
      waypoints_.pop_front();
      ++result.waypoints_reached;
    }
  }

  state_.stamp_ns += dt_ns;
  state_.velocity_world_mps = (state_.xyz_world - xyz0) / dt_s;
  state_.yaw_rate_radps = geometry::wrapAngle(state_.yaw_rad - yaw0) / dt_s;
  if (blocked_) {
    result.status = MotionStatus::kBlocked;
  } else if (result.waypoints_reached > 0) {
    result.status = MotionStatus::kReached;
  } else {
    result.status = waypoints_.empty() ? MotionStatus::kIdle : MotionStatus::kMoving;
  }
  return result;
}

}  // namespace vog::sim
