#pragma once
// vogd's configuration: every component's config struct, read from one YAML file (config/vogd.yaml
// documents every key). Unknown keys and out-of-range values are rejected with file:line and the
// allowed range (ConfigReader); each component's own validate() runs afterwards for cross-field rules.

#include "vog/app/device_feed.hpp"
#include "vog/app/waypoint_follower.hpp"
#include "vog/core/result.hpp"
#include "vog/io/can.hpp"
#include "vog/io/modbus_client.hpp"
#include "vog/io/serial.hpp"
#include "vog/io/tcp_client.hpp"
#include "vog/io/udp.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/nav/dead_reckoning.hpp"
#include "vog/plan/planner_config.hpp"
#include "vog/slam/mapping_pipeline.hpp"
#include "vog/slam/revisit_policy.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <string>

namespace vog::app {

enum class Source { kSim, kDevices };

struct MissionSection {
  // Exploration box (world frame, z up); the operator may replace it through the API.
  Eigen::Vector3d box_min_m{-6.0, -4.5, -8.5};
  Eigen::Vector3d box_max_m{6.0, 4.5, -0.5};
  std::filesystem::path directory = "/var/lib/vogd/missions";
  std::string name = "current";  // this mission's folder in `directory`; an existing one is resumed
  bool start_on_launch = false;  // start exploring as soon as navigation is up (simulator runs)
  int max_submaps = 156;         // submap budget (thesis Table 4.2); reaching it sends the vehicle home
};

struct SimSection {
  std::filesystem::path scene;  // resolved against the configuration file's folder
  std::uint64_t seed = 1;
  double speedup = 20.0;               // simulated seconds per wall second; 0 = as fast as possible
  double odometry_noise_scale = 0.25;  // factor on the thesis Eq. 4.1 rates (random walk)
};

struct DevicesSection {
  // Stamps are the monotonic clock times this: 1 on a vehicle; a simulated vehicle that runs
  // faster than real time (vogsim vehicle --speedup) sets its speed-up.
  double time_scale = 1.0;
  bool dvl_enabled = true;
  io::SerialConfig dvl;
  bool depth_enabled = true;
  io::SerialConfig depth;
  bool imu_enabled = true;
  io::CanConfig imu;
  bool sonar_enabled = true;
  io::UdpReceiverConfig sonar;
  bool backseat_enabled = true;
  io::TcpClientConfig backseat;
  bool aux_enabled = false;
  io::ModbusConfig aux;
  // Decoding: DVL format, depth conversion, IMU ids, range extraction, navigation source, the
  // backseat's origin. Its `nav` is the top-level nav section, its `n_beams` the mapping's fan.
  DeviceFeedConfig feed;
  WaypointFollowerConfig follower;  // waypoints over the backseat
};

struct ApiSection {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 29600;
  std::uint32_t max_frame_bytes = 4u << 20;
  int max_clients = 64;
  std::filesystem::path secret_file;           // operator shared secret; empty: operator role disabled
  std::filesystem::path tls_certificate_file;  // PEM chain; set: every client speaks TLS
  std::filesystem::path tls_private_key_file;  // PEM
};

struct VogdConfig {
  Source source = Source::kSim;
  MissionSection mission;
  SimSection sim;
  slam::MappingPipelineConfig mapping;
  map::MergeConfig merge;
  plan::PlannerConfig planner;
  slam::RevisitConfig revisit;  // keys planner.revisit_*; used when loop closures are enabled
  nav::DeadReckoningConfig nav;
  DevicesSection devices;
  ApiSection api;
  std::string log_level = "info";  // debug | info | warning | error
  std::string text;                // the file as read (served by the API's config call)
};

// Reads, range-checks and validates a configuration file. Relative paths in it are resolved against
// the file's folder.
Result<VogdConfig> loadVogdConfig(const std::filesystem::path& file);
Result<VogdConfig> parseVogdConfig(const std::string& text, const std::string& source_name,
                                   const std::filesystem::path& base_dir);

}  // namespace vog::app
