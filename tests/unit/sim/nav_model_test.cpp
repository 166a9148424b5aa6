#include "vog/sim/nav_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace vog::sim {
namespace {

// Planar drift (estimate minus truth: x, y, yaw) after the vehicle followed `truth(t)` = (x, y, yaw)
// for T seconds.
template <class Truth>
Eigen::Vector3d driftAlong(const OdometryNoiseConfig& cfg, std::uint64_t seed, double T_s, Truth truth) {
  auto o = OdometryCorruptor::create(cfg, seed);
  EXPECT_TRUE(o.ok());
  const Eigen::Vector3d p0 = truth(0.0);
  o->reset(p0.x(), p0.y(), p0.z());
  Eigen::Vector3d p = p0, e = p0;
  const int steps = static_cast<int>(std::lround(T_s * cfg.rate_hz));
  for (int k = 1; k <= steps; ++k) {
    p = truth(k * cfg.dt_s());
    e = o->stepPlanar(p.x(), p.y(), p.z());
  }
  return Eigen::Vector3d(e.x() - p.x(), e.y() - p.y(), geometry::wrapAngle(e.z() - p.z()));
}

Eigen::Vector3d straightLine(double t) { return Eigen::Vector3d(0.25 * t, 0.0, 0.0); }  // 0.25 m/s along x

// A circle of radius 3 m at `rate` rad/s, heading along it.
auto circle(double rate) {
  return [rate](double t) {
    return Eigen::Vector3d(3.0 * std::cos(rate * t), 3.0 * std::sin(rate * t),
                           geometry::wrapAngle(rate * t + std::numbers::pi / 2));
  };
}

// Sample variance of the planar drift after T seconds over n seeded runs of the odometry integrator
// alone, along `truth` (default: a straight line).
template <class Truth = decltype(&straightLine)>
Eigen::Vector3d driftVariance(const OdometryNoiseConfig& cfg, double T_s, int runs, Truth truth = &straightLine) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  for (int run = 0; run < runs; ++run) {
    const Eigen::Vector3d e = driftAlong(cfg, static_cast<std::uint64_t>(1000 + run), T_s, truth);
    sum += e;
    sum2 += e.cwiseProduct(e);
  }
  const Eigen::Vector3d mean = sum / runs;
  return (sum2 - runs * mean.cwiseProduct(mean)) / (runs - 1);
}

TEST(Odometry, Eq41LiteralDriftVarianceIsTDtSigma) {
  OdometryNoiseConfig cfg;  // thesis defaults, 100 Hz
  const double T = 20.0;
  const Eigen::Vector3d v = driftVariance(cfg, T, 1000);
  const Eigen::Vector3d pred = cfg.predictedVariance(T);
  EXPECT_NEAR(pred.x(), T * 0.01 * 0.00138, 1e-15);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(v[i] / pred[i], 1.0, 0.10) << "axis " << i << ": " << v[i] << " vs " << pred[i];
}

TEST(Odometry, RandomWalkDriftVarianceIsTSigma) {
  OdometryNoiseConfig cfg;
  cfg.profile = OdometryNoiseProfile::kRandomWalk;
  const double T = 20.0;
  const Eigen::Vector3d v = driftVariance(cfg, T, 1000);
  const Eigen::Vector3d pred = cfg.predictedVariance(T);
  EXPECT_NEAR(pred.x(), T * 0.00138, 1e-15);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(v[i] / pred[i], 1.0, 0.10) << "axis " << i << ": " << v[i] << " vs " << pred[i];
  // The stress profile drifts 1/dt = 100 times more in variance than the literal one.
  OdometryNoiseConfig literal;
  EXPECT_NEAR(pred.x() / literal.predictedVariance(T).x(), 100.0, 1e-9);
}

