#pragma once
// Lockstep simulation: the simulated vehicle and every sensor advanced together in simulated time,
// one step per odometry period. What the sensors produce is handed to a SimulationSink as it happens,
// in a fixed order per step (truth + odometry, IMU, DVL, depth, sonar), so a recorder, the mapping
// pipeline or a mock device can consume the same stream. Deterministic per seed: every model draws
// from its own seeded stream and time comes only from the step counter.
//
// Lifecycle: create() places the vehicle at the scene's start pose; start() emits the samples due at
// time 0 (the odometry starts at the true pose, thesis Eq. 4.1: P^_1 = P_1); then step() any number
// of times, changing the vehicle's waypoints in between as the caller wishes. Invariants: the
// odometry estimate was advanced exactly once per step; sample stamps never decrease.

#include "vog/core/result.hpp"
#include "vog/sim/nav_model.hpp"
#include "vog/sim/sonar_model.hpp"
#include "vog/sim/vehicle.hpp"
#include "vog/sim/world.hpp"

#include <cstdint>

namespace vog::sim {

struct LockstepConfig {
  std::uint64_t seed = 1;
  double sonar_rate_hz = 5.0;  // thesis Table 4.2, FPS_sensor
  int frame_every = 1;         // render the intensity frame of every n-th scan; 0 = none
  VehicleConfig vehicle;
  SonarModelConfig sonar;
  NavSensorConfig nav;
  OdometryNoiseConfig odometry;  // its rate is also the simulation step rate

  Status validate() const;
};

// Receives the samples of a lockstep run. Every method defaults to ignoring its sample.
class SimulationSink {
 public:
  virtual ~SimulationSink() = default;
  // Once per step: the true vehicle state and the corrupted odometry pose at the same stamp.
  virtual void truth(const VehicleState& /*state*/, const geometry::Pose3& /*T_world_vehicle_odom*/) {}
  virtual void imu(const ImuSample& /*sample*/) {}
  virtual void dvl(const DvlSample& /*sample*/) {}
  virtual void depth(const DepthSample& /*sample*/) {}
  // A sonar ping taken at the true pose; `frame` of the ping is empty unless it was rendered.
  virtual void scan(std::uint32_t /*scan_index*/, const SonarPing& /*ping*/,
                    const geometry::Pose3& /*T_world_vehicle_true*/, const geometry::Pose3& /*T_world_vehicle_odom*/) {}
};

class LockstepSimulation {
 public:
  // Borrows the World, which must outlive the simulation.
  static Result<LockstepSimulation> create(const World& world, const LockstepConfig& config);

  // Emits the samples due at the start (call once, before the first step()).
  void start(SimulationSink& sink);
  // Advances the vehicle by one odometry period and emits the samples due at the new stamp.
  StepResult step(SimulationSink& sink);

  VehicleModel& vehicle() { return vehicle_; }
  const VehicleModel& vehicle() const { return vehicle_; }
  std::int64_t stampNs() const { return vehicle_.state().stamp_ns; }
  std::int64_t stepNs() const { return step_ns_; }
  std::uint32_t scanCount() const { return n_scans_; }
  std::uint32_t frameCount() const { return n_frames_; }
  double pathLengthM() const { return path_length_m_; }
  const LockstepConfig& config() const { return config_; }

 private:
  LockstepSimulation(const LockstepConfig& config, VehicleModel vehicle, SonarModel sonar, NavSensorModel nav,
                     OdometryCorruptor odometry);
  void emit(const geometry::Pose3& T_world_vehicle_odom, SimulationSink& sink);

  LockstepConfig config_;
  VehicleModel vehicle_;
  SonarModel sonar_;
  NavSensorModel nav_;
  OdometryCorruptor odometry_;
  std::int64_t step_ns_ = 0;
  std::int64_t sonar_period_ns_ = 0, dvl_period_ns_ = 0, imu_period_ns_ = 0, depth_period_ns_ = 0;
  std::int64_t next_sonar_ns_ = 0, next_dvl_ns_ = 0, next_imu_ns_ = 0, next_depth_ns_ = 0;
  std::uint32_t n_scans_ = 0;
  std::uint32_t n_frames_ = 0;
  double path_length_m_ = 0.0;
};

}  // namespace vog::sim
