#include "vog/app/vogd_config.hpp"

#include "vog/api/limits.hpp"
#include "vog/api/tls_context.hpp"
#include "vog/yaml/config_reader.hpp"

#include <asio/ip/address.hpp>
#include <asio/ssl/context.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <vector>

namespace vog::app {
namespace {

using yaml::ConfigMap;
using yaml::ConfigReader;

constexpr double kInf = std::numeric_limits<double>::infinity();

// An unsigned integer field of any width, range-checked in [min, max] (which fit the field's type).
template <class T>
void readUnsigned(ConfigMap& m, const char* key, T& field, std::uint64_t min, std::uint64_t max) {
  std::uint64_t v = field;
  m.unsignedInteger(key, v, min, max);
  field = static_cast<T>(v);
}

void readReconnect(ConfigMap m, io::ReconnectConfig& c) {
  m.integer("initial_delay_ms", c.initial_delay_ms, 1, 60'000);
  m.integer("max_delay_ms", c.max_delay_ms, 1, 3'600'000);
  m.number("factor", c.factor, 1.0, 10.0);
  m.finish();
}

void readSerial(ConfigMap& m, io::SerialConfig& c) {
  m.text("device", c.device_path);
  readUnsigned(m, "baud", c.baud, 300, 4'000'000);
  m.enumeration("parity", c.parity,
                {{"none", io::Parity::kNone}, {"odd", io::Parity::kOdd}, {"even", io::Parity::kEven}});
  m.integer("data_bits", c.data_bits, 5, 8);
  m.integer("stop_bits", c.stop_bits, 1, 2);
  m.boolean("exclusive", c.exclusive);
  readReconnect(m.map("reconnect"), c.reconnect);
}

void readPort(ConfigMap& m, const char* key, std::uint16_t& port, std::uint64_t min) {
  readUnsigned(m, key, port, min, 65535);
}

void readMapping(ConfigMap m, slam::MappingPipelineConfig& c) {
  ConfigMap g = m.map("grid");
  map::GridConfig& grid = c.builder.grid;
  g.number("resolution_m", grid.resolution_m, 0.01, 1.0);
  g.number("prob_hit", grid.prob_hit, 0.5, 0.999);
  g.number("prob_miss", grid.prob_miss, 0.001, 0.5);
  g.number("clamp_min", grid.clamp_min, 0.001, 0.5);
  g.number("clamp_max", grid.clamp_max, 0.5, 0.999);
  // Its range depends on the clamping bounds: GridConfig::validate() is the one rule, (clamp_min, clamp_max).
  g.number("occupancy_threshold", grid.occupancy_threshold, -kInf, kInf);
  g.number("max_range_m", grid.max_range_m, 0.5, 100.0);
  g.number("cloud_voxel_m", grid.cloud_voxel_m, 0.0, 2.0);
  g.integer("normal_neighbours", grid.normal_neighbours, 3, 100);
  g.finish();
  ConfigMap s = m.map("submaps");
  slam::SubmapBuilderConfig& b = c.builder;
  s.integer("max_scans", b.max_scans, 2, 100'000);
  s.degrees("max_heading_change_deg", b.max_heading_change_rad, 1.0, 360.0);
  s.number("max_position_stddev_m", b.max_position_stddev_m, 0.001, 100.0);
  s.degrees("max_yaw_stddev_deg", b.max_yaw_stddev_rad, 0.001, 180.0);
  s.number("odometry_cov_x_m2_per_s", b.odometry_cov_x_m2_per_s, 0.0, 10.0);
  s.number("odometry_cov_y_m2_per_s", b.odometry_cov_y_m2_per_s, 0.0, 10.0);
  s.number("odometry_cov_yaw_rad2_per_s", b.odometry_cov_yaw_rad2_per_s, 0.0, 10.0);
  s.finish();
  ConfigMap l = m.map("loop_closures");
  slam::LoopCloserConfig& lc = c.loop_closer;
  l.boolean("enabled", c.loop_closures);
  std::string mode = slam::toString(lc.mode);
  l.choice("mode", mode, {"degenerate", "p2p"});
  lc.mode = mode == "p2p" ? slam::LoopClosureMode::kPointToPoint2d : slam::LoopClosureMode::kDegenerate;
  l.number("max_fitness_m2", lc.acceptance.max_fitness_m2, 1e-6, 10.0);
  l.number("p2p_max_fitness_m2", lc.p2p_max_fitness_m2, 1e-6, 10.0);
  l.number("max_direction_stddev", lc.point_to_plane.max_direction_stddev, 1e-6, 10.0);
  l.number("sigma_point_m", lc.point_to_plane.sigma_point_m, 1e-4, 10.0);
  l.boolean("normal_noise_floor", lc.point_to_plane.normal_noise_floor);
  l.number("probe_max_shift_m", lc.point_to_plane.probe_max_shift_m, 0.01, 10.0);
  l.integer("probe_steps", lc.point_to_plane.probe_steps, 0, 100);
  l.number("min_probe_cost_points", lc.point_to_plane.min_probe_cost_points, 0.0, 1e6);
  l.degrees("max_normal_angle_deg", lc.point_to_plane.max_normal_angle_rad, 1.0, 180.0);
  l.integer("normal_search_neighbours", lc.point_to_plane.normal_search_neighbours, 1, 64);
  double corr = lc.point_to_plane.max_correspondence_distance_m;
  l.number("max_correspondence_distance_m", corr, 0.01, 10.0);
  lc.point_to_plane.max_correspondence_distance_m = corr;
  lc.p2p.max_correspondence_distance_m = corr;
  l.number("min_correspondence_distance_m", lc.point_to_plane.min_correspondence_distance_m, 0.01, 10.0);
  l.degrees("max_heading_difference_deg", lc.max_heading_difference_rad, 1.0, 180.0);
  l.degrees("max_yaw_disagreement_deg", lc.max_yaw_disagreement_rad, 0.1, 180.0);
  l.integer("max_registrations", lc.max_registrations, 0, 100'000);
  l.integer("max_revisits", lc.max_revisits, 0, 100'000);
  l.integer("revisit_gap", lc.revisit_gap, 1, 100'000);
  l.number("min_overlap_fraction", lc.min_overlap_fraction, 0.0, 1.0);
  l.number("p2p_min_overlap_fraction", lc.p2p_min_overlap_fraction, 0.0, 1.0);
  l.number("odometry_cov_x_m2_per_s", lc.acceptance.odometry_cov_x_m2_per_s, 1e-9, 10.0);
  l.number("odometry_cov_y_m2_per_s", lc.acceptance.odometry_cov_y_m2_per_s, 1e-9, 10.0);
  l.number("odometry_yaw_sigmas", lc.odometry_yaw_sigmas, 0.0, 100.0);
  l.number("odometry_cov_yaw_rad2_per_s", lc.odometry_cov_yaw_rad2_per_s, 0.0, 10.0);
  l.degrees("registration_yaw_stddev_deg", lc.registration_yaw_stddev_rad, 1e-3, 45.0);
  l.number("robust_loss_scale", c.graph.loop_closure_loss_scale, 1e-3, 1e3);
  l.number("consistency_confidence", c.consistency_confidence, 0.0, 0.999999);
  l.number("consistency_floor_m", c.consistency_floor_m, 0.0, 10.0);
  l.degrees("consistency_floor_deg", c.consistency_floor_rad, 0.0, 45.0);
  l.finish();
  m.number("depth_stddev_m", c.depth_stddev_m, 1e-4, 10.0);
  m.degrees("roll_pitch_stddev_deg", c.roll_pitch_stddev_rad, 1e-3, 45.0);
  m.boolean("optimize_every_submap", c.optimize_every_submap);
  m.boolean("optimize_closed_loop_only", c.optimize_closed_loop_only);
  m.integer("local_optimization_nodes", c.local_optimization_nodes, 0, 1'000'000);
  m.integer("full_optimization_every", c.full_optimization_every, 1, 1'000'000);
  m.enumeration("sparse_backend", c.graph.sparse_backend,
                {{"eigen", slam::SparseBackend::kEigen}, {"suitesparse", slam::SparseBackend::kSuiteSparse}});
  m.enumeration(
      "linear_solver", c.graph.linear_solver,
      {{"cholesky", slam::LinearSolver::kSparseCholesky}, {"cg", slam::LinearSolver::kChainPreconditionedCg}});
  m.boolean("attitude_from_absolute", c.graph.attitude_from_absolute);
  m.finish();
}

void readPlanner(ConfigMap m, plan::PlannerConfig& c, slam::RevisitConfig& revisit) {
  m.vector3("collision_box_m", c.collision_box_m, 0.01, 20.0);
  m.number("clearance_m", c.clearance_m, 0.0, 5.0);
  m.number("planner_range_m", c.planner_range_m, 0.1, 100.0);
  m.number("lambda", c.lambda, 0.0, 100.0);
  m.number("max_edge_m", c.max_edge_m, 0.05, 100.0);
  m.integer("n_max", c.n_max, 1, 100'000);
  m.integer("n_tol", c.n_tol, 1, 100'000);
  m.integer("max_samples", c.max_samples, 1, 10'000'000);
  m.degrees("max_heading_change_deg", c.max_heading_change_rad, 1.0, 180.0);
  m.number("v_max_mps", c.v_max_mps, 0.01, 10.0);
  m.degrees("yaw_rate_deg_per_s", c.yaw_rate_radps, 0.1, 180.0);
  m.number("xy_sample_share", c.xy_sample_share, 0.0, 1.0);
  m.boolean("constrained_sampling", c.constrained_sampling);
  m.boolean("gain_along_edge", c.gain_along_edge);
  m.number("assume_free_radius_m", c.assume_free_radius_m, 0.0, 100.0);
  m.number("root_tolerance_m", c.root_tolerance_m, 0.0, 10.0);
  m.number("recovery_radius_m", c.recovery_radius_m, 0.0, 10.0);
  m.number("obstruction_retreat_m", c.obstruction_retreat_m, 0.0, 5.0);
  m.number("gain_unknown", c.gain_unknown, 0.0, 1e6);
  m.number("gain_free", c.gain_free, 0.0, 1e6);
  m.number("gain_occupied", c.gain_occupied, 0.0, 1e6);
  m.number("gain_threshold", c.gain_threshold, 0.0, 1e12);
  m.unsignedInteger("seed", c.seed, 0, std::numeric_limits<std::uint64_t>::max());
  m.number("revisit_after_s", revisit.after_s, 0.0, 1e6);
  m.number("revisit_anchor_span_s", revisit.anchor_span_s, 1.0, 1e6);
  m.finish();
}

void readNav(ConfigMap m, nav::DeadReckoningConfig& c) {
  m.degrees("dvl_mount_roll_deg", c.dvl_mount_roll_rad, -180.0, 180.0);
  m.degrees("dvl_mount_pitch_deg", c.dvl_mount_pitch_rad, -90.0, 90.0);
  m.degrees("dvl_mount_yaw_deg", c.dvl_mount_yaw_rad, -180.0, 180.0);
  m.number("imu_max_gap_s", c.imu_max_gap_s, 1e-3, 10.0);
  m.number("imu_timeout_s", c.imu_timeout_s, 1e-3, 60.0);
  m.number("dvl_timeout_s", c.dvl_timeout_s, 1e-3, 60.0);
  m.number("depth_timeout_s", c.depth_timeout_s, 1e-3, 60.0);
  m.number("max_error_velocity_mps", c.max_error_velocity_mps, 1e-3, 10.0);
  m.number("max_speed_mps", c.max_speed_mps, 0.01, 20.0);
  m.number("dvl_velocity_sigma_mps", c.dvl_velocity_sigma_mps, 0.0, 1.0);
  m.degrees("heading_sigma_deg", c.heading_sigma_rad, 0.0, 45.0);
  m.number("heading_drift_rad2_per_s", c.heading_drift_rad2_per_s, 0.0, 1.0);
  m.finish();
}

void readAris(ConfigMap m, ArisLinkConfig& a, sonar::ArisFrameAssemblerConfig& frames) {
  m.text("address", a.address);
  readUnsigned(m, "serial_number", a.serial_number, 0, std::numeric_limits<std::uint32_t>::max());
  readPort(m, "command_port", a.command_port, 1);
  readPort(m, "beacon_port", a.beacon_port, 0);
  m.text("receiver_address", a.receiver_address);
  sonar::ArisSonarConfig& c = a.sonar;
  m.enumeration("model", c.model,
                {{"1200", sonar::ArisSystemType::k1200},
                 {"1800", sonar::ArisSystemType::k1800},
                 {"3000", sonar::ArisSystemType::k3000}});
  m.number("window_start_m", c.window_start_m, 0.0, 100.0);
  m.number("window_end_m", c.window_end_m, 0.0, 100.0);
  m.number("sound_speed_mps", c.sound_speed_mps, 1400.0, 1600.0);
  readUnsigned(m, "ping_mode", c.ping_mode, 1, 9);
  m.number("frame_rate_hz", c.frame_rate_hz, sonar::kArisFrameRateMinHz, sonar::kArisFrameRateMaxHz);
  m.enumeration("salinity", c.salinity,
                {{"fresh", sonar::ArisSalinity::kFresh},
                 {"brackish", sonar::ArisSalinity::kBrackish},
                 {"saltwater", sonar::ArisSalinity::kSaltwater}});
  m.enumeration("frequency", c.frequency, {{"low", sonar::ArisFrequency::kLow}, {"high", sonar::ArisFrequency::kHigh}});
  readUnsigned(m, "samples_per_beam", c.samples_per_beam, 0, sonar::kArisSamplesPerBeamMax);
  m.number("range_resolution_m", c.range_resolution_m, 0.0, 1.0);
  m.number("receiver_gain_db", c.receiver_gain_db, 0.0, sonar::kArisReceiverGainMaxDb);
  m.enumeration("packet_loss_mitigation", a.stream.packet_loss_mitigation,
                {{"pessimistic_retry", sonar::ArisPacketLossMitigation::kPessimisticRetry},
                 {"drop_partial_frames", sonar::ArisPacketLossMitigation::kDropPartialFrames}});
  m.number("keepalive_period_s", a.keepalive_period_s, 0.1, 10.0);
  m.number("settings_timeout_s", a.settings_timeout_s, 0.5, 60.0);
  m.number("max_frame_age_s", frames.max_frame_age_s, 0.1, 60.0);
  readUnsigned(m, "max_frames_in_flight", frames.max_frames_in_flight, 1, 64);
  readReconnect(m.map("reconnect"), a.reconnect);
  m.finish();
}

void readDevices(ConfigMap m, DevicesSection& d) {
  DeviceFeedConfig& f = d.feed;
  m.number("time_scale", d.time_scale, 0.01, 1000.0);
  m.enumeration("navigation", f.navigation,
                {{"dead_reckoning", NavigationSource::kDeadReckoning}, {"backseat", NavigationSource::kBackseat}});
  ConfigMap dvl = m.map("dvl");
  dvl.boolean("enabled", d.dvl_enabled);
  dvl.enumeration("format", f.dvl_format, {{"pd0", DvlFormat::kPd0}, {"pd6", DvlFormat::kPd6}});
  readSerial(dvl, d.dvl);
  dvl.finish();
  ConfigMap depth = m.map("depth");
  depth.boolean("enabled", d.depth_enabled);
  depth.number("latitude_deg", f.depth.latitude_deg, -90.0, 90.0);
  depth.integer("units_code", f.depth.units_code, 0, 8);
  depth.number("atmospheric_pressure_pa", f.depth.atmospheric_pressure_pa, 0.0, 2e5);
  depth.boolean("reading_is_absolute", f.depth.reading_is_absolute);
  readSerial(depth, d.depth);
  depth.finish();
  ConfigMap imu = m.map("imu");
  imu.boolean("enabled", d.imu_enabled);
  imu.text("can_interface", d.imu.interface);
  imu.text("unix_seqpacket", d.imu.unix_seqpacket);
  readUnsigned(imu, "base_id", f.imu.base_id, 0, 0x7FC);
  readReconnect(imu.map("reconnect"), d.imu.reconnect);
  if (!d.imu.interface.empty() && !d.imu.unix_seqpacket.empty())
    imu.fail("unix_seqpacket", "give either can_interface or unix_seqpacket, not both");
  imu.finish();
  ConfigMap sonar = m.map("sonar");
  sonar.boolean("enabled", d.sonar_enabled);
  sonar.enumeration("kind", d.sonar_kind, {{"fragments", SonarKind::kFragments}, {"aris", SonarKind::kAris}});
  sonar.text("bind_address", d.sonar.bind_address);
  readPort(sonar, "port", d.sonar.port, 0);
  readAris(sonar.map("aris"), d.aris, f.aris_frames);
  ConfigMap ex = sonar.map("range_extraction");
  sonar::RangeExtractionConfig& r = f.range_extraction;
  ex.boolean("median_denoise", r.median_denoise);
  ex.number("noise_floor_percentile", r.noise_floor_percentile, 0.0, 1.0);
  ex.number("threshold_above_noise", r.threshold_above_noise, 0.0, 255.0);
  ex.integer("min_run_samples", r.min_run_samples, 1, 1000);
  ex.number("min_range_m", r.min_range_m, 0.0, 100.0);
  ex.number("max_range_m", r.max_range_m, 0.0, kInf);
  ex.finish();
  sonar.finish();
  ConfigMap bs = m.map("backseat");
  WaypointFollowerConfig& w = d.follower;
  bs.boolean("enabled", d.backseat_enabled);
  bs.text("address", d.backseat.address);
  readPort(bs, "port", d.backseat.port, 1);
  readReconnect(bs.map("reconnect"), d.backseat.reconnect);
  bs.number("origin_latitude_deg", f.origin.latitude_deg, -80.0, 80.0);
  bs.number("origin_longitude_deg", f.origin.longitude_deg, -180.0, 180.0);
  bs.boolean("align_dead_reckoning", f.align_to_vehicle);
  bs.number("max_extrapolation_s", f.backseat_max_extrapolation_s, 0.0, 10.0);
  bs.number("arrival_tolerance_m", w.arrival_tolerance_m, 0.001, 10.0);
  bs.degrees("arrival_tolerance_deg", w.arrival_tolerance_rad, 0.01, 180.0);
  bs.number("arrival_max_speed_mps", w.arrival_max_speed_mps, 0.001, 10.0);
  bs.number("arrival_timeout_margin_s", w.arrival_timeout_margin_s, 0.0, 3600.0);
  double resend_s = 1e-9 * static_cast<double>(w.ack.resend_after_ns);
  bs.number("resend_after_s", resend_s, 0.1, 600.0);
  w.ack.resend_after_ns = std::llround(resend_s * 1e9);
  bs.integer("max_attempts", w.ack.max_attempts, 1, 100);
  bs.finish();
  ConfigMap aux = m.map("aux");
  aux.boolean("enabled", d.aux_enabled);
  aux.text("address", d.aux.tcp_address);
  readPort(aux, "port", d.aux.tcp_port, 1);
  aux.integer("slave_id", d.aux.slave_id, 1, 247);
  aux.finish();
  m.finish();
}

// The bounds of limits.hpp for the field types of ApiServerConfig.
template <class T>
void readCount(ConfigMap& m, const char* key, T& field, api::Range<std::uint64_t> range) {
  readUnsigned(m, key, field, range.min, range.max);
}

void readInt(ConfigMap& m, const char* key, int& field, api::Range<std::int64_t> range) {
  m.integer(key, field, static_cast<int>(std::max<std::int64_t>(range.min, INT_MIN)),
            static_cast<int>(std::min<std::int64_t>(range.max, INT_MAX)));
}

void readMillis(ConfigMap& m, const char* key, std::chrono::milliseconds& field, api::Range<std::int64_t> range) {
  int ms = static_cast<int>(field.count());
  readInt(m, key, ms, range);
  field = std::chrono::milliseconds(ms);
}

// Records an error of `section` ("section.key: what", the form of every validate() and of
// api::makeTlsContext) at that key's line when the file gives the key, else at its mapping's line.
void failAtNamedKey(ConfigMap root, const std::string& section, const std::string& message) {
  const std::size_t colon = message.find(": ");
  std::string key = colon == std::string::npos ? std::string() : message.substr(0, colon);
  if (!key.starts_with(section + ".") || key.find(' ') != std::string::npos) return root.fail(section, message);
  ConfigMap m = root;
  const std::string what = message.substr(colon + 2);
  for (std::size_t dot = key.find('.'); dot != std::string::npos && m.has(key.substr(0, dot)); dot = key.find('.')) {
    m = m.map(key.substr(0, dot));
    key = key.substr(dot + 1);
  }
  m.fail(key, what);
}

// The smallest max_frame_bytes for which DispatchConfig::validate() accepts the chunk sizes (its rule,
// searched: what fits in a frame grows with the frame); nullopt when no allowed frame size fits them.
std::optional<std::uint64_t> minFrameBytes(api::DispatchConfig d) {
  std::uint64_t lo = api::limits::kMaxFrameBytes.min, hi = api::limits::kMaxFrameBytes.max;
  d.max_frame_bytes = static_cast<std::uint32_t>(hi);
  if (!d.validate().ok()) return std::nullopt;
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    d.max_frame_bytes = static_cast<std::uint32_t>(mid);
    if (d.validate().ok()) {
      hi = mid;
    } else {
      lo = mid + 1;
    }
  }
  return lo;
}

// The api section: every setting of ApiServerConfig in the ranges of vog/api/limits.hpp, then the
// server's own cross-field rules and the files it will open, each reported at its key's line.
void readApi(ConfigMap& root, ApiSection& a, const std::filesystem::path& base_dir) {
  namespace lim = api::limits;
  api::ApiServerConfig& s = a.server;
  ConfigMap m = root.map("api");
  m.text("bind_address", a.bind_address);
  asio::error_code ec;
  (void)asio::ip::make_address(a.bind_address, ec);
  if (ec) m.fail("bind_address", "must be an IPv4 or IPv6 address, got '" + a.bind_address + "'");
  readPort(m, "port", a.port, 0);
  readCount(m, "max_frame_bytes", s.dispatch.max_frame_bytes, lim::kMaxFrameBytes);
  readCount(m, "map_blocks_per_chunk", s.dispatch.map_blocks_per_chunk, lim::kMapBlocksPerChunk);
  readCount(m, "cloud_points_per_chunk", s.dispatch.cloud_points_per_chunk, lim::kCloudPointsPerChunk);
  readCount(m, "max_clients", s.max_clients, lim::kMaxClients);
  readCount(m, "max_clients_per_peer", s.max_clients_per_peer, lim::kMaxClientsPerPeer);
  readCount(m, "max_in_flight", s.max_in_flight, lim::kMaxInFlight);
  m.number("max_requests_per_s", s.max_requests_per_s, lim::kMaxRequestsPerS.min, lim::kMaxRequestsPerS.max);
  m.number("request_burst", s.request_burst, lim::kRequestBurst.min, lim::kRequestBurst.max);
  readCount(m, "max_queued_responses", s.max_queued_responses, lim::kMaxQueuedResponses);
  readCount(m, "max_queued_waypoints", s.max_queued_waypoints, lim::kMaxQueuedWaypoints);
  readCount(m, "max_queued_bytes", s.max_queued_bytes, lim::kMaxQueuedBytes);
  readInt(m, "socket_send_buffer_bytes", s.socket_send_buffer_bytes, lim::kSocketSendBufferBytes);
  readMillis(m, "close_timeout_ms", s.close_timeout, lim::kCloseTimeoutMs);
  readMillis(m, "hello_timeout_ms", s.hello_timeout, lim::kHelloTimeoutMs);
  readMillis(m, "idle_timeout_ms", s.idle_timeout, lim::kIdleTimeoutMs);
  readMillis(m, "write_timeout_ms", s.write_timeout, lim::kWriteTimeoutMs);
  std::string secret;
  m.text("secret_file", secret);
  if (!secret.empty()) {
    a.secret_file = base_dir / secret;
    if (auto read = readSecretFile(a.secret_file); !read) m.fail("secret_file", read.error().message);
  }
  ConfigMap tls = m.map("tls");
  std::string certificate, key;
  tls.text("certificate_file", certificate);
  tls.text("private_key_file", key);
  if (certificate.empty() != key.empty())
    tls.fail(certificate.empty() ? "certificate_file" : "private_key_file",
             "give both certificate_file and private_key_file, or neither");
  if (!certificate.empty()) s.tls.certificate_chain_file = base_dir / certificate;
  if (!key.empty()) s.tls.private_key_file = base_dir / key;
  readMillis(tls, "handshake_timeout_ms", s.tls.handshake_timeout, lim::kTlsHandshakeTimeoutMs);
  tls.finish();
  m.finish();

  // A frame too small for the chunk sizes is the frame size's fault when the file sets it.
  if (m.has("max_frame_bytes") && !s.dispatch.validate().ok()) {
    if (const auto min = minFrameBytes(s.dispatch))
      m.fail("max_frame_bytes", "must be in [" + std::to_string(*min) + ", " + std::to_string(lim::kMaxFrameBytes.max) +
                                    "] for map_blocks_per_chunk " + std::to_string(s.dispatch.map_blocks_per_chunk) +
                                    " and cloud_points_per_chunk " + std::to_string(s.dispatch.cloud_points_per_chunk) +
                                    ", got " + std::to_string(s.dispatch.max_frame_bytes));
  }
  if (Status st = s.validate(); !st.ok()) failAtNamedKey(root, "api", st.error().message);
  if (s.tls.enabled()) {
    if (auto context = api::makeTlsContext(s.tls); !context) failAtNamedKey(root, "api", context.error().message);
  }
}

template <class T>
Status named(const char* section, const T& config) {
  Status s = config.validate();
  if (!s.ok()) return Error{std::string(section) + ": " + s.error().message};
  return s;
}

}  // namespace

Result<VogdConfig> parseVogdConfig(const std::string& text, const std::string& source_name,
                                   const std::filesystem::path& base_dir) {
  auto reader = ConfigReader::parse(text, source_name);
  if (!reader) return reader.error();
  VogdConfig c;
  c.text = text;
  ConfigMap root = (*reader)->root();
  std::string source = "sim";
  root.choice("source", source, {"sim", "devices"});
  c.source = source == "sim" ? Source::kSim : Source::kDevices;

  ConfigMap mission = root.map("mission");
  mission.vector3("box_min_m", c.mission.box_min_m, -1e4, 1e4);
  mission.vector3("box_max_m", c.mission.box_max_m, -1e4, 1e4);
  std::string dir = c.mission.directory.string();
  mission.text("directory", dir);
  c.mission.directory = dir;
  mission.text("name", c.mission.name);
  if (c.mission.name.empty() || c.mission.name.find('/') != std::string::npos || c.mission.name == "." ||
      c.mission.name == "..")
    mission.fail("name", "must be a plain folder name");
  mission.boolean("start_on_launch", c.mission.start_on_launch);
  mission.integer("max_submaps", c.mission.max_submaps, 1, 100000);
  mission.unsignedInteger("raw_log_max_bytes", c.mission.raw_log_max_bytes, std::uint64_t{1} << 20,
                          std::uint64_t{1} << 50);
  if ((c.mission.box_max_m.array() <= c.mission.box_min_m.array()).any())
    mission.fail("box_max_m", "must exceed box_min_m on every axis");
  mission.finish();

  c.mission.directory_setting = mission.has("directory") ? mission.location("directory") + ": mission.directory"
                                : mission.has("name")    ? mission.location("name") + ": mission.name"
                                                         : source_name + ": mission.directory (default)";

  ConfigMap sim = root.map("sim");
  std::string scene;
  sim.text("scene", scene, c.source == Source::kSim);
  if (!scene.empty()) c.sim.scene = base_dir / scene;
  if (c.source == Source::kSim && !scene.empty()) {
    if (auto read = yaml::readText(c.sim.scene, "scene"); !read) sim.fail("scene", read.error().message);
  }
  sim.unsignedInteger("seed", c.sim.seed, 0, std::numeric_limits<std::uint64_t>::max());
  sim.number("speedup", c.sim.speedup, 0.0, 1e6);
  sim.number("odometry_noise_scale", c.sim.odometry_noise_scale, 0.0, 1e3);
  sim.finish();

  readMapping(root.map("mapping"), c.mapping);
  ConfigMap merge = root.map("merge");
  merge.number("remerge_translation_m", c.merge.remerge_translation_m, 0.0, 10.0);
  merge.degrees("remerge_rotation_deg", c.merge.remerge_rotation_rad, 0.0, 180.0);
  merge.integer("max_moves_per_sync", c.merge.max_moves_per_sync, 0, 1'000'000);
  merge.integer("threads", c.merge.threads, 0, 64);
  merge.finish();
  readPlanner(root.map("planner"), c.planner, c.revisit);
  readNav(root.map("nav"), c.nav);
  readDevices(root.map("devices"), c.devices);

  readApi(root, c.api, base_dir);
  ConfigMap log = root.map("log");
  log.choice("level", c.log_level, {"debug", "info", "warning", "error"});
  log.finish();
  root.finish();
  if (Status s = (*reader)->status(); !s.ok()) return s.error();

  // The device backend decodes with the nav section's dead reckoning and the mapping's fan; without
  // a backseat there is no vehicle navigation to align to; waypoints go at the planner's speed.
  c.devices.feed.nav = c.nav;
  c.devices.feed.n_beams = c.mapping.builder.fan.n_beams;
  if (!c.devices.backseat_enabled) c.devices.feed.align_to_vehicle = false;
  c.devices.follower.speed_mps = c.planner.v_max_mps;
  c.devices.follower.yaw_rate_radps = c.planner.yaw_rate_radps;
  // The exploration box goes to the planner; cross-field rules of each component.
  c.planner.box_min_world_m = c.mission.box_min_m;
  c.planner.box_max_world_m = c.mission.box_max_m;
  c.planner.fan = c.mapping.builder.fan;
  // Each component's own rules, in file order; the first failure is reported.
  std::vector<Status> checks = {named("mapping", c.mapping), named("merge", c.merge), named("planner", c.planner),
                                c.nav.validate("nav")};
  if (c.source == Source::kDevices) {
    const DevicesSection& d = c.devices;
    if (d.feed.navigation == NavigationSource::kBackseat && !d.backseat_enabled)
      checks.push_back(Error{"devices.navigation: backseat needs devices.backseat.enabled"});
    if (d.feed.navigation == NavigationSource::kDeadReckoning && !(d.dvl_enabled && d.imu_enabled && d.depth_enabled))
      checks.push_back(Error{"devices.navigation: dead_reckoning needs the dvl, imu and depth devices enabled"});
    if (!d.sonar_enabled) checks.push_back(Error{"devices.sonar: the sonar must be enabled (it is what is mapped)"});
    if (d.dvl_enabled) checks.push_back(d.dvl.validate("devices.dvl"));
    if (d.depth_enabled) checks.push_back(d.depth.validate("devices.depth"));
    if (d.imu_enabled) checks.push_back(d.imu.validate("devices.imu"));
    if (d.sonar_enabled) checks.push_back(d.sonar.validate("devices.sonar"));
    if (d.sonar_enabled && d.sonar_kind == SonarKind::kAris) checks.push_back(d.aris.validate(d.sonar.bind_address));
    if (d.backseat_enabled) {
      checks.push_back(d.backseat.validate("devices.backseat"));
      checks.push_back(d.follower.validate());
    }
    checks.push_back(d.feed.validate());
    if (d.aux_enabled) checks.push_back(d.aux.validate("devices.aux"));
  }
  for (const Status& s : checks) {
    if (!s.ok()) return Error{source_name + ": " + s.error().message};
  }
  return c;
}

Result<std::string> readSecretFile(const std::filesystem::path& file) {
  const api::Range<std::uint64_t> size = api::limits::kSecretFileBytes;
  const std::string allowed =
      "(a secret has " + std::to_string(size.min) + " to " + std::to_string(size.max) + " bytes)";
  // O_NONBLOCK: a FIFO named by mistake must not hang the start.
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) return Error{errnoText("cannot open " + file.string())};
  const struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) return Error{errnoText("cannot stat " + file.string())};
  if (S_ISDIR(st.st_mode)) return Error{file.string() + " is a directory, not a file " + allowed};
  if (!S_ISREG(st.st_mode)) return Error{file.string() + " is not a regular file " + allowed};
  std::string secret(size.max + 3, '\0');  // the largest secret, a trailing CR LF, and one more byte
  const ssize_t n = ::read(fd, secret.data(), secret.size());
  if (n < 0) return Error{errnoText("cannot read " + file.string())};
  secret.resize(static_cast<std::size_t>(n));
  while (!secret.empty() && (secret.back() == '\n' || secret.back() == '\r')) secret.pop_back();
  if (secret.size() < size.min)
    return Error{file.string() + " holds " + std::to_string(secret.size()) + " bytes, fewer than " +
                 std::to_string(size.min) + " bytes " + allowed};
  if (secret.size() > size.max) return Error{file.string() + " holds too many bytes " + allowed};
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof(mode), "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return Error{file.string() + " has mode " + mode + ", accessible by group or others; chmod 600 " + file.string()};
  }
  return secret;
}

Status checkMissionDirectory(const std::filesystem::path& dir, const std::string& setting) {
  namespace fs = std::filesystem;
  const std::string where = setting + ": " + dir.string();
  // The folder itself when it exists, else its nearest existing ancestor (where vogd would create it).
  fs::path existing = dir.empty() ? fs::path(".") : dir;
  std::error_code ec;
  while (!fs::exists(existing, ec)) {
    if (ec) return Error{where + ": cannot inspect " + existing.string() + ": " + ec.message()};
    fs::path parent = existing.parent_path();
    if (parent.empty()) parent = ".";
    if (parent == existing) return Error{where + ": no folder of it exists"};
    existing = parent;
  }
  if (!fs::is_directory(existing, ec)) return Error{where + ": " + existing.string() + " is not a directory"};
  // Writing is what vogd will do there; mode bits alone do not tell (root, read-only mounts).
  std::string probe = (existing / ".vogd-check-XXXXXX").string();
  const int fd = ::mkstemp(probe.data());
  if (fd < 0) return Error{errnoText(where + ": cannot write in " + existing.string())};
  ::close(fd);
  ::unlink(probe.c_str());
  return {};
}

Result<VogdConfig> loadVogdConfig(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return Error{"cannot read configuration " + file.string()};
  std::stringstream text;
  text << in.rdbuf();
  return parseVogdConfig(text.str(), file.filename().string(), file.parent_path());
}

Status ArisLinkConfig::validate(const std::string& bind_address) const {
  const std::string prefix = "devices.sonar.aris.";
  auto ipv4 = [](const std::string& text) {
    std::error_code ec;
    const asio::ip::address a = asio::ip::make_address(text, ec);
    return !ec && a.is_v4();
  };
  if (!address.empty() && !ipv4(address)) {
    return Error{prefix + "address: '" + address + "' is not a numeric IPv4 address (empty: discovered)"};
  }
  if (address.empty() && beacon_port == 0) {
    return Error{prefix + "address: empty and beacon_port 0: give the sonar's address or listen for its beacon"};
  }
  const std::string& receiver = receiver_address.empty() ? bind_address : receiver_address;
  const std::string receiver_key =
      receiver_address.empty() ? "devices.sonar.bind_address" : prefix + "receiver_address";
  if (!ipv4(receiver) || receiver == "0.0.0.0") {
    return Error{receiver_key + ": '" + receiver + "' is not an IPv4 address the sonar can send frames to" +
                 (receiver_address.empty() ? " (set devices.sonar.aris.receiver_address)" : "")};
  }
  if (Status s = sonar.validate(); !s.ok()) return Error{prefix + s.error().message};
  if (auto derived = sonar::deriveArisAcousticSettings(sonar); !derived) {
    return Error{prefix + derived.error().message};
  }
  if (!(keepalive_period_s >= 0.1 && keepalive_period_s <= 10.0)) {
    return Error{prefix + "keepalive_period_s: " + std::to_string(keepalive_period_s) + ", must be in [0.1, 10]"};
  }
  if (!(settings_timeout_s >= 0.5 && settings_timeout_s <= 60.0)) {
    return Error{prefix + "settings_timeout_s: " + std::to_string(settings_timeout_s) + ", must be in [0.5, 60]"};
  }
  return reconnect.validate(prefix + "reconnect");
}

}  // namespace vog::app