TEST(Odometry, WithoutNoiseTheIntegratorReproducesACurvedTrajectory) {
  // Checks the SE(2) compose/relative operators of Eq. 4.1: zero noise must give back P exactly.
  OdometryNoiseConfig cfg;
  cfg.sigma2_x_m2ps = cfg.sigma2_y_m2ps = cfg.sigma2_yaw_rad2ps = 0.0;
  auto o = OdometryCorruptor::create(cfg, 1);
  ASSERT_TRUE(o.ok());
  auto truth = [](double t) {
    return Eigen::Vector3d(3.0 * std::cos(0.1 * t), 2.0 * std::sin(0.1 * t),
                           geometry::wrapAngle(0.1 * t + std::numbers::pi / 2));
  };
  o->reset(truth(0).x(), truth(0).y(), truth(0).z());
  for (int k = 1; k <= 10000; ++k) {
    const Eigen::Vector3d p = truth(k * 0.01);
    const Eigen::Vector3d e = o->stepPlanar(p.x(), p.y(), p.z());
    ASSERT_NEAR((e.head<2>() - p.head<2>()).norm(), 0.0, 1e-9) << k;
    ASSERT_NEAR(geometry::wrapAngle(e.z() - p.z()), 0.0, 1e-9) << k;
  }
}

TEST(Odometry, WorldFrameNoiseGivesEveryPathTheSameDrift) {
  OdometryNoiseConfig cfg;
  cfg.profile = OdometryNoiseProfile::kRandomWalk;
  cfg.sigma2_yaw_rad2ps = 0.0;  // no heading error (which turns each path's motion its own way)
  const double T = 200.0;
  cfg.world_frame_xy_noise = false;  // Eq. 4.1: drawn in the estimate's frame, so each path turns it its own way
  const Eigen::Vector3d a = driftAlong(cfg, 7, T, straightLine), b = driftAlong(cfg, 7, T, circle(0.08));
  EXPECT_GT((a - b).norm(), 0.1) << a.transpose() << " / " << b.transpose();
  cfg.world_frame_xy_noise = true;
  const Eigen::Vector3d c = driftAlong(cfg, 7, T, straightLine), d = driftAlong(cfg, 7, T, circle(0.08));
  EXPECT_GT(c.norm(), 0.1);  // sqrt(2 T sigma^2) = 0.74 m expected
  EXPECT_LT((c - d).norm(), 1e-9) << c.transpose() << " / " << d.transpose();
}

TEST(Odometry, WorldFrameNoiseHasTheSameVariance) {
  OdometryNoiseConfig cfg;
  cfg.profile = OdometryNoiseProfile::kRandomWalk;
  cfg.world_frame_xy_noise = true;
  const double T = 20.0;
  const Eigen::Vector3d v = driftVariance(cfg, T, 1000, circle(0.2));
  const Eigen::Vector3d pred = cfg.predictedVariance(T);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(v[i] / pred[i], 1.0, 0.10) << "axis " << i << ": " << v[i] << " vs " << pred[i];
  cfg.sigma2_y_m2ps = 2.0 * cfg.sigma2_x_m2ps;  // anisotropic: no longer the same distribution
  const Status st = cfg.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("world_frame_xy_noise"), std::string::npos) << st.error().message;
}

TEST(Odometry, FullPoseHasAbsoluteNoiseOnZRollPitch) {
  OdometryNoiseConfig cfg;
  auto o = OdometryCorruptor::create(cfg, 3);
  ASSERT_TRUE(o.ok());
  const geometry::Pose3 T = geometry::poseFromXyzRpy(1, 2, -3, 0, 0, 0.5);
  o->reset(T);
  double sz = 0, sr = 0;
  const int n = 5000;
  for (int k = 0; k < n; ++k) {
    const geometry::Pose3 e = o->step(T);
    sz += std::pow(e.translation().z() + 3.0, 2);
    sr += std::pow(geometry::rpyFromRotation(e.linear()).x(), 2);
  }
  EXPECT_NEAR(std::sqrt(sz / n), cfg.z_sigma_m, 0.05 * cfg.z_sigma_m);
  EXPECT_NEAR(std::sqrt(sr / n), cfg.roll_pitch_sigma_rad, 0.05 * cfg.roll_pitch_sigma_rad);
}

