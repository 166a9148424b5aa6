#include "vog/slam/submap_builder.hpp"

#include "vog/slam/pose_graph.hpp"

#include <cmath>
#include <numbers>
#include <sstream>
#include <utility>

namespace vog::slam {

namespace {

bool positiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

Error badKey(const char* key, double value, const char* rule) {
  std::ostringstream os;
  os << "submap builder config: " << key << " = " << value << " " << rule;
  return Error{os.str()};
}

}  // namespace

const char* toString(CloseReason reason) {
  switch (reason) {
    case CloseReason::kUncertainty: return "uncertainty";
    case CloseReason::kScanCount: return "scan_count";
    case CloseReason::kHeadingChange: return "heading_change";
    case CloseReason::kFlush: return "flush";
  }
  return "unknown";
}

Status SubmapBuilderConfig::validate() const {
  if (Status s = grid.validate(); !s.ok()) return Error{"submap builder config: grid: " + s.error().message};
  if (Status s = fan.validate(); !s.ok()) return Error{"submap builder config: fan: " + s.error().message};
  if (!positiveFinite(odometry_cov_x_m2_per_s))
    return badKey("odometry_cov_x_m2_per_s", odometry_cov_x_m2_per_s, "must be > 0");
  if (!positiveFinite(odometry_cov_y_m2_per_s))
    return badKey("odometry_cov_y_m2_per_s", odometry_cov_y_m2_per_s, "must be > 0");
  if (!positiveFinite(odometry_cov_yaw_rad2_per_s)) {
    return badKey("odometry_cov_yaw_rad2_per_s", odometry_cov_yaw_rad2_per_s, "must be > 0");
  }
  if (!positiveFinite(max_position_stddev_m))
    return badKey("max_position_stddev_m", max_position_stddev_m, "must be > 0");
  if (!positiveFinite(max_yaw_stddev_rad)) return badKey("max_yaw_stddev_rad", max_yaw_stddev_rad, "must be > 0");
  if (max_scans < 1) return badKey("max_scans", max_scans, "must be >= 1");
  if (!positiveFinite(max_heading_change_rad) || max_heading_change_rad > std::numbers::pi) {
    return badKey("max_heading_change_rad", max_heading_change_rad, "must be in (0, pi]");
  }
  return Status::success();
}

Result<SubmapBuilder> SubmapBuilder::create(const SubmapBuilderConfig& config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  return SubmapBuilder(config);
}

Status SubmapBuilder::checkInput(const ScanInput& input) const {
  if (!geometry::isValidPose(input.T_world_vehicle_odom)) {
    return Error{"submap builder: scan at stamp_ns " + std::to_string(input.scan.stamp_ns) +
                 " has an invalid or non-finite odometry pose"};
  }
  if (!input.z_roll_pitch.allFinite()) {
    return Error{"submap builder: scan at stamp_ns " + std::to_string(input.scan.stamp_ns) +
                 " has a non-finite depth/roll/pitch measurement"};
  }
  if (has_stamp_ && input.scan.stamp_ns <= last_stamp_ns_) {
    return Error{"submap builder: stamp_ns " + std::to_string(input.scan.stamp_ns) +
                 " is not after the previous scan's " + std::to_string(last_stamp_ns_)};
  }
  if (input.scan.range_m.size() != static_cast<std::size_t>(config_.fan.n_beams)) {
    return Error{"submap builder: scan at stamp_ns " + std::to_string(input.scan.stamp_ns) + " has " +
                 std::to_string(input.scan.range_m.size()) + " beams, the fan has " +
                 std::to_string(config_.fan.n_beams)};
  }
  for (std::size_t i = 0; i < input.scan.range_m.size(); ++i) {
    const float r = input.scan.range_m[i];
    if (std::isnan(r) || r < 0.0F) {
      return Error{"submap builder: scan at stamp_ns " + std::to_string(input.scan.stamp_ns) + " beam " +
                   std::to_string(i) + " has range " + std::to_string(r)};
    }
  }
  return Status::success();
}

std::optional<CloseReason> SubmapBuilder::closeReason(const ScanInput& input) const {
  if (!active_) return std::nullopt;
  if (static_cast<int>(active_->scanCount()) >= config_.max_scans) return CloseReason::kScanCount;
  // Thesis 3.2: Sigma_i = dt * Sigma since the base scan.
  const double dt_s = 1e-9 * static_cast<double>(input.scan.stamp_ns - first_stamp_ns_);
  const double position_var = dt_s * (config_.odometry_cov_x_m2_per_s + config_.odometry_cov_y_m2_per_s);
  const double yaw_var = dt_s * config_.odometry_cov_yaw_rad2_per_s;
  if (position_var > config_.max_position_stddev_m * config_.max_position_stddev_m ||
      yaw_var > config_.max_yaw_stddev_rad * config_.max_yaw_stddev_rad) {
    return CloseReason::kUncertainty;
  }
  const double dyaw = geometry::wrapAngle(geometry::yawOf(input.T_world_vehicle_odom.linear()) -
                                          geometry::yawOf(T_world_base_.linear()));
  if (std::abs(dyaw) > config_.max_heading_change_rad) return CloseReason::kHeadingChange;
  return std::nullopt;
}

Result<SubmapBuilder> SubmapBuilder::resumeAfter(const SubmapBuilderConfig& config, const ClosedSubmap& last_closed) {
  auto builder = create(config);
  if (!builder) return builder.error();
  if (last_closed.index < 0) {
    return Error{"submap builder: cannot resume after submap index " + std::to_string(last_closed.index)};
  }
  if (!geometry::isValidPose(last_closed.T_world_base_odom)) {
    return Error{"submap builder: cannot resume after submap " + std::to_string(last_closed.index) +
                 ": its base pose is non-finite or non-rigid"};
  }
  if (last_closed.last_stamp_ns < last_closed.first_stamp_ns) {
    return Error{"submap builder: cannot resume after submap " + std::to_string(last_closed.index) + ": last stamp " +
                 std::to_string(last_closed.last_stamp_ns) + " is before first stamp " +
                 std::to_string(last_closed.first_stamp_ns)};
  }
  SubmapBuilder& b = builder.value();
  b.has_stamp_ = true;
  b.last_stamp_ns_ = last_closed.last_stamp_ns;
  b.next_index_ = last_closed.index + 1;
  b.has_previous_base_ = true;
  b.T_world_previous_base_ = last_closed.T_world_base_odom;
  b.previous_first_stamp_ns_ = last_closed.first_stamp_ns;
  return builder;
}

Result<ClosedSubmap> SubmapBuilder::closeActive(CloseReason reason) {
  ClosedSubmap out;
  out.index = next_index_;
  out.T_world_base_odom = T_world_base_;
  out.base_z_roll_pitch = base_z_roll_pitch_;
  out.first_stamp_ns = first_stamp_ns_;
  out.last_stamp_ns = last_stamp_ns_;
  out.n_scans = active_->scanCount();
  out.reason = reason;
  if (has_previous_base_) {
    out.has_previous = true;
    out.odometry_from_previous = planarOdometry(T_world_previous_base_, T_world_base_);
    const double dt_s = 1e-9 * static_cast<double>(first_stamp_ns_ - previous_first_stamp_ns_);
    out.odometry_covariance = dt_s * Eigen::Vector3d(config_.odometry_cov_x_m2_per_s, config_.odometry_cov_y_m2_per_s,
                                                     config_.odometry_cov_yaw_rad2_per_s)
                                         .asDiagonal();
  }
  active_->finalize();
  out.grid = std::shared_ptr<const map::LocalGrid>(std::move(active_));
  has_previous_base_ = true;
  T_world_previous_base_ = T_world_base_;
  previous_first_stamp_ns_ = first_stamp_ns_;
  ++next_index_;
  return out;
}

Result<std::optional<ClosedSubmap>> SubmapBuilder::addScan(const ScanInput& input) {
  if (Status s = checkInput(input); !s.ok()) return s.error();

  // Build the next grid first so that a failure leaves everything as it was.
  const std::optional<CloseReason> reason = closeReason(input);
  std::unique_ptr<map::LocalGrid> fresh;
  const bool starts_new = !active_ || reason.has_value();
  if (starts_new) {
    auto grid = map::LocalGrid::create(config_.grid);
    if (!grid) return Error{"submap builder: " + grid.error().message};
    fresh = std::move(grid.value());
  }
  map::LocalGrid& target = starts_new ? *fresh : *active_;
  const geometry::Pose3 T_world_base = starts_new ? input.T_world_vehicle_odom : T_world_base_;
  const geometry::Pose3 T_grid_sensor =
      T_world_base.inverse() * input.T_world_vehicle_odom * config_.fan.T_vehicle_sensor;
  if (Status s = target.insertScan(T_grid_sensor, config_.fan, input.scan); !s.ok()) {
    return Error{"submap builder: " + s.error().message};
  }

  std::optional<ClosedSubmap> closed;
  if (reason) {
    auto c = closeActive(*reason);
    if (!c) return c.error();
    closed = std::move(c.value());
  }
  if (starts_new) {
    active_ = std::move(fresh);
    T_world_base_ = input.T_world_vehicle_odom;
    base_z_roll_pitch_ = input.z_roll_pitch;
    first_stamp_ns_ = input.scan.stamp_ns;
  }
  last_stamp_ns_ = input.scan.stamp_ns;
  has_stamp_ = true;
  return closed;
}

Result<std::optional<ClosedSubmap>> SubmapBuilder::flush() {
  if (!active_ || active_->scanCount() == 0) return std::optional<ClosedSubmap>{};
  auto c = closeActive(CloseReason::kFlush);
  if (!c) return c.error();
  return std::optional<ClosedSubmap>{std::move(c.value())};
}

}  // namespace vog::slam
