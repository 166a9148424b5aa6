#pragma once
// Simulator navigation samples (sim/world nav_model.hpp) as the messages the real devices put
// on the wire: a PD0 ensemble with bottom track in instrument coordinates (DVL), an IMU sample of
// the CAN layout (drivers/imu/README.md) and a Digiquartz pressure reading. The mock devices
// (serial_devices.hpp, socket_devices.hpp) and the codec encoders take these messages as they
// are, so a simulated vehicle can feed the daemon's real decoders.
//
// Frames. The simulator's vehicle frame is x forward, y left, z up in an east-north-up world; the
// IMU reports the NED attitude of a forward-starboard-down body; the DVL reports in its
// instrument frame (RDI "ADCP Coordinate Transformation": beam 3 forward, x starboard, z up),
// mounted with R_vehicle_dvl, and PD0 bottom track is the bottom's motion (the vehicle's negated).

#include <cstdint>

#include <Eigen/Core>

#include "vog/depth/depth_types.hpp"
#include "vog/dvl/dvl_types.hpp"
#include "vog/core/result.hpp"
#include "vog/imu/imu_types.hpp"
#include "vog/sim/nav_model.hpp"

namespace vog::vehicle {

struct SimWireConfig {
  // Mount of the DVL instrument frame in the vehicle frame, R_vehicle_dvl = Rz(yaw) Ry(pitch)
  // Rx(roll); the same default as nav::DeadReckoningConfig (instrument x starboard, y forward).
  double dvl_mount_roll_rad = 0.0;
  double dvl_mount_pitch_rad = 0.0;
  double dvl_mount_yaw_rad = -1.5707963267948966;
  // Fixed-leader fields of the simulated instrument (WorkHorse Navigator: 4 beams at 30 deg).
  int dvl_beam_angle_deg = 30;
  double dvl_sound_speed_mps = 1500.0;
  // Unix time of simulated stamp 0, for the PD0 real-time clock (2026-01-01T00:00:00Z).
  std::int64_t epoch_unix_ns = 1'767'225'600'000'000'000;
  // Pressure reading: units and conversion the receiving side is configured with, so that
  // depth::toDepthSample() of the reading gives back the simulated depth.
  depth::DepthConversionConfig depth;
  int depth_decimals = 4;  // digits after the decimal point of the reading (Digiquartz default)
  // IMU integration interval written into the CAN frames (100 Hz, PROTOCOLS.md).
  double imu_dt_s = 0.01;

  // Names the first bad key and value, or is ok.
  Status validate() const;
};

// PD0 ensemble of one DVL sample: fixed and variable leader (clock from the stamp) and bottom
// track in instrument coordinates; without bottom lock every velocity is marked bad (-32768 on
// the wire) and the ranges are 0. Errors on a non-finite velocity or altitude.
Result<dvl::DvlEnsemble> toPd0Ensemble(const sim::DvlSample& sample, std::uint32_t ensemble_number,
                                       const SimWireConfig& config);

// IMU CAN sample (stamp kept, sequence as given): NED attitude and body (FRD) rates. The
// simulator models no accelerometer, so the delta velocity is zero. Errors on non-finite values.
Result<imu::ImuSample> toImuSample(const sim::ImuSample& sample, std::uint32_t sequence, const SimWireConfig& config);

// The Digiquartz reading (in config.depth.units_code units, absolute or gauge as configured) of
// the sample's depth: the inverse of depth::toDepthSample() (UNESCO 1983 inverted by bisection).
Result<double> toDigiquartzReading(const sim::DepthSample& sample, const SimWireConfig& config);

// NED roll, pitch, heading (Z-Y-X) of a forward-left-up vehicle with rotation R_world_vehicle in
// east-north-up: the inverse of nav::worldFromNedAttitude().
Eigen::Vector3d nedRollPitchHeading(const Eigen::Matrix3d& R_world_vehicle);

// Sea pressure in decibars at which depth::unescoDepth_m() gives depth_m (to 1e-9 m).
Result<double> seaPressureForDepth_dbar(double depth_m, double latitude_deg);

}  // namespace vog::vehicle
