#pragma once
// Inertial measurement domain type shared by every IMU wire format (the CAN layout of
// drivers/imu/README.md and NovAtel RAWIMUS records). Vehicle body frame: x forward, y starboard,
// z down (the IMU is assumed aligned with the body; mounting rotations are applied by navigation).

#include <cstdint>
#include <optional>

#include <Eigen/Core>

namespace vog::imu {

struct ImuAttitude {
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;  // heading, 0 = north, positive clockwise seen from above
};

struct ImuSample {
  std::int64_t stamp_ns = 0;                          // host receive time for CAN, GPS-derived time for RAWIMUS
  std::uint32_t sequence = 0;                         // wire sequence counter (CAN: 8 bits, wraps at 256)
  std::uint32_t status = 0;                           // device status word; 0 = healthy
  std::optional<ImuAttitude> attitude;                // CAN only (an AHRS solution)
  std::optional<Eigen::Vector3d> angular_rate_radps;  // CAN only
  Eigen::Vector3d delta_velocity_mps = Eigen::Vector3d::Zero();  // integrated over dt_s
  std::optional<Eigen::Vector3d> delta_angle_rad;                // RAWIMUS only
  double dt_s = 0.01;                                            // integration interval (100 Hz default)
};

}  // namespace vog::imu
