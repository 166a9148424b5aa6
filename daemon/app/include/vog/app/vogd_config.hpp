#pragma once
// vogd's configuration: every component's config struct, read from one YAML file (config/vogd.yaml
// documents every key). Unknown keys and out-of-range values are rejected with file:line and the
// allowed range (ConfigReader); each component's own validate() runs afterwards for cross-field rules.

#include "vog/app/device_feed.hpp"
#include "vog/api/api_server.hpp"
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
#include "vog/sonar/aris_command.hpp"

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
  // Cap of the raw device log (raw_log.hpp): its oldest segments are dropped beyond it.
  std::uint64_t raw_log_max_bytes = std::uint64_t{2} << 30;
  // Where the folder is set, for errors about it: "file:line: mission.directory" (or mission.name).
  std::string directory_setting = "mission.directory";
};

struct SimSection {
  std::filesystem::path scene;  // resolved against the configuration file's folder
  std::uint64_t seed = 1;
  double speedup = 20.0;               // simulated seconds per wall second; 0 = as fast as possible
  double odometry_noise_scale = 0.25;  // factor on the thesis Eq. 4.1 rates (random walk)
};

// How the imaging sonar's frames arrive (devices.sonar.kind).
enum class SonarKind {
  kFragments,  // fragment datagrams of sonar_udp.hpp (the simulated vehicle's own format)
  kAris,       // the ARIS live protocol: command channel, FramePart stream with acks, beacon
};

// devices.sonar.aris: the ARIS's command channel, its discovery and the settings sent to it.
struct ArisLinkConfig {
  std::string address;                 // the sonar's IPv4 address; empty: the sender of the first beacon
  std::uint32_t serial_number = 0;     // with discovery, the sonar to use; 0: any
  std::uint16_t command_port = 56888;  // TCP
  std::uint16_t beacon_port = 56124;   // UDP port the Availability beacons arrive on; 0: not listened to
  // The address the sonar sends its frames to (this computer, as the sonar reaches it); empty: the
  // sonar receiver's bind_address, which must then not be a wildcard.
  std::string receiver_address;
  sonar::ArisSonarConfig sonar;              // range window, ping mode, frame rate, ... (the acoustic settings)
  sonar::ArisSetFrameStreamSettings stream;  // packet-loss mitigation, interpacket delay
  double keepalive_period_s = 1.0;           // a PING this often (the sonar drops a silent client)
  // Frames that still carry other settings this long after SET_ACOUSTICS make the sonar degraded.
  double settings_timeout_s = 3.0;
  io::ReconnectConfig reconnect;  // the command channel

  // Error naming the key (devices.sonar.aris.*) and its value.
  Status validate(const std::string& bind_address) const;
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
  SonarKind sonar_kind = SonarKind::kFragments;
  io::UdpReceiverConfig sonar;  // where the frames arrive (fragments or ARIS FramePart datagrams)
  ArisLinkConfig aris;          // kind aris only
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
  std::string bind_address = "127.0.0.1";  // an IPv4 or IPv6 address
  std::uint16_t port = 29600;
  std::filesystem::path secret_file;  // operator shared secret (readSecretFile); empty: operator role disabled
  // Every other setting of the server (keys api.*, api.tls.*): limits, timeouts, chunk sizes, the TLS
  // files. Its operator_secret stays empty here: vogd reads secret_file when it starts.
  api::ApiServerConfig server;
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
// the file's folder. The files it names are checked as vogd will use them: the operator secret
// (readSecretFile), the TLS certificate and key (api::makeTlsContext), the simulator's scene.
Result<VogdConfig> loadVogdConfig(const std::filesystem::path& file);
Result<VogdConfig> parseVogdConfig(const std::string& text, const std::string& source_name,
                                   const std::filesystem::path& base_dir);

// The operator secret of api.secret_file, as ssh treats a private key: refused when it is not a
// regular file, holds fewer than 16 or more than 4096 bytes (trailing line breaks not counted), or
// is accessible by group or others (the error names the mode and `chmod 600`).
Result<std::string> readSecretFile(const std::filesystem::path& file);

// Whether vogd can open `dir` as its mission folder: an existing one must be a directory it can
// write to; a missing one must be creatable (its nearest existing ancestor a directory it can write
// to). Writes and removes one probe file; creates nothing. Errors start with `setting`.
Status checkMissionDirectory(const std::filesystem::path& dir, const std::string& setting);

}  // namespace vog::app
