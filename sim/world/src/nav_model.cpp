#include "vog/sim/nav_model.hpp"

#include "vog/sim/rng.hpp"

#include <cmath>

namespace vog::sim {

namespace {
Error bad(const std::string& key, double v, const std::string& rule) {
  return Error{key + " must be " + rule + ", got " + std::to_string(v)};
}
bool positiveFinite(double v) { return v > 0.0 && std::isfinite(v); }
bool nonNegativeFinite(double v) { return v >= 0.0 && std::isfinite(v); }
}  // namespace

const char* toString(OdometryNoiseProfile profile) {
  return profile == OdometryNoiseProfile::kEq41Literal ? "eq41" : "random_walk";
}

Result<OdometryNoiseProfile> parseOdometryNoiseProfile(const std::string& name) {
  if (name == "eq41") return OdometryNoiseProfile::kEq41Literal;
  if (name == "random_walk") return OdometryNoiseProfile::kRandomWalk;
  return Error{"odometry.profile must be 'eq41' or 'random_walk', got '" + name + "'"};
}

Status OdometryNoiseConfig::validate() const {
  if (!positiveFinite(rate_hz) || rate_hz > 100000.0) return bad("odometry.rate_hz", rate_hz, "in (0, 100000]");
  if (!nonNegativeFinite(sigma2_x_m2ps)) return bad("odometry.sigma2_x_m2ps", sigma2_x_m2ps, "finite and >= 0");
  if (!nonNegativeFinite(sigma2_y_m2ps)) return bad("odometry.sigma2_y_m2ps", sigma2_y_m2ps, "finite and >= 0");
  if (!nonNegativeFinite(sigma2_yaw_rad2ps))
    return bad("odometry.sigma2_yaw_rad2ps", sigma2_yaw_rad2ps, "finite and >= 0");
  if (!nonNegativeFinite(z_sigma_m)) return bad("odometry.z_sigma_m", z_sigma_m, "finite and >= 0");
  if (!nonNegativeFinite(roll_pitch_sigma_rad))
    return bad("odometry.roll_pitch_sigma_rad", roll_pitch_sigma_rad, "finite and >= 0");
  if (world_frame_xy_noise && sigma2_x_m2ps != sigma2_y_m2ps) {
    return Error{"odometry.world_frame_xy_noise needs sigma2_x_m2ps = sigma2_y_m2ps (an isotropic x-y noise), got " +
                 std::to_string(sigma2_x_m2ps) + " and " + std::to_string(sigma2_y_m2ps)};
  }
  return {};
}

Eigen::Vector3d OdometryNoiseConfig::predictedVariance(double T_s) const {
  const Eigen::Vector3d sigma(sigma2_x_m2ps, sigma2_y_m2ps, sigma2_yaw_rad2ps);
  // Eq. 4.1 literal: T/dt steps of variance dt^2 Sigma; random walk: T/dt steps of dt Sigma.
  return profile == OdometryNoiseProfile::kEq41Literal ? Eigen::Vector3d(T_s * dt_s() * sigma)
                                                       : Eigen::Vector3d(T_s * sigma);
}

Result<OdometryCorruptor> OdometryCorruptor::create(const OdometryNoiseConfig& config, std::uint64_t seed) {
  if (auto st = config.validate(); !st) return st.error();
  return OdometryCorruptor(config, seed);
}

OdometryCorruptor::OdometryCorruptor(const OdometryNoiseConfig& config, std::uint64_t seed)
    : config_(config),
      rng_(makeRng(seed, RngStream::kOdometry)),
      previous_true_(Eigen::Vector3d::Zero()),
      estimate_(Eigen::Vector3d::Zero()) {
  const Eigen::Vector3d sigma2(config_.sigma2_x_m2ps, config_.sigma2_y_m2ps, config_.sigma2_yaw_rad2ps);
  const double dt = config_.dt_s();
  sigma_step_ = config_.profile == OdometryNoiseProfile::kEq41Literal
                    ? Eigen::Vector3d(dt * sigma2.cwiseSqrt())     // dt * N(0, Sigma)
                    : Eigen::Vector3d((dt * sigma2).cwiseSqrt());  // N(0, dt * Sigma)
}

void OdometryCorruptor::reset(double x_m, double y_m, double yaw_rad) {
  previous_true_ = Eigen::Vector3d(x_m, y_m, yaw_rad);
  estimate_ = previous_true_;
}

Eigen::Vector3d OdometryCorruptor::stepPlanar(double x_m, double y_m, double yaw_rad) {
  std::normal_distribution<double> n01(0.0, 1.0);
  // P_{t+1} (-) P_t: motion in the frame of P_t.
  const double c0 = std::cos(previous_true_.z()), s0 = std::sin(previous_true_.z());
  const double dx_w = x_m - previous_true_.x(), dy_w = y_m - previous_true_.y();
  Eigen::Vector3d rel(c0 * dx_w + s0 * dy_w, -s0 * dx_w + c0 * dy_w, geometry::wrapAngle(yaw_rad - previous_true_.z()));
  // + noise (thesis Eq. 4.1: additive white Gaussian noise on the relative motion).
  Eigen::Vector2d n_xy;
  n_xy.x() = sigma_step_.x() * n01(rng_);  // one draw per statement: a fixed order of the stream
  n_xy.y() = sigma_step_.y() * n01(rng_);
  rel.z() += sigma_step_.z() * n01(rng_);
  const double c = std::cos(estimate_.z()), s = std::sin(estimate_.z());
  // Drawn in the world frame: rotated into the estimate's frame, so that (+) below adds it unrotated.
  if (config_.world_frame_xy_noise) n_xy = Eigen::Vector2d(c * n_xy.x() + s * n_xy.y(), -s * n_xy.x() + c * n_xy.y());
  rel.head<2>() += n_xy;
  // P^_t (+) rel.
  estimate_.x() += c * rel.x() - s * rel.y();
  estimate_.y() += s * rel.x() + c * rel.y();
  estimate_.z() = geometry::wrapAngle(estimate_.z() + rel.z());
  previous_true_ = Eigen::Vector3d(x_m, y_m, yaw_rad);
  return estimate_;
}

void OdometryCorruptor::reset(const geometry::Pose3& T) {
  reset(T.translation().x(), T.translation().y(), geometry::yawOf(T.linear()));
}

geometry::Pose3 OdometryCorruptor::step(const geometry::Pose3& T) {
  const Eigen::Vector3d rpy = geometry::rpyFromRotation(T.linear());
  const Eigen::Vector3d e = stepPlanar(T.translation().x(), T.translation().y(), rpy.z());
  std::normal_distribution<double> n01(0.0, 1.0);
  const double z = T.translation().z() + config_.z_sigma_m * n01(rng_);
  const double roll = rpy.x() + config_.roll_pitch_sigma_rad * n01(rng_);
  const double pitch = rpy.y() + config_.roll_pitch_sigma_rad * n01(rng_);
  return geometry::poseFromXyzRpy(e.x(), e.y(), z, roll, pitch, e.z());
}

// ---------------------------------------------------------------------------------------------

Status NavSensorConfig::validate() const {
  if (!positiveFinite(dvl_rate_hz)) return bad("nav.dvl_rate_hz", dvl_rate_hz, "finite and > 0");
  if (!nonNegativeFinite(dvl_sigma_mps)) return bad("nav.dvl_sigma_mps", dvl_sigma_mps, "finite and >= 0");
  if (!positiveFinite(dvl_max_altitude_m)) return bad("nav.dvl_max_altitude_m", dvl_max_altitude_m, "finite and > 0");
  if (!positiveFinite(imu_rate_hz)) return bad("nav.imu_rate_hz", imu_rate_hz, "finite and > 0");
  if (!nonNegativeFinite(imu_roll_pitch_sigma_rad))
    return bad("nav.imu_roll_pitch_sigma_rad", imu_roll_pitch_sigma_rad, "finite and >= 0");
  if (!nonNegativeFinite(imu_yaw_sigma_rad)) return bad("nav.imu_yaw_sigma_rad", imu_yaw_sigma_rad, "finite and >= 0");
  if (!nonNegativeFinite(imu_yaw_drift_rad2ps))
    return bad("nav.imu_yaw_drift_rad2ps", imu_yaw_drift_rad2ps, "finite and >= 0");
  if (!nonNegativeFinite(imu_rate_sigma_radps))
    return bad("nav.imu_rate_sigma_radps", imu_rate_sigma_radps, "finite and >= 0");
  if (!positiveFinite(depth_rate_hz)) return bad("nav.depth_rate_hz", depth_rate_hz, "finite and > 0");
  if (!nonNegativeFinite(depth_noise_fraction))
    return bad("nav.depth_noise_fraction", depth_noise_fraction, "finite and >= 0");
  if (!positiveFinite(depth_full_scale_m)) return bad("nav.depth_full_scale_m", depth_full_scale_m, "finite and > 0");
  return {};
}

Result<NavSensorModel> NavSensorModel::create(const World& world, const NavSensorConfig& config, std::uint64_t seed) {
  if (auto st = config.validate(); !st) return st.error();
  return NavSensorModel(world, config, seed);
}

NavSensorModel::NavSensorModel(const World& world, const NavSensorConfig& config, std::uint64_t seed)
    : world_(&world),
      config_(config),
      dvl_rng_(makeRng(seed, RngStream::kDvl)),
      imu_rng_(makeRng(seed, RngStream::kImu)),
      depth_rng_(makeRng(seed, RngStream::kDepth)) {}

DvlSample NavSensorModel::dvl(const VehicleState& truth) {
  std::normal_distribution<double> n01(0.0, 1.0);
  DvlSample s;
  s.stamp_ns = truth.stamp_ns;
  // Bottom track: velocity over ground in the vehicle frame, when a surface is in reach below.
  const auto hit = world_->castRay(truth.xyz_world, -Eigen::Vector3d::UnitZ(), config_.dvl_max_altitude_m);
  // Draws happen whether or not there is a lock, so the stream does not depend on the scene.
  const Eigen::Vector3d noise(n01(dvl_rng_), n01(dvl_rng_), n01(dvl_rng_));
  if (!hit) return s;
  s.bottom_lock = true;
  s.altitude_m = hit->range_m;
  const Eigen::Matrix3d R_world_vehicle = truth.T_world_vehicle().linear();
  s.velocity_vehicle_mps = R_world_vehicle.transpose() * truth.velocity_world_mps + config_.dvl_sigma_mps * noise;
  return s;
}

ImuSample NavSensorModel::imu(const VehicleState& truth) {
  std::normal_distribution<double> n01(0.0, 1.0);
  if (imu_started_ && truth.stamp_ns > last_imu_stamp_ns_) {
    const double dt_s = static_cast<double>(truth.stamp_ns - last_imu_stamp_ns_) * 1e-9;
    yaw_drift_rad_ += std::sqrt(config_.imu_yaw_drift_rad2ps * dt_s) * n01(imu_rng_);
  }
  imu_started_ = true;
  last_imu_stamp_ns_ = truth.stamp_ns;
  ImuSample s;
  s.stamp_ns = truth.stamp_ns;
  s.rpy_rad.x() = config_.imu_roll_pitch_sigma_rad * n01(imu_rng_);
  s.rpy_rad.y() = config_.imu_roll_pitch_sigma_rad * n01(imu_rng_);
  s.rpy_rad.z() = geometry::wrapAngle(truth.yaw_rad + yaw_drift_rad_ + config_.imu_yaw_sigma_rad * n01(imu_rng_));
  s.angular_rate_vehicle_radps =
      Eigen::Vector3d(0.0, 0.0, truth.yaw_rate_radps) +
      config_.imu_rate_sigma_radps * Eigen::Vector3d(n01(imu_rng_), n01(imu_rng_), n01(imu_rng_));
  return s;
}

DepthSample NavSensorModel::depth(const VehicleState& truth) {
  std::normal_distribution<double> n01(0.0, 1.0);
  DepthSample s;
  s.stamp_ns = truth.stamp_ns;
  s.depth_m = -truth.xyz_world.z() + config_.depth_noise_fraction * config_.depth_full_scale_m * n01(depth_rng_);
  return s;
}

}  // namespace vog::sim
