// vogd's configuration: the shipped files load, every documented value is the default, and bad
// input is refused with file:line, the full key and the allowed range.
#include "test_support.hpp"
#include "vog/app/vogd_config.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

namespace vog::app {
namespace {

std::filesystem::path configDir() { return vog::test::sourceDir() / "config"; }

Result<VogdConfig> parse(const std::string& text) { return parseVogdConfig(text, "test.yaml", configDir()); }

std::string errorOf(const std::string& text) {
  auto c = parse(text);
  EXPECT_FALSE(c.ok()) << text;
  return c.ok() ? std::string() : c.error().message;
}

// `text` written to `file` with `mode`.
std::filesystem::path writeFile(const std::filesystem::path& file, const std::string& text,
                                std::filesystem::perms mode) {
  std::ofstream(file, std::ios::binary) << text;
  std::filesystem::permissions(file, mode);
  return file;
}

constexpr auto kOwnerOnly = std::filesystem::perms::owner_read | std::filesystem::perms::owner_write;
constexpr auto kWorldReadable = kOwnerOnly | std::filesystem::perms::group_read | std::filesystem::perms::others_read;

TEST(VogdConfig, ShippedFilesLoad) {
  for (const char* f : {"vogd.yaml", "sim/pilings.yaml", "sim/propeller.yaml"}) {
    auto c = loadVogdConfig(configDir() / f);
    ASSERT_TRUE(c.ok()) << f << ": " << c.error().message;
    if (c->source == Source::kSim) {
      EXPECT_TRUE(std::filesystem::exists(c->sim.scene)) << c->sim.scene;
    }
  }
}

// config/vogd.yaml states every key with its default value: parsing it must give the same structs
// as parsing nothing (the device paths and addresses are examples, not defaults).
TEST(VogdConfig, DocumentedValuesAreTheDefaults) {
  auto documented = loadVogdConfig(configDir() / "vogd.yaml");
  auto defaults = parse("source: sim\nsim: {scene: scenes/pilings.yaml}\n");
  ASSERT_TRUE(documented.ok()) << documented.error().message;
  ASSERT_TRUE(defaults.ok()) << defaults.error().message;
  const VogdConfig& a = *documented;
  const VogdConfig& b = *defaults;
  const auto& ga = a.mapping.builder.grid;
  const auto& gb = b.mapping.builder.grid;
  EXPECT_EQ(ga.resolution_m, gb.resolution_m);
  EXPECT_EQ(ga.prob_hit, gb.prob_hit);
  EXPECT_EQ(ga.prob_miss, gb.prob_miss);
  EXPECT_EQ(ga.clamp_min, gb.clamp_min);
  EXPECT_EQ(ga.clamp_max, gb.clamp_max);
  EXPECT_EQ(ga.occupancy_threshold, gb.occupancy_threshold);
  EXPECT_EQ(ga.max_range_m, gb.max_range_m);
  EXPECT_EQ(ga.cloud_voxel_m, gb.cloud_voxel_m);
  EXPECT_EQ(ga.normal_neighbours, gb.normal_neighbours);
  const auto& sa = a.mapping.builder;
  const auto& sb = b.mapping.builder;
  EXPECT_EQ(sa.max_scans, sb.max_scans);
  EXPECT_NEAR(sa.max_heading_change_rad, sb.max_heading_change_rad, 1e-12);
  EXPECT_EQ(sa.max_position_stddev_m, sb.max_position_stddev_m);
  EXPECT_NEAR(sa.max_yaw_stddev_rad, sb.max_yaw_stddev_rad, 1e-5);
  EXPECT_EQ(sa.odometry_cov_x_m2_per_s, sb.odometry_cov_x_m2_per_s);
  EXPECT_EQ(sa.odometry_cov_y_m2_per_s, sb.odometry_cov_y_m2_per_s);
  EXPECT_EQ(sa.odometry_cov_yaw_rad2_per_s, sb.odometry_cov_yaw_rad2_per_s);
  const auto& la = a.mapping.loop_closer;
  const auto& lb = b.mapping.loop_closer;
  EXPECT_EQ(a.mapping.loop_closures, b.mapping.loop_closures);
  EXPECT_EQ(la.mode, lb.mode);
  EXPECT_EQ(la.acceptance.max_fitness_m2, lb.acceptance.max_fitness_m2);
  EXPECT_EQ(la.p2p_max_fitness_m2, lb.p2p_max_fitness_m2);
  EXPECT_EQ(la.point_to_plane.max_direction_stddev, lb.point_to_plane.max_direction_stddev);
  EXPECT_EQ(la.point_to_plane.sigma_point_m, lb.point_to_plane.sigma_point_m);
  EXPECT_EQ(la.point_to_plane.max_correspondence_distance_m, lb.point_to_plane.max_correspondence_distance_m);
  EXPECT_EQ(la.point_to_plane.min_correspondence_distance_m, lb.point_to_plane.min_correspondence_distance_m);
  EXPECT_NEAR(la.point_to_plane.max_normal_angle_rad, lb.point_to_plane.max_normal_angle_rad, 1e-9);
  EXPECT_EQ(la.point_to_plane.normal_search_neighbours, lb.point_to_plane.normal_search_neighbours);
  EXPECT_NEAR(la.max_heading_difference_rad, lb.max_heading_difference_rad, 1e-4);
  EXPECT_NEAR(la.max_yaw_disagreement_rad, lb.max_yaw_disagreement_rad, 1e-4);
  EXPECT_EQ(la.max_registrations, lb.max_registrations);
  EXPECT_EQ(la.max_revisits, lb.max_revisits);
  EXPECT_EQ(la.revisit_gap, lb.revisit_gap);
  EXPECT_EQ(la.min_overlap_fraction, lb.min_overlap_fraction);
  EXPECT_EQ(la.p2p_min_overlap_fraction, lb.p2p_min_overlap_fraction);
  EXPECT_EQ(la.acceptance.odometry_cov_x_m2_per_s, lb.acceptance.odometry_cov_x_m2_per_s);
  EXPECT_EQ(la.odometry_yaw_sigmas, lb.odometry_yaw_sigmas);
  EXPECT_EQ(la.odometry_cov_yaw_rad2_per_s, lb.odometry_cov_yaw_rad2_per_s);
  EXPECT_NEAR(la.registration_yaw_stddev_rad, lb.registration_yaw_stddev_rad, 1e-6);
  EXPECT_EQ(la.point_to_plane.normal_noise_floor, lb.point_to_plane.normal_noise_floor);
  EXPECT_EQ(a.mapping.graph.loop_closure_loss_scale, b.mapping.graph.loop_closure_loss_scale);
  EXPECT_EQ(a.mapping.depth_stddev_m, b.mapping.depth_stddev_m);
  EXPECT_NEAR(a.mapping.roll_pitch_stddev_rad, b.mapping.roll_pitch_stddev_rad, 1e-9);
  EXPECT_EQ(a.mapping.optimize_every_submap, b.mapping.optimize_every_submap);
  EXPECT_EQ(a.mapping.optimize_closed_loop_only, b.mapping.optimize_closed_loop_only);
  EXPECT_EQ(a.mapping.local_optimization_nodes, b.mapping.local_optimization_nodes);
  EXPECT_EQ(a.mapping.full_optimization_every, b.mapping.full_optimization_every);
  EXPECT_EQ(a.mapping.graph.sparse_backend, b.mapping.graph.sparse_backend);
  EXPECT_EQ(a.mapping.graph.linear_solver, b.mapping.graph.linear_solver);
  EXPECT_EQ(a.mapping.graph.attitude_from_absolute, b.mapping.graph.attitude_from_absolute);
  EXPECT_EQ(a.merge.remerge_translation_m, b.merge.remerge_translation_m);
  EXPECT_NEAR(a.merge.remerge_rotation_rad, b.merge.remerge_rotation_rad, 1e-6);
  EXPECT_EQ(a.merge.max_moves_per_sync, b.merge.max_moves_per_sync);
  EXPECT_EQ(a.merge.threads, b.merge.threads);
  const auto& pa = a.planner;
  const auto& pb = b.planner;
  EXPECT_EQ(pa.collision_box_m, pb.collision_box_m);
  EXPECT_EQ(pa.planner_range_m, pb.planner_range_m);
  EXPECT_EQ(pa.lambda, pb.lambda);
  EXPECT_EQ(pa.max_edge_m, pb.max_edge_m);
  EXPECT_EQ(pa.n_max, pb.n_max);
  EXPECT_EQ(pa.n_tol, pb.n_tol);
  EXPECT_EQ(pa.max_samples, pb.max_samples);
  EXPECT_NEAR(pa.max_heading_change_rad, pb.max_heading_change_rad, 1e-12);
  EXPECT_EQ(pa.v_max_mps, pb.v_max_mps);
  EXPECT_NEAR(pa.yaw_rate_radps, pb.yaw_rate_radps, 1e-5);
  EXPECT_EQ(pa.xy_sample_share, pb.xy_sample_share);
  EXPECT_EQ(pa.constrained_sampling, pb.constrained_sampling);
  EXPECT_EQ(pa.gain_along_edge, pb.gain_along_edge);
  EXPECT_EQ(pa.assume_free_radius_m, pb.assume_free_radius_m);
  EXPECT_EQ(pa.root_tolerance_m, pb.root_tolerance_m);
  EXPECT_EQ(pa.recovery_radius_m, pb.recovery_radius_m);
  EXPECT_EQ(pa.obstruction_retreat_m, pb.obstruction_retreat_m);
  EXPECT_EQ(pa.clearance_m, pb.clearance_m);
  EXPECT_EQ(a.revisit.after_s, b.revisit.after_s);
  EXPECT_EQ(a.revisit.anchor_span_s, b.revisit.anchor_span_s);
  EXPECT_EQ(pa.gain_unknown, pb.gain_unknown);
  EXPECT_EQ(pa.gain_free, pb.gain_free);
  EXPECT_EQ(pa.gain_occupied, pb.gain_occupied);
  EXPECT_EQ(pa.gain_threshold, pb.gain_threshold);
  EXPECT_EQ(pa.seed, pb.seed);
  const auto& na = a.nav;
  const auto& nb = b.nav;
  EXPECT_NEAR(na.dvl_mount_yaw_rad, nb.dvl_mount_yaw_rad, 1e-12);
  EXPECT_EQ(na.imu_max_gap_s, nb.imu_max_gap_s);
  EXPECT_EQ(na.imu_timeout_s, nb.imu_timeout_s);
  EXPECT_EQ(na.dvl_timeout_s, nb.dvl_timeout_s);
  EXPECT_EQ(na.depth_timeout_s, nb.depth_timeout_s);
  EXPECT_EQ(na.max_error_velocity_mps, nb.max_error_velocity_mps);
  EXPECT_EQ(na.max_speed_mps, nb.max_speed_mps);
  EXPECT_EQ(na.dvl_velocity_sigma_mps, nb.dvl_velocity_sigma_mps);
  EXPECT_NEAR(na.heading_sigma_rad, nb.heading_sigma_rad, 1e-5);
  EXPECT_EQ(na.heading_drift_rad2_per_s, nb.heading_drift_rad2_per_s);
  EXPECT_EQ(a.devices.feed.range_extraction.threshold_above_noise,
            b.devices.feed.range_extraction.threshold_above_noise);
  EXPECT_EQ(a.devices.feed.range_extraction.min_range_m, b.devices.feed.range_extraction.min_range_m);
  const DevicesSection& da = a.devices;
  const DevicesSection& db = b.devices;
  EXPECT_EQ(da.time_scale, db.time_scale);
  EXPECT_EQ(da.feed.navigation, db.feed.navigation);
  EXPECT_EQ(da.feed.dvl_format, db.feed.dvl_format);
  EXPECT_EQ(da.feed.depth.units_code, db.feed.depth.units_code);
  EXPECT_EQ(da.feed.depth.latitude_deg, db.feed.depth.latitude_deg);
  EXPECT_EQ(da.feed.depth.atmospheric_pressure_pa, db.feed.depth.atmospheric_pressure_pa);
  EXPECT_EQ(da.feed.depth.reading_is_absolute, db.feed.depth.reading_is_absolute);
  EXPECT_EQ(da.feed.imu.base_id, db.feed.imu.base_id);
  EXPECT_EQ(da.feed.origin.latitude_deg, db.feed.origin.latitude_deg);
  EXPECT_EQ(da.feed.origin.longitude_deg, db.feed.origin.longitude_deg);
  EXPECT_EQ(da.feed.align_to_vehicle, db.feed.align_to_vehicle);
  EXPECT_EQ(da.feed.backseat_max_extrapolation_s, db.feed.backseat_max_extrapolation_s);
  EXPECT_EQ(da.sonar_kind, db.sonar_kind);
  EXPECT_EQ(da.aris.address, db.aris.address);
  EXPECT_EQ(da.aris.serial_number, db.aris.serial_number);
  EXPECT_EQ(da.aris.command_port, db.aris.command_port);
  EXPECT_EQ(da.aris.beacon_port, db.aris.beacon_port);
  EXPECT_EQ(da.aris.receiver_address, db.aris.receiver_address);
  EXPECT_EQ(da.aris.sonar.model, db.aris.sonar.model);
  EXPECT_EQ(da.aris.sonar.window_start_m, db.aris.sonar.window_start_m);
  EXPECT_EQ(da.aris.sonar.window_end_m, db.aris.sonar.window_end_m);
  EXPECT_EQ(da.aris.sonar.sound_speed_mps, db.aris.sonar.sound_speed_mps);
  EXPECT_EQ(da.aris.sonar.ping_mode, db.aris.sonar.ping_mode);
  EXPECT_EQ(da.aris.sonar.frame_rate_hz, db.aris.sonar.frame_rate_hz);
  EXPECT_EQ(da.aris.sonar.salinity, db.aris.sonar.salinity);
  EXPECT_EQ(da.aris.sonar.frequency, db.aris.sonar.frequency);
  EXPECT_EQ(da.aris.sonar.samples_per_beam, db.aris.sonar.samples_per_beam);
  EXPECT_EQ(da.aris.sonar.range_resolution_m, db.aris.sonar.range_resolution_m);
  EXPECT_EQ(da.aris.sonar.receiver_gain_db, db.aris.sonar.receiver_gain_db);
  EXPECT_EQ(da.aris.stream, db.aris.stream);
  EXPECT_EQ(da.aris.keepalive_period_s, db.aris.keepalive_period_s);
  EXPECT_EQ(da.aris.settings_timeout_s, db.aris.settings_timeout_s);
  EXPECT_EQ(da.feed.aris_frames.max_frame_age_s, db.feed.aris_frames.max_frame_age_s);
  EXPECT_EQ(da.feed.aris_frames.max_frames_in_flight, db.feed.aris_frames.max_frames_in_flight);
  EXPECT_EQ(da.follower.arrival_tolerance_m, db.follower.arrival_tolerance_m);
  EXPECT_NEAR(da.follower.arrival_tolerance_rad, db.follower.arrival_tolerance_rad, 1e-12);
  EXPECT_EQ(da.follower.arrival_max_speed_mps, db.follower.arrival_max_speed_mps);
  EXPECT_EQ(da.follower.arrival_timeout_margin_s, db.follower.arrival_timeout_margin_s);
  EXPECT_EQ(da.follower.ack.resend_after_ns, db.follower.ack.resend_after_ns);
  EXPECT_EQ(da.follower.ack.max_attempts, db.follower.ack.max_attempts);
  EXPECT_EQ(a.api.bind_address, b.api.bind_address);
  EXPECT_EQ(a.api.port, b.api.port);
  const api::ApiServerConfig& ra = a.api.server;
  const api::ApiServerConfig& rb = b.api.server;
  EXPECT_EQ(ra.dispatch.max_frame_bytes, rb.dispatch.max_frame_bytes);
  EXPECT_EQ(ra.dispatch.map_blocks_per_chunk, rb.dispatch.map_blocks_per_chunk);
  EXPECT_EQ(ra.dispatch.cloud_points_per_chunk, rb.dispatch.cloud_points_per_chunk);
  EXPECT_EQ(ra.max_clients, rb.max_clients);
  EXPECT_EQ(ra.max_in_flight, rb.max_in_flight);
  EXPECT_EQ(ra.max_requests_per_s, rb.max_requests_per_s);
  EXPECT_EQ(ra.request_burst, rb.request_burst);
  EXPECT_EQ(ra.max_queued_responses, rb.max_queued_responses);
  EXPECT_EQ(ra.max_queued_waypoints, rb.max_queued_waypoints);
  EXPECT_EQ(ra.socket_send_buffer_bytes, rb.socket_send_buffer_bytes);
  EXPECT_EQ(ra.close_timeout, rb.close_timeout);
  EXPECT_EQ(ra.tls.handshake_timeout, rb.tls.handshake_timeout);
  EXPECT_EQ(ra.max_clients_per_peer, rb.max_clients_per_peer);
  EXPECT_EQ(ra.max_queued_bytes, rb.max_queued_bytes);
  EXPECT_EQ(ra.hello_timeout, rb.hello_timeout);
  EXPECT_EQ(ra.idle_timeout, rb.idle_timeout);
  EXPECT_EQ(ra.write_timeout, rb.write_timeout);
  EXPECT_EQ(a.log_level, b.log_level);
}

TEST(VogdConfig, UnknownKeyIsRefusedWithItsLine) {
  const std::string e = errorOf("source: devices\nmapping:\n  grid:\n    resolution: 0.1\n");
  EXPECT_NE(e.find("test.yaml:4: mapping.grid.resolution: unknown key"), std::string::npos) << e;
  EXPECT_NE(e.find("resolution_m"), std::string::npos) << e;  // lists what is allowed
  EXPECT_NE(errorOf("source: devices\nplaner: {lambda: 1}\n").find("test.yaml:2: planer: unknown key"),
            std::string::npos);
}

TEST(VogdConfig, OutOfRangeValueNamesTheRange) {
  const std::string e = errorOf("source: devices\nmapping:\n  grid: {resolution_m: 5}\n");
  EXPECT_NE(e.find("test.yaml:3: mapping.grid.resolution_m: must be in [0.01, 1], got 5"), std::string::npos) << e;
  EXPECT_NE(errorOf("source: devices\nplanner: {lambda: -0.5}\n").find("planner.lambda: must be in [0, 100], got -0.5"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\nplanner: {revisit_after_s: -1}\n")
                .find("planner.revisit_after_s: must be in [0, 1e+06], got -1"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\napi: {port: 70000}\n").find("api.port: must be in [0, 65535], got 70000"),
            std::string::npos);
}

TEST(VogdConfig, WrongTypesAndSyntaxAreRefused) {
  EXPECT_NE(errorOf("source: devices\nplanner: {n_max: many}\n").find("planner.n_max: must be an integer, got 'many'"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\nplanner: {n_max: 2.5}\n").find("must be an integer"), std::string::npos);
  EXPECT_NE(errorOf("source: devices\nmapping: {loop_closures: {enabled: maybe}}\n").find("must be true or false"),
            std::string::npos);
  EXPECT_NE(
      errorOf("source: devices\nmission: {box_min_m: [1, 2]}\n").find("mission.box_min_m: must be a list of 3 numbers"),
      std::string::npos);
  EXPECT_NE(errorOf("source: satellite\n").find("source: must be one of sim, devices, got 'satellite'"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\nmapping: {sparse_backend: cxsparse}\n")
                .find("mapping.sparse_backend: must be one of eigen, suitesparse, got 'cxsparse'"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\nmapping: {linear_solver: qr}\n")
                .find("mapping.linear_solver: must be one of cholesky, cg, got 'qr'"),
            std::string::npos);
  auto cg = parse("source: sim\nsim: {scene: scenes/pilings.yaml}\nmapping: {linear_solver: cg}\n");
  ASSERT_TRUE(cg.ok()) << cg.error().message;
  EXPECT_EQ(cg->mapping.graph.linear_solver, slam::LinearSolver::kChainPreconditionedCg);
  EXPECT_NE(errorOf("source: devices\nmapping: [1, 2]\n").find("mapping: must be a mapping"), std::string::npos);
  EXPECT_NE(errorOf("source: devices\nmapping:\n  grid: {resolution_m: 0.1\n").find("test.yaml:"), std::string::npos);
  EXPECT_NE(errorOf("- 1\n- 2\n").find("must be a mapping of sections"), std::string::npos);
  EXPECT_NE(errorOf("source: devices\nplanner: {lambda: .nan}\n").find("planner.lambda: must be a number"),
            std::string::npos);
}

TEST(VogdConfig, CrossFieldRulesAreChecked) {
  EXPECT_NE(errorOf("source: devices\nmission: {box_min_m: [0, 0, 0], box_max_m: [1, 1, 0]}\n")
                .find("mission.box_max_m: must exceed box_min_m"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\ndevices: {imu: {can_interface: can0, unix_seqpacket: /run/x}}\n")
                .find("devices.imu.unix_seqpacket: give either"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\napi: {tls: {certificate_file: server.pem}}\n")
                .find("api.tls.private_key_file: give both certificate_file and private_key_file"),
            std::string::npos);
  // The device backend's navigation needs its devices.
  EXPECT_NE(errorOf("source: devices\ndevices:\n  navigation: backseat\n  backseat: {enabled: false}\n")
                .find("devices.navigation: backseat needs devices.backseat.enabled"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\ndevices:\n  dvl: {enabled: false}\n")
                .find("devices.navigation: dead_reckoning needs the dvl, imu and depth devices enabled"),
            std::string::npos);
  EXPECT_NE(errorOf("source: devices\ndevices: {time_scale: 0}\n").find("devices.time_scale"), std::string::npos);
  // A component's own rule (clamping bounds around the occupancy threshold), named by section.
  const std::string e = errorOf("source: devices\nmapping:\n  grid: {clamp_max: 0.6, occupancy_threshold: 0.7}\n");
  EXPECT_NE(e.find("mapping"), std::string::npos) << e;
  // The occupancy threshold has that one rule only, whatever side of the clamping bounds it is on.
  for (const char* t : {"0.05", "0.995"}) {
    const std::string o = errorOf(std::string("source: devices\nmapping:\n  grid: {occupancy_threshold: ") + t + "}\n");
    EXPECT_NE(o.find("occupancy_threshold"), std::string::npos) << o;
    EXPECT_NE(o.find("(clamp_min, clamp_max)"), std::string::npos) << o;
  }
  // The simulator needs a scene; devices need a device path.
  EXPECT_NE(errorOf("source: sim\n").find("sim.scene: missing required key"), std::string::npos);
  EXPECT_NE(errorOf("source: devices\n").find("devices.dvl"), std::string::npos);
}

// The operator secret is refused as ssh refuses a private key, at the key's line, naming the file.
TEST(VogdConfig, ArisSettingsAreCheckedAgainstTheModel) {
  const std::string devices =
      "source: devices\ndevices:\n  dvl: {device: /dev/null}\n  depth: {device: /dev/null}\n"
      "  imu: {can_interface: can0}\n  backseat: {address: 127.0.0.1}\n";
  const std::string aris = devices + "  sonar:\n    kind: aris\n    bind_address: 127.0.0.1\n    aris:\n";
  auto ok = parse(aris + "      address: 10.0.0.5\n");
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->devices.sonar_kind, SonarKind::kAris);
  EXPECT_NE(errorOf(aris + "      address: sonar.local\n")
                .find("devices.sonar.aris.address: 'sonar.local' is not a numeric IPv4"),
            std::string::npos);
  EXPECT_NE(errorOf(aris + "      beacon_port: 0\n").find("give the sonar's address or listen for its beacon"),
            std::string::npos);
  EXPECT_NE(
      errorOf(aris + "      window_end_m: 60\n").find("devices.sonar.aris.window_end_m: 60, outside the ARIS 1800's"),
      std::string::npos);
  EXPECT_NE(errorOf(aris + "      ping_mode: 6\n").find("devices.sonar.aris.ping_mode: 6"), std::string::npos);
  EXPECT_NE(errorOf(aris + "      salinity: sea\n").find("devices.sonar.aris.salinity: must be one of"),
            std::string::npos);
  EXPECT_NE(errorOf(aris + "      windows_start_m: 1\n").find("devices.sonar.aris.windows_start_m: unknown key"),
            std::string::npos);
  // Frames must be sent somewhere the sonar can reach.
  EXPECT_NE(errorOf(devices + "  sonar: {kind: aris, bind_address: 0.0.0.0}\n")
                .find("set devices.sonar.aris.receiver_address"),
            std::string::npos);
  EXPECT_TRUE(
      parse(devices + "  sonar: {kind: aris, bind_address: 0.0.0.0, aris: {receiver_address: 192.168.1.20}}\n").ok());
}

TEST(VogdConfig, SecretFileIsCheckedWhenRead) {
  test::TempDir dir("vog-config");
  const auto withSecret = [](const std::filesystem::path& f) {
    return "source: devices\napi:\n  port: 0\n  secret_file: " + f.string() + "\n";
  };
  const std::string secret = "correct horse battery staple\n";
  const auto shared = writeFile(dir.path() / "shared", secret, kWorldReadable);
  std::string e = errorOf(withSecret(shared));
  EXPECT_NE(e.find("test.yaml:4: api.secret_file: " + shared.string() + " has mode 0644"), std::string::npos) << e;
  EXPECT_NE(e.find("chmod 600 " + shared.string()), std::string::npos) << e;
  e = errorOf(withSecret(dir.path()));
  EXPECT_NE(e.find("test.yaml:4: api.secret_file: " + dir.path().string() + " is a directory"), std::string::npos) << e;
  e = errorOf(withSecret(dir.path() / "missing"));
  EXPECT_NE(e.find("test.yaml:4: api.secret_file: cannot open " + (dir.path() / "missing").string()), std::string::npos)
      << e;
  e = errorOf(withSecret(writeFile(dir.path() / "short", "fifteen bytes!!\n", kOwnerOnly)));
  EXPECT_NE(e.find("test.yaml:4: api.secret_file:"), std::string::npos) << e;
  EXPECT_NE(e.find("holds 15 bytes, fewer than 16 bytes (a secret has 16 to 4096 bytes)"), std::string::npos) << e;
  e = errorOf(withSecret(writeFile(dir.path() / "long", std::string(4097, 'x'), kOwnerOnly)));
  EXPECT_NE(e.find("holds too many bytes (a secret has 16 to 4096 bytes)"), std::string::npos) << e;

  const auto good = writeFile(dir.path() / "good", secret, kOwnerOnly);
  auto c = parse("source: sim\nsim: {scene: scenes/pilings.yaml}\napi: {secret_file: " + good.string() + "}\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->api.secret_file, good);
  EXPECT_EQ(readSecretFile(good).value(), "correct horse battery staple");
}

// The certificate and key are loaded by the function the server starts with.
TEST(VogdConfig, TlsFilesAreLoadedAsTheServerLoadsThem) {
  test::TempDir dir("vog-config");
  const auto garbage = writeFile(dir.path() / "server.pem", "-----BEGIN CERTIFICATE-----\nnot base64\n", kOwnerOnly);
  const auto key = writeFile(dir.path() / "server.key", "not a key\n", kOwnerOnly);
  std::string e = errorOf("source: devices\napi:\n  tls:\n    certificate_file: " + garbage.string() +
                          "\n    private_key_file: " + key.string() + "\n");
  EXPECT_NE(e.find("test.yaml:4: api.tls.certificate_file: cannot use " + garbage.string()), std::string::npos) << e;
  e = errorOf("source: devices\napi:\n  tls:\n    private_key_file: " + key.string() +
              "\n    certificate_file: missing.pem\n");
  EXPECT_NE(e.find("test.yaml:5: api.tls.certificate_file: cannot use " + (configDir() / "missing.pem").string()),
            std::string::npos)
      << e;
}

TEST(VogdConfig, MissingSceneIsRefused) {
  const std::string e = errorOf("source: sim\nsim:\n  scene: scenes/missing.yaml\n");
  EXPECT_NE(e.find("test.yaml:3: sim.scene: cannot open scene " + (configDir() / "scenes/missing.yaml").string()),
            std::string::npos)
      << e;
}

TEST(VogdConfig, BindAddressMustBeAnIpAddress) {
  EXPECT_NE(errorOf("source: devices\napi:\n  bind_address: vehicle.local\n")
                .find("test.yaml:3: api.bind_address: must be an IPv4 or IPv6 address, got 'vehicle.local'"),
            std::string::npos);
  for (const char* address : {"0.0.0.0", "::1", "192.168.1.2"}) {
    auto c =
        parse(std::string("source: sim\nsim: {scene: scenes/pilings.yaml}\napi: {bind_address: '") + address + "'}\n");
    ASSERT_TRUE(c.ok()) << c.error().message;
    EXPECT_EQ(c->api.bind_address, address);
  }
}

// Every ApiServerConfig setting has its key; what the file says is what the server gets.
TEST(VogdConfig, EveryServerSettingRoundTrips) {
  auto c = parse(
      "source: sim\nsim: {scene: scenes/pilings.yaml}\n"
      "api:\n"
      "  bind_address: 10.0.0.2\n  port: 29601\n  max_clients: 4096\n  max_frame_bytes: 1048576\n"
      "  map_blocks_per_chunk: 100\n  cloud_points_per_chunk: 1000\n  max_in_flight: 8\n"
      "  max_requests_per_s: 50.5\n  request_burst: 60\n  max_queued_responses: 300\n"
      "  max_queued_waypoints: 70\n  socket_send_buffer_bytes: 65536\n  close_timeout_ms: 250\n"
      "  max_clients_per_peer: 3\n  max_queued_bytes: 2097152\n  hello_timeout_ms: 2000\n"
      "  idle_timeout_ms: 60000\n  write_timeout_ms: 3000\n"
      "  tls: {handshake_timeout_ms: 1500}\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  const ApiSection& a = c->api;
  EXPECT_EQ(a.bind_address, "10.0.0.2");
  EXPECT_EQ(a.port, 29601);
  EXPECT_EQ(a.server.max_clients, 4096u);
  EXPECT_EQ(a.server.dispatch.max_frame_bytes, 1048576u);
  EXPECT_EQ(a.server.dispatch.map_blocks_per_chunk, 100u);
  EXPECT_EQ(a.server.dispatch.cloud_points_per_chunk, 1000u);
  EXPECT_EQ(a.server.max_in_flight, 8u);
  EXPECT_EQ(a.server.max_requests_per_s, 50.5);
  EXPECT_EQ(a.server.request_burst, 60.0);
  EXPECT_EQ(a.server.max_queued_responses, 300u);
  EXPECT_EQ(a.server.max_queued_waypoints, 70u);
  EXPECT_EQ(a.server.socket_send_buffer_bytes, 65536);
  EXPECT_EQ(a.server.close_timeout, std::chrono::milliseconds(250));
  EXPECT_EQ(a.server.tls.handshake_timeout, std::chrono::milliseconds(1500));
  EXPECT_EQ(a.server.max_clients_per_peer, 3u);
  EXPECT_EQ(a.server.max_queued_bytes, 2097152u);
  EXPECT_EQ(a.server.hello_timeout, std::chrono::milliseconds(2000));
  EXPECT_EQ(a.server.idle_timeout, std::chrono::milliseconds(60000));
  EXPECT_EQ(a.server.write_timeout, std::chrono::milliseconds(3000));
  EXPECT_TRUE(a.server.validate().ok());
}

// The ranges are the server's (vog/api/limits.hpp), named with the key's line.
TEST(VogdConfig, ServerSettingsOutOfRangeNameTheirRange) {
  const struct {
    const char* line;
    const char* expected;
  } cases[] = {
      {"max_clients: 5000", "api.max_clients: must be in [1, 4096], got 5000"},
      {"max_frame_bytes: 1000", "api.max_frame_bytes: must be in [65536, 1073741824], got 1000"},
      {"map_blocks_per_chunk: 0", "api.map_blocks_per_chunk: must be in [1, 1048576], got 0"},
      {"cloud_points_per_chunk: 0", "api.cloud_points_per_chunk: must be in [1, 16777216], got 0"},
      {"max_in_flight: 2000", "api.max_in_flight: must be in [1, 1024], got 2000"},
      {"max_requests_per_s: 0", "api.max_requests_per_s: must be in [0.001, 1e+06], got 0"},
      {"request_burst: 0.5", "api.request_burst: must be in [1, 1e+06], got 0.5"},
      {"max_queued_responses: 70000", "api.max_queued_responses: must be in [1, 65536], got 70000"},
      {"max_queued_waypoints: 0", "api.max_queued_waypoints: must be in [1, 65536], got 0"},
      {"socket_send_buffer_bytes: -1", "api.socket_send_buffer_bytes: must be in [0, 67108864], got -1"},
      {"close_timeout_ms: 0", "api.close_timeout_ms: must be in [1, 60000], got 0"},
      {"tls: {handshake_timeout_ms: 0}", "api.tls.handshake_timeout_ms: must be in [1, 600000], got 0"},
      {"max_clients_per_peer: 0", "api.max_clients_per_peer: must be in [1, 4096], got 0"},
      {"max_queued_bytes: 1000", "api.max_queued_bytes: must be in [65536, 4294967296], got 1000"},
      {"hello_timeout_ms: 50", "api.hello_timeout_ms: must be in [100, 600000], got 50"},
      {"idle_timeout_ms: 999", "api.idle_timeout_ms: must be in [1000, 86400000], got 999"},
      {"write_timeout_ms: 99", "api.write_timeout_ms: must be in [100, 600000], got 99"},
  };
  for (const auto& c : cases) {
    const std::string e = errorOf(std::string("source: devices\napi:\n  ") + c.line + "\n");
    EXPECT_NE(e.find(std::string("test.yaml:3: ") + c.expected), std::string::npos) << c.line << ": " << e;
  }
}

// Rules across keys are the server's own, reported at the line of the key at fault.
TEST(VogdConfig, ServerCrossFieldRulesNameTheKeyAtFault) {
  // The default chunks need 32768 x 24 + 1024 = 787456 bytes.
  std::string e = errorOf("source: devices\napi:\n  port: 0\n  max_frame_bytes: 787455\n");
  EXPECT_NE(e.find("test.yaml:4: api.max_frame_bytes: must be in [787456, 1073741824] for map_blocks_per_chunk 256 "
                   "and cloud_points_per_chunk 32768, got 787455"),
            std::string::npos)
      << e;
  auto c = parse("source: sim\nsim: {scene: scenes/pilings.yaml}\napi: {max_frame_bytes: 787456}\n");
  EXPECT_TRUE(c.ok()) << c.error().message;
  // A chunk larger than the (default) frame is the chunk size's fault.
  e = errorOf("source: devices\napi:\n  port: 0\n  map_blocks_per_chunk: 2000\n");
  EXPECT_NE(e.find("test.yaml:4: api.map_blocks_per_chunk: 2000 is outside [1, 1906]"), std::string::npos) << e;
  e = errorOf("source: devices\napi:\n  max_in_flight: 32\n  max_queued_responses: 16\n");
  EXPECT_NE(e.find("test.yaml:4: api.max_queued_responses: 16 is"), std::string::npos) << e;
  EXPECT_NE(e.find("max_in_flight 32"), std::string::npos) << e;
  e = errorOf("source: devices\napi:\n  max_frame_bytes: 4194304\n  max_queued_bytes: 1048576\n");
  EXPECT_NE(e.find("test.yaml:4: api.max_queued_bytes: 1048576 is"), std::string::npos) << e;
}

// The mission folder: checked by writing there, as vogd will; nothing is left behind.
TEST(VogdConfig, MissionDirectoryMustBeWritable) {
  test::TempDir dir("vog-config");
  auto c =
      parse("source: sim\nsim: {scene: scenes/pilings.yaml}\nmission:\n  directory: " + dir.path().string() + "\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->mission.directory_setting, "test.yaml:4: mission.directory");
  const std::filesystem::path folder = c->mission.directory / c->mission.name;
  EXPECT_TRUE(checkMissionDirectory(folder, c->mission.directory_setting).ok());
  EXPECT_FALSE(std::filesystem::exists(folder)) << "the check creates nothing";
  std::filesystem::create_directory(folder);
  EXPECT_TRUE(checkMissionDirectory(folder, "m").ok());
  EXPECT_TRUE(std::filesystem::is_empty(folder)) << "the probe file is removed";

  const auto file = writeFile(dir.path() / "file", "x", kOwnerOnly);
  Status s = checkMissionDirectory(file, "test.yaml:4: mission.directory");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message,
            "test.yaml:4: mission.directory: " + file.string() + ": " + file.string() + " is not a directory");
  s = checkMissionDirectory(file / "missions" / "current", "m");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find(file.string() + " is not a directory"), std::string::npos) << s.error().message;
  // Not writable even by root: procfs takes no new files.
  s = checkMissionDirectory("/proc/vogd-missions/current", "m");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("m: /proc/vogd-missions/current: cannot write in /proc"), std::string::npos)
      << s.error().message;
}

TEST(VogdConfig, UnreadableFileIsNamed) {
  auto c = loadVogdConfig("/nonexistent/vogd.yaml");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("/nonexistent/vogd.yaml"), std::string::npos);
}

}  // namespace
}  // namespace vog::app
