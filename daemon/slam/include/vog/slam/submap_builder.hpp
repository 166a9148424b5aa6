#pragma once
// SubmapBuilder (thesis 3.2, 4.5.3): cuts the scan stream into submaps. Each scan is integrated into the
// active LocalGrid relative to the submap's base pose (the odometry pose of its first scan). A submap is
// closed when the next scan would break one of three rules:
//  - uncertainty: the base-pose uncertainty accumulated since the submap started, Sigma_i = dt * Sigma
//    (thesis 3.2), with Sigma the odometry noise rates (thesis Eq. 4.1 defaults), exceeds a bound
//    (planar position standard deviation sqrt((cov_x + cov_y) dt), or yaw standard deviation
//    sqrt(cov_yaw dt));
//  - scan count: the submap already holds max_scans scans (thesis Table 4.2: 100);
//  - heading change: the scan's yaw differs from the base yaw by more than max_heading_change_rad
//    (thesis 4.5.3: heading changes dominate drift and make poor submaps; 90 deg as Fig. 4.14).
// The scan that breaks a rule becomes the first scan (base pose) of the next submap.
//
// Lifecycle: create(); addScan() in time order, each call possibly returning the submap it closed;
// flush() closes the active submap at the end of a run. Invariants: stamps strictly increase; every
// scan in the active grid was inserted relative to the active base pose; a rejected scan (bad pose,
// non-increasing stamp, wrong beam count, NaN range) changes nothing.
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"
#include "vog/map/grid_config.hpp"
#include "vog/map/local_grid.hpp"

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>

namespace vog::slam {

struct SubmapBuilderConfig {
  map::GridConfig grid;
  geometry::SonarFan fan;
  // Odometry noise rates Sigma (variance per second), thesis Eq. 4.1.
  double odometry_cov_x_m2_per_s = 0.00138;
  double odometry_cov_y_m2_per_s = 0.00138;
  double odometry_cov_yaw_rad2_per_s = 1e-7;
  // Uncertainty bounds on Sigma_i = dt * Sigma. With the defaults the position bound is reached after
  // 0.3^2 / 0.00276 = 32.6 s, i.e. after the 100-scan limit at 5 scans/s (20 s, thesis Table 4.2),
  // so it only acts when scans are sparse or the odometry is noisier.
  double max_position_stddev_m = 0.3;
  double max_yaw_stddev_rad = 0.01;
  int max_scans = 100;                                      // thesis Table 4.2
  double max_heading_change_rad = geometry::deg2rad(90.0);  // thesis 4.5.3, Fig. 4.14
  // Names the first bad key and value, or is ok.
  Status validate() const;
};

// One scan with the odometry pose of the vehicle at its stamp and the absolute measurements of depth
// (z) and attitude (roll, pitch) from the depth sensor and the IMU at that time.
struct ScanInput {
  geometry::Pose3 T_world_vehicle_odom = geometry::Pose3::Identity();
  Eigen::Vector3d z_roll_pitch = Eigen::Vector3d::Zero();
  geometry::RangeScan scan;
};

enum class CloseReason { kUncertainty, kScanCount, kHeadingChange, kFlush };
const char* toString(CloseReason reason);

struct ClosedSubmap {
  std::int64_t index = 0;                      // 0, 1, 2, ... in closing order
  std::shared_ptr<const map::LocalGrid> grid;  // finalized, in the base frame
  geometry::Pose3 T_world_base_odom = geometry::Pose3::Identity();
  Eigen::Vector3d base_z_roll_pitch = Eigen::Vector3d::Zero();  // absolute measurement at the base scan
  std::int64_t first_stamp_ns = 0;
  std::int64_t last_stamp_ns = 0;
  std::size_t n_scans = 0;
  CloseReason reason = CloseReason::kFlush;
  // Odometry from the previous submap's base pose to this one (planarOdometry: dx, dy in the previous
  // heading frame, dyaw) and its covariance dt * Sigma; absent for the first submap.
  bool has_previous = false;
  Eigen::Vector3d odometry_from_previous = Eigen::Vector3d::Zero();
  Eigen::Matrix3d odometry_covariance = Eigen::Matrix3d::Zero();
};

class SubmapBuilder {
 public:
  static Result<SubmapBuilder> create(const SubmapBuilderConfig& config);
  // A builder in the state right after `last_closed` was closed, but with no active submap (a resumed
  // mission: the scans of the submap that was active at a crash are gone). The next scan starts
  // submap last_closed.index + 1, its odometry factor runs from last_closed's base pose, and its stamp
  // must be after last_closed.last_stamp_ns.
  static Result<SubmapBuilder> resumeAfter(const SubmapBuilderConfig& config, const ClosedSubmap& last_closed);

  // Adds one scan. Returns the submap this scan closed (the scan then starts the next one), or nullopt.
  Result<std::optional<ClosedSubmap>> addScan(const ScanInput& input);
  // Closes the active submap if it holds any scan.
  Result<std::optional<ClosedSubmap>> flush();

  std::size_t activeScanCount() const { return active_ ? active_->scanCount() : 0; }
  std::int64_t nextIndex() const { return next_index_; }
  const SubmapBuilderConfig& config() const { return config_; }

 private:
  explicit SubmapBuilder(const SubmapBuilderConfig& config) : config_(config) {}
  Status checkInput(const ScanInput& input) const;
  std::optional<CloseReason> closeReason(const ScanInput& input) const;
  Result<ClosedSubmap> closeActive(CloseReason reason);

  SubmapBuilderConfig config_;
  std::unique_ptr<map::LocalGrid> active_;  // null when no submap is open
  geometry::Pose3 T_world_base_ = geometry::Pose3::Identity();
  Eigen::Vector3d base_z_roll_pitch_ = Eigen::Vector3d::Zero();
  std::int64_t first_stamp_ns_ = 0;
  std::int64_t last_stamp_ns_ = 0;
  bool has_stamp_ = false;  // any scan accepted yet (stamps must increase across submaps too)
  std::int64_t next_index_ = 0;
  bool has_previous_base_ = false;
  geometry::Pose3 T_world_previous_base_ = geometry::Pose3::Identity();
  std::int64_t previous_first_stamp_ns_ = 0;
};

}  // namespace vog::slam
