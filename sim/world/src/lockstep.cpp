#include "vog/sim/lockstep.hpp"

#include <cmath>
#include <string>

namespace vog::sim {

Status LockstepConfig::validate() const {
  if (!(sonar_rate_hz > 0.0) || !std::isfinite(sonar_rate_hz) || sonar_rate_hz > odometry.rate_hz)
    return Error{"sim.sonar_rate_hz must be in (0, odometry.rate_hz], got " + std::to_string(sonar_rate_hz)};
  if (frame_every < 0) return Error{"sim.frame_every must be >= 0, got " + std::to_string(frame_every)};
  if (auto st = vehicle.validate(); !st) return st;
  if (auto st = sonar.validate(); !st) return st;
  if (auto st = nav.validate(); !st) return st;
  if (auto st = odometry.validate(); !st) return st;
  for (const double r : {nav.dvl_rate_hz, nav.imu_rate_hz, nav.depth_rate_hz})
    if (r > odometry.rate_hz) return Error{"nav rates must not exceed odometry.rate_hz (the simulation step rate)"};
  return {};
}

namespace {
std::int64_t periodNs(double hz) { return static_cast<std::int64_t>(std::llround(1e9 / hz)); }
}  // namespace

LockstepSimulation::LockstepSimulation(const LockstepConfig& config, VehicleModel vehicle, SonarModel sonar,
                                       NavSensorModel nav, OdometryCorruptor odometry)
    : config_(config),
      vehicle_(std::move(vehicle)),
      sonar_(std::move(sonar)),
      nav_(std::move(nav)),
      odometry_(std::move(odometry)),
      step_ns_(periodNs(config.odometry.rate_hz)),
      sonar_period_ns_(periodNs(config.sonar_rate_hz)),
      dvl_period_ns_(periodNs(config.nav.dvl_rate_hz)),
      imu_period_ns_(periodNs(config.nav.imu_rate_hz)),
      depth_period_ns_(periodNs(config.nav.depth_rate_hz)) {}

Result<LockstepSimulation> LockstepSimulation::create(const World& world, const LockstepConfig& config) {
  if (auto st = config.validate(); !st) return st.error();
  const Scene& scene = world.scene();
  auto vehicle = VehicleModel::create(world, config.vehicle, scene.T_world_start.translation(),
                                      geometry::yawOf(scene.T_world_start.linear()), 0);
  if (!vehicle) return vehicle.error();
  auto sonar = SonarModel::create(world, config.sonar, config.seed);
  if (!sonar) return sonar.error();
  auto nav = NavSensorModel::create(world, config.nav, config.seed);
  if (!nav) return nav.error();
  auto odometry = OdometryCorruptor::create(config.odometry, config.seed);
  if (!odometry) return odometry.error();
  return LockstepSimulation(config, std::move(vehicle).value(), std::move(sonar).value(), std::move(nav).value(),
                            std::move(odometry).value());
}

void LockstepSimulation::start(SimulationSink& sink) {
  const geometry::Pose3 T_true = vehicle_.state().T_world_vehicle();
  odometry_.reset(T_true);
  emit(T_true, sink);
}

StepResult LockstepSimulation::step(SimulationSink& sink) {
  const Eigen::Vector3d before = vehicle_.state().xyz_world;
  const StepResult r = vehicle_.step(step_ns_);
  path_length_m_ += (vehicle_.state().xyz_world - before).norm();
  emit(odometry_.step(vehicle_.state().T_world_vehicle()), sink);
  return r;
}

void LockstepSimulation::emit(const geometry::Pose3& T_odom, SimulationSink& sink) {
  const VehicleState& s = vehicle_.state();
  sink.truth(s, T_odom);
  if (s.stamp_ns >= next_imu_ns_) {
    sink.imu(nav_.imu(s));
    next_imu_ns_ += imu_period_ns_;
  }
  if (s.stamp_ns >= next_dvl_ns_) {
    sink.dvl(nav_.dvl(s));
    next_dvl_ns_ += dvl_period_ns_;
  }
  if (s.stamp_ns >= next_depth_ns_) {
    sink.depth(nav_.depth(s));
    next_depth_ns_ += depth_period_ns_;
  }
  if (s.stamp_ns >= next_sonar_ns_) {
    const bool with_frame = config_.frame_every > 0 && n_scans_ % static_cast<std::uint32_t>(config_.frame_every) == 0;
    const geometry::Pose3 T_true = s.T_world_vehicle();
    const SonarPing ping = sonar_.ping(T_true, s.stamp_ns, with_frame, n_frames_);
    sink.scan(n_scans_, ping, T_true, T_odom);
    if (with_frame) ++n_frames_;
    ++n_scans_;
    next_sonar_ns_ += sonar_period_ns_;
  }
}

}  // namespace vog::sim
