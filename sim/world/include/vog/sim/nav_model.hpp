#pragma once
// Navigation sensor models (thesis 4.1, Table 4.1) and the thesis's corrupted odometry (Eq. 4.1).
// All noise comes from the model's own seeded streams; time comes from the caller's stamps.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"
#include "vog/sim/vehicle.hpp"
#include "vog/sim/world.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <random>
#include <string>

namespace vog::sim {

// ---------------------------------------------------------------------------------------------
// Corrupted odometry.
//
// kEq41Literal: thesis Eq. 4.1 applied literally at every odometry step of length dt:
//   P^_{t+1} = P^_t (+) ((P_{t+1} (-) P_t) + dt * N(0, Sigma)),   P^_1 = P_1,
// on (x, y, yaw), with (+)/(-) the SE(2) compose/relative operators and the noise added to the
// relative motion vector. Per step the noise variance is dt^2 Sigma, so the drift variance after T
// seconds is (T / dt) * dt^2 * Sigma = T * dt * Sigma (small: 0.0138 * 0.01 m^2 after 100 s).
// kRandomWalk: the same with noise N(0, dt * Sigma) per step, a random walk whose variance grows by
// Sigma per second (T * Sigma after T seconds): much larger drift, a stress case.
// z, roll and pitch get small absolute (non-accumulating) noise, as depth and IMU measure them
// absolutely (thesis 4.4.1).
// The x-y noise is drawn in the frame of the estimate (Eq. 4.1), or, with world_frame_xy_noise, in
// the world frame: for an isotropic Sigma (sigma_x = sigma_y, required) the same distribution, but
// the drift then depends on the seed and the time alone, not on the path (up to what the heading
// error does to the motion): two planners flown on one seed meet the same drift, so comparing them
// compares the planners, not two draws of the noise (common random numbers).
enum class OdometryNoiseProfile { kEq41Literal, kRandomWalk };

const char* toString(OdometryNoiseProfile profile);
Result<OdometryNoiseProfile> parseOdometryNoiseProfile(const std::string& name);  // "eq41" | "random_walk"

struct OdometryNoiseConfig {
  OdometryNoiseProfile profile = OdometryNoiseProfile::kEq41Literal;
  double rate_hz = 100.0;                                 // default step rate
  double sigma2_x_m2ps = 0.00138;                         // thesis 4.4.1, sigma_x^2
  double sigma2_y_m2ps = 0.00138;                         // thesis 4.4.1, sigma_y^2
  double sigma2_yaw_rad2ps = 1e-7;                        // thesis 4.4.1, sigma_psi^2
  double z_sigma_m = 0.005;                               // absolute depth noise
  double roll_pitch_sigma_rad = geometry::deg2rad(0.02);  // thesis Table 4.1, IMU roll/pitch
  bool world_frame_xy_noise = false;                      // see above; needs sigma2_x_m2ps == sigma2_y_m2ps

  Status validate() const;
  double dt_s() const { return 1.0 / rate_hz; }
  // Predicted drift variance (x, y, yaw) after T seconds of the profile.
  Eigen::Vector3d predictedVariance(double T_s) const;
};

// Lifecycle: reset() with the first true pose (P^_1 = P_1), then step() once per odometry period
// with the next true pose. Invariants: the estimate has zero roll/pitch drift (absolute noise only).
class OdometryCorruptor {
 public:
  static Result<OdometryCorruptor> create(const OdometryNoiseConfig& config, std::uint64_t seed);

  void reset(double x_m, double y_m, double yaw_rad);
  // Planar integrator only (x, y, yaw): the literal Eq. 4.1 update.
  Eigen::Vector3d stepPlanar(double x_m, double y_m, double yaw_rad);
  // Full pose: the planar update for x, y, yaw and absolute noise on z, roll, pitch.
  geometry::Pose3 step(const geometry::Pose3& T_world_vehicle_true);
  void reset(const geometry::Pose3& T_world_vehicle_true);

  const Eigen::Vector3d& planarEstimate() const { return estimate_; }
  const OdometryNoiseConfig& config() const { return config_; }

 private:
  OdometryCorruptor(const OdometryNoiseConfig& config, std::uint64_t seed);

  OdometryNoiseConfig config_;
  std::mt19937_64 rng_;
  Eigen::Vector3d sigma_step_;     // per-step noise standard deviation of x, y, yaw
  Eigen::Vector3d previous_true_;  // P_t as (x, y, yaw)
  Eigen::Vector3d estimate_;       // P^_t as (x, y, yaw)
};

// ---------------------------------------------------------------------------------------------
// Navigation sensors.
struct NavSensorConfig {
  double dvl_rate_hz = 5.0;
  double dvl_sigma_mps = 0.003;      // thesis Table 4.1, DVL x, y, z
  double dvl_max_altitude_m = 30.0;  // bottom lock lost above this
  double imu_rate_hz = 100.0;
  double imu_roll_pitch_sigma_rad = geometry::deg2rad(0.02);  // thesis Table 4.1
  double imu_yaw_sigma_rad = geometry::deg2rad(0.05);         // thesis Table 4.1 (white part)
  double imu_yaw_drift_rad2ps = 1e-7;                         // yaw random-walk variance per second (thesis 4.4.1)
  double imu_rate_sigma_radps = 1e-4;                         // angular-rate white noise
  double depth_rate_hz = 10.0;
  // Digiquartz accuracy 0.01 % (thesis Table 4.1), taken of full scale as the manufacturer states it.
  double depth_noise_fraction = 1e-4;
  double depth_full_scale_m = 100.0;

  Status validate() const;
};

struct DvlSample {
  std::int64_t stamp_ns = 0;
  bool bottom_lock = false;  // false: no bottom within range, velocity invalid
  Eigen::Vector3d velocity_vehicle_mps = Eigen::Vector3d::Zero();
  double altitude_m = 0.0;  // range to the bottom straight down (valid with lock)
};

struct ImuSample {
  std::int64_t stamp_ns = 0;
  Eigen::Vector3d rpy_rad = Eigen::Vector3d::Zero();  // yaw drifts
  Eigen::Vector3d angular_rate_vehicle_radps = Eigen::Vector3d::Zero();
};

struct DepthSample {
  std::int64_t stamp_ns = 0;
  double depth_m = 0.0;  // positive down (depth = -z_world)
};

// Lifecycle: construct, then call the sensors with successive true states (stamps non-decreasing).
// The IMU's yaw drift is a random walk advanced on each imu() call by the time since the last one.
class NavSensorModel {
 public:
  static Result<NavSensorModel> create(const World& world, const NavSensorConfig& config, std::uint64_t seed);

  DvlSample dvl(const VehicleState& truth);
  ImuSample imu(const VehicleState& truth);
  DepthSample depth(const VehicleState& truth);

  double yawDriftRad() const { return yaw_drift_rad_; }
  const NavSensorConfig& config() const { return config_; }

 private:
  NavSensorModel(const World& world, const NavSensorConfig& config, std::uint64_t seed);

  const World* world_;
  NavSensorConfig config_;
  std::mt19937_64 dvl_rng_;
  std::mt19937_64 imu_rng_;
  std::mt19937_64 depth_rng_;
  double yaw_drift_rad_ = 0.0;
  std::int64_t last_imu_stamp_ns_ = 0;
  bool imu_started_ = false;
};

}  // namespace vog::sim
