#pragma once
// The endpoints file of `vogsim vehicle` (format in sim/README.md "Endpoints file"): where
// each simulated device can be reached and how its data is to be read, so a test or a script can
// write a vogd configuration for the run. YAML, written atomically (temporary file, fsync, rename)
// once every device listens.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include <Eigen/Core>

#include "vog/core/result.hpp"

namespace vog::vehicle {

// How the simulated sonar is reached. kFragments: its frames as fragment datagrams (sonar_udp.hpp)
// sent to sonar_address:sonar_port. kAris: a mock ARIS on the ARIS live protocol (PROTOCOLS.md) that
// a client controls over TCP at sonar_address:sonar_command_port and that sends its frames where
// the client asks.
enum class SonarKind : std::uint8_t { kFragments, kAris };
const char* toString(SonarKind kind);  // "fragments", "aris"
Result<SonarKind> parseSonarKind(std::string_view text);

struct VehicleEndpoints {
  int format_version = 1;
  std::string scene_file;
  std::string scene_name;
  std::uint64_t seed = 1;
  std::int64_t pid = 0;
  // Time base: simulated stamp_ns = (steady_clock ns - steady_ns_at_sim_zero) * speedup, where the
  // steady clock is CLOCK_MONOTONIC (shared by every process on the host).
  double speedup = 1.0;
  std::int64_t steady_ns_at_sim_zero = 0;
  std::int64_t epoch_unix_ns = 0;  // UTC of simulated stamp 0 (PD0 clock, backseat time of day)
  // World frame (x east, y north, z up) origin for the backseat's latitude/longitude.
  double origin_latitude_deg = 0.0;
  double origin_longitude_deg = 0.0;
  Eigen::Vector3d start_xyz_world = Eigen::Vector3d::Zero();
  double start_yaw_deg = 0.0;
  // DVL: PD0 ensembles on a pseudo-terminal (bottom track in instrument coordinates).
  std::string dvl_device;
  unsigned dvl_baud = 115200;
  double dvl_mount_yaw_deg = -90.0;
  // Depth: Digiquartz on a pseudo-terminal; answers P3, streams after P4.
  std::string depth_device;
  unsigned depth_baud = 9600;
  int depth_units_code = 1;
  double depth_latitude_deg = 42.0;
  double depth_atmospheric_pressure_pa = 101325.0;
  bool depth_reading_is_absolute = true;
  // IMU: can_frame records on the Unix-domain SOCK_SEQPACKET stand-in.
  std::string imu_unix_seqpacket;
  std::uint32_t imu_base_id = 0x180;
  // Sonar. A file without sonar.kind is read as kFragments.
  SonarKind sonar_kind = SonarKind::kFragments;
  std::string sonar_address = "127.0.0.1";
  // kFragments: fragment datagrams (sonar_udp.hpp) sent to this port; 0 = no sonar.
  std::uint16_t sonar_port = 0;
  // kAris: the command TCP port, the UDP port the Availability beacon goes to (0 = none) and the
  // serial number the beacon announces.
  std::uint16_t sonar_command_port = 0;
  std::uint16_t sonar_beacon_port = 0;
  std::uint32_t sonar_serial_number = 0;
  // Backseat TCP server.
  std::string backseat_address = "127.0.0.1";
  std::uint16_t backseat_port = 0;
  // Control socket (empty: none).
  std::string control_socket;
};

// Writes `file` atomically: readers see either no file or the complete one.
Status writeEndpointsFile(const std::filesystem::path& file, const VehicleEndpoints& endpoints);
// Errors name the file and the missing or bad key.
Result<VehicleEndpoints> readEndpointsFile(const std::filesystem::path& file);

// Simulated stamp of a steady-clock reading (ns), by the file's time base.
std::int64_t simStampFromSteady(const VehicleEndpoints& endpoints, std::int64_t steady_ns);

}  // namespace vog::vehicle
