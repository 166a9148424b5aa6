#pragma once
// The vehicle side of vogd: where odometry and sonar scans come from and where waypoints go. One
// implementation runs the built-in simulator (SimSource); the device backends implement the same.
//
// Frames: odometry and waypoints are in the vehicle's odometry frame (the frame its own navigation
// steers in); the daemon converts the planner's map-frame waypoints with its current estimate.

#include "vog/api/domain.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/slam/submap_builder.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace vog::app {

struct OdometrySample {
  std::int64_t stamp_ns = 0;
  geometry::Pose3 T_odom_vehicle = geometry::Pose3::Identity();
  Eigen::Vector3d sigma_xyz_m = Eigen::Vector3d::Zero();
  double sigma_yaw_rad = 0.0;
};

// Receives what a source produces, on the source's thread. onScan() may block while the mapping
// side is behind (back-pressure); it returns false when the daemon is stopping. A simulated source
// also gives the true vehicle pose of each scan; it is recorded for evaluation, never used to map.
class SourceSink {
 public:
  virtual ~SourceSink() = default;
  virtual void onOdometry(const OdometrySample& odometry) = 0;
  virtual bool onScan(const slam::ScanInput& scan, const std::optional<geometry::Pose3>& T_world_vehicle_true) = 0;
  // Bytes a device delivered, for the raw log, before they are decoded (device ids: device_feed.hpp).
  virtual void onRawBytes(std::uint16_t /*device_id*/, std::int64_t /*stamp_ns*/,
                          std::span<const std::uint8_t> /*bytes*/) {}
};

struct SourceWaypoint {
  Eigen::Vector3d p_odom_m = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
};

// The vehicle stopped short of a waypoint (an obstacle, a refused move): where it stopped and where
// it was going, odometry frame.
struct SourceObstruction {
  Eigen::Vector3d p_odom_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d target_odom_m = Eigen::Vector3d::Zero();
};

class VehicleSource {
 public:
  virtual ~VehicleSource() = default;
  // Starts producing into `sink` (which must outlive stop()).
  virtual Status start(SourceSink& sink) = 0;
  // Stops producing and joins; idempotent.
  virtual void stop() = 0;
  // Replaces the vehicle's waypoint list (odometry frame); empty = hold position.
  virtual Status setWaypoints(std::vector<SourceWaypoint> waypoints) = 0;
  // Every waypoint sent so far was reached (or the list was empty).
  virtual bool idle() const = 0;
  virtual std::vector<api::DeviceHealth> health() const = 0;
  // Grows while the source's thread is alive (watchdog).
  virtual std::uint64_t heartbeat() const = 0;
  // The source's own error (e.g. the simulator failed), if it stopped producing because of one.
  virtual Status failure() const = 0;
  // The newest obstruction since the last call, once (the vehicle then holds and is idle).
  virtual std::optional<SourceObstruction> takeObstruction() = 0;
  // True when the odometry frame outlives the daemon (the vehicle's own navigation frame): after a
  // restart the new odometry continues the old frame. False (the simulator): a restarted source
  // starts a new frame, aligned by the daemon at its first sample.
  virtual bool persistentFrame() const { return false; }
};

}  // namespace vog::app