TEST(Odometry, ProfileNamesAndBadConfig) {
  EXPECT_EQ(*parseOdometryNoiseProfile("eq41"), OdometryNoiseProfile::kEq41Literal);
  EXPECT_EQ(*parseOdometryNoiseProfile("random_walk"), OdometryNoiseProfile::kRandomWalk);
  EXPECT_FALSE(parseOdometryNoiseProfile("gaussian").ok());
  OdometryNoiseConfig cfg;
  cfg.rate_hz = 0;
  auto o = OdometryCorruptor::create(cfg, 1);
  ASSERT_FALSE(o.ok());
  EXPECT_NE(o.error().message.find("odometry.rate_hz"), std::string::npos);
  cfg = OdometryNoiseConfig{};
  cfg.sigma2_x_m2ps = -1;
  EXPECT_FALSE(cfg.validate().ok());
}

std::unique_ptr<World> seabedWorld() {
  auto s = parseScene(
      "name: t\nbounds: {min: [-20, -20, -20], max: [20, 20, 0]}\nstart: {xyz: [0, 0, -2]}\n"
      "objects:\n  - {type: plane, pose: {xyz: [0, 0, -10]}, size: [100, 100]}\n",
      "t.yaml", ".");
  EXPECT_TRUE(s.ok());
  auto w = World::create(*s);
  EXPECT_TRUE(w.ok());
  return std::move(w).value();
}

TEST(NavSensors, DvlImuDepthMatchTheirNoiseModels) {
  const auto w = seabedWorld();
  NavSensorConfig cfg;
  auto nav = NavSensorModel::create(*w, cfg, 9);
  ASSERT_TRUE(nav.ok());
  VehicleState s;
  s.xyz_world = Eigen::Vector3d(1, 1, -4);
  s.yaw_rad = std::numbers::pi / 2;
  s.velocity_world_mps = Eigen::Vector3d(0, 0.2, 0);  // forward, as the vehicle faces +y
  const int n = 4000;
  double dv = 0, dd = 0;
  for (int k = 0; k < n; ++k) {
    s.stamp_ns = static_cast<std::int64_t>(k) * 10'000'000;
    const DvlSample d = nav->dvl(s);
    ASSERT_TRUE(d.bottom_lock);
    EXPECT_NEAR(d.altitude_m, 6.0, 1e-4);
    dv += (d.velocity_vehicle_mps - Eigen::Vector3d(0.2, 0, 0)).squaredNorm();
    dd += std::pow(nav->depth(s).depth_m - 4.0, 2);
    (void)nav->imu(s);
  }
  EXPECT_NEAR(std::sqrt(dv / (3 * n)), cfg.dvl_sigma_mps, 0.05 * cfg.dvl_sigma_mps);
  EXPECT_NEAR(std::sqrt(dd / n), cfg.depth_noise_fraction * cfg.depth_full_scale_m, 0.05 * 0.01);
  // Yaw drift is a random walk: after 40 s its standard deviation is sqrt(40 * 1e-7) = 2 mrad;
  // one run is one sample of it, so only bound it loosely here.
  EXPECT_LT(std::abs(nav->yawDriftRad()), 5 * std::sqrt(40 * cfg.imu_yaw_drift_rad2ps));
  // No bottom in reach: no lock.
  s.xyz_world.z() = 25.0;
  EXPECT_FALSE(nav->dvl(s).bottom_lock);
}

TEST(NavSensors, ImuYawDriftVarianceGrowsLinearly) {
  const auto w = seabedWorld();
  NavSensorConfig cfg;
  cfg.imu_yaw_drift_rad2ps = 1e-4;
  const double T = 10.0;
  double sum2 = 0;
  const int runs = 1000;
  for (int r = 0; r < runs; ++r) {
    auto nav = NavSensorModel::create(*w, cfg, static_cast<std::uint64_t>(r + 1));
    ASSERT_TRUE(nav.ok());
    VehicleState s;
    s.xyz_world = Eigen::Vector3d(0, 0, -2);
    for (int k = 0; k <= 100; ++k) {
      s.stamp_ns = static_cast<std::int64_t>(k) * 100'000'000;
      (void)nav->imu(s);
    }
    sum2 += nav->yawDriftRad() * nav->yawDriftRad();
  }
  EXPECT_NEAR(sum2 / runs / (T * cfg.imu_yaw_drift_rad2ps), 1.0, 0.10);
}

}  // namespace
}  // namespace vog::sim
