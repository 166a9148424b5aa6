#pragma once
// Dead reckoning (DESIGN "nav/"): DVL bottom-track velocity rotated by IMU attitude and
// integrated for x, y; z from depth; roll, pitch, yaw from the IMU.
//
// Frames. World: local level, x east, y north, z up (geometry/pose.hpp: world z up). Vehicle: x
// forward, y left, z up. The IMU reports NED attitude of an x-forward, y-starboard, z-down body
// (imu_types.hpp); it is converted to T_world_vehicle here. DVL velocities come in the frame the
// coordinate-transform byte names: instrument (rotated by the mounting and the attitude), ship
// (x starboard, y forward, z up; rotated by the attitude) or earth (east, north, up; used as is).

#include <cstdint>
#include <deque>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vog/depth/depth_types.hpp"
#include "vog/dvl/dvl_types.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/imu/imu_types.hpp"

namespace vog::nav {

struct DeadReckoningConfig {
  // Rotation of the DVL instrument frame in the vehicle frame (R_vehicle_dvl = Rz(yaw) Ry(pitch)
  // Rx(roll)). Default: RDI instrument frame with beam 3 forward, X to starboard, Z up (RDI "ADCP
  // Coordinate Transformation", instrument coordinates), i.e. a -90 deg yaw into x-forward/y-left.
  double dvl_mount_roll_rad = 0.0;
  double dvl_mount_pitch_rad = 0.0;
  double dvl_mount_yaw_rad = -1.5707963267948966;
  // Largest gap between IMU samples (or from the last one) over which attitude is interpolated
  // (held) for a DVL stamp; the IMU runs at 100 Hz (PROTOCOLS.md), so 0.1 s is ten lost samples.
  double imu_max_gap_s = 0.1;
  // A sensor whose newest accepted sample is older than this (relative to the query time) marks
  // the solution degraded. The DVL pings at a few Hz, the depth sensor at 1-10 Hz.
  double imu_timeout_s = 0.1;
  double dvl_timeout_s = 1.0;
  double depth_timeout_s = 1.0;
  // Bottom-track solutions with |error velocity| above this are rejected (the four beams disagree).
  double max_error_velocity_mps = 0.2;
  // Plausibility bound of a bottom velocity; the HAUV moves at most 0.25 m/s (thesis Table 4.2).
  double max_speed_mps = 3.0;
  // Noise model for the reported position sigma: white DVL velocity noise per axis, white
  // heading noise of the attitude used to rotate each sample, and the heading's random-walk drift
  // (variance per second; thesis 4.4.1 sigma_psi^2).
  double dvl_velocity_sigma_mps = 0.005;
  double heading_sigma_rad = 0.002;
  double heading_drift_rad2_per_s = 1e-7;

  Status validate(const std::string& prefix = "nav") const;
};

struct NavSolution {
  std::int64_t stamp_ns = 0;  // time the health was evaluated at
  bool initialized = false;   // at least one attitude, depth and DVL velocity have been used
  geometry::Pose3 T_world_vehicle = geometry::Pose3::Identity();
  Eigen::Vector3d velocity_world_mps = Eigen::Vector3d::Zero();  // last DVL velocity in world
  double position_sigma_m = 0.0;  // predicted 1-sigma drift of x (and of y) from the noise model
  bool degraded = true;
  std::string reason;  // why degraded ("; "-separated), empty when healthy
  std::uint64_t dvl_used = 0;
  std::uint64_t dvl_rejected = 0;
  std::uint64_t imu_rejected = 0;
  std::uint64_t depth_rejected = 0;
};

// Lifecycle: construct with a validated config; feed samples in time order per sensor (the three
// streams may interleave arbitrarily within imu_max_gap_s); query solution() at any time.
// Invariants: rejected samples (bad beams, bad status, out-of-order or non-finite values) change
// nothing but a counter and the last-rejection reason; x, y advance only from accepted DVL samples
// with an attitude available; the pose is always a valid rigid transform.
class DeadReckoning {
 public:
  explicit DeadReckoning(DeadReckoningConfig config = {});

  Status addImu(const imu::ImuSample& sample);
  Status addDepth(const depth::DepthSample& sample);
  // PD0 ensemble with bottom track: frame from the coordinate-transform byte, bad beams rejected,
  // sign flipped (PD0 bottom track is the bottom's motion, PD6 the vehicle's).
  Status addDvl(const dvl::DvlEnsemble& ensemble);
  // Vehicle velocity over the bottom (PD6 sign), e.g. from dvl::bottomVelocity().
  Status addDvl(const dvl::BottomVelocity& velocity);

  // Solution with sensor health evaluated at `now_ns` (the caller's newest sample time).
  NavSolution solution(std::int64_t now_ns) const;

  // The pose at `stamp_ns` (e.g. of a sonar ping between two DVL samples): attitude interpolated
  // from the IMU, x and y carried from the newest DVL sample with its velocity, z from the newest
  // depth. An error names the sensor that cannot give it: no data yet, or data more than its
  // timeout away from the stamp.
  Result<geometry::Pose3> poseAt(std::int64_t stamp_ns) const;

  // Sets the horizontal position (e.g. from a surface fix) and resets its sigma.
  void resetPosition(double x_m, double y_m);

 private:
  struct Attitude {
    std::int64_t stamp_ns;
    Eigen::Quaterniond q_world_vehicle;
  };
  Result<Eigen::Quaterniond> attitudeAt(std::int64_t stamp_ns) const;
  Status reject(std::uint64_t& counter, std::string reason);

  DeadReckoningConfig config_;
  Eigen::Matrix3d R_vehicle_dvl_;
  std::deque<Attitude> attitudes_;  // increasing stamps, about the last second
  std::int64_t last_imu_ns_ = -1;
  std::int64_t last_depth_ns_ = -1;
  std::int64_t last_dvl_ns_ = -1;
  double depth_m_ = 0.0;
  Eigen::Vector2d xy_m_ = Eigen::Vector2d::Zero();
  Eigen::Vector3d v_world_mps_ = Eigen::Vector3d::Zero();
  double variance_m2_ = 0.0;  // white parts, per axis
  // Heading drift: a yaw error that is a random walk of rate q turns the path behind the vehicle, so
  // the position error at T has variance q * integral |p(T) - p(t)|^2 dt (both axes together), kept
  // as the moments of the path since the last reset: integral dt, integral p dt, integral |p|^2 dt.
  double path_s0_s_ = 0.0;
  Eigen::Vector2d path_s1_ = Eigen::Vector2d::Zero();
  double path_s2_ = 0.0;
  std::uint64_t dvl_used_ = 0;
  std::uint64_t dvl_rejected_ = 0;
  std::uint64_t imu_rejected_ = 0;
  std::uint64_t depth_rejected_ = 0;
  std::string last_rejection_;
};

// NED attitude of a forward-starboard-down body (IMU convention) to the rotation of the
// forward-left-up vehicle frame in the east-north-up world frame.
Eigen::Matrix3d worldFromNedAttitude(double roll_rad, double pitch_rad, double heading_rad);

}  // namespace vog::nav
