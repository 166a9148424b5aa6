#include "vog/sim/survey.hpp"

#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

namespace vog::sim {

Status SurveyConfig::validate() const {
  if (!(max_duration_s > 0.0) || !std::isfinite(max_duration_s))
    return Error{"survey.max_duration_s must be finite and > 0, got " + std::to_string(max_duration_s)};
  if (!(waypoint_timeout_factor >= 1.0) || !std::isfinite(waypoint_timeout_factor))
    return Error{"survey.waypoint_timeout_factor must be finite and >= 1, got " +
                 std::to_string(waypoint_timeout_factor)};
  return LockstepConfig::validate();
}

namespace {

// A file opened for writing whose failure is remembered and reported once at the end.
class CsvFile {
 public:
  CsvFile(const std::filesystem::path& path, const char* header) : path_(path), f_(std::fopen(path.c_str(), "wb")) {
    if (f_ != nullptr) std::fprintf(f_, "%s\n", header);
  }
  ~CsvFile() {
    if (f_ != nullptr) std::fclose(f_);
  }
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;
  std::FILE* get() { return f_; }
  Status close() {
    if (f_ == nullptr) return Error{"cannot write " + path_.string() + ": " + errnoText()};
    const bool bad = std::ferror(f_) != 0;
    const int rc = std::fclose(f_);
    f_ = nullptr;
    if (bad || rc != 0) return Error{"error while writing " + path_.string()};
    return {};
  }

 private:
  std::filesystem::path path_;
  std::FILE* f_;
};

void writePose(std::FILE* f, const geometry::Pose3& T) {
  const Eigen::Vector3d p = T.translation();
  const Eigen::Vector3d rpy = geometry::rpyFromRotation(T.linear());
  std::fprintf(f, ",%.9g,%.9g,%.9g,%.9g,%.9g,%.9g", p.x(), p.y(), p.z(), rpy.x(), rpy.y(), rpy.z());
}

template <class T>
void putLe(std::string& out, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  // Little-endian on disk; this build targets little-endian hosts (x86-64, aarch64), checked below.
  static_assert(std::endian::native == std::endian::little, "frames.bin writer assumes a little-endian host");
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

template <class T>
T getLe(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

constexpr char kFrameMagic[4] = {'V', 'O', 'G', 'F'};
constexpr std::uint32_t kFrameVersion = 1;
// magic 4, version 4, stamp 8, frame_index 4, scan_index 4, n_beams 4, n_samples 4,
// window_start 8, window_length 8, sound_speed 8.
constexpr std::size_t kFrameHeaderBytes = 56;

std::string encodeFrame(const sonar::SonarFrame& f, std::uint32_t scan_index) {
  std::string out;
  out.append(kFrameMagic, 4);
  putLe<std::uint32_t>(out, kFrameVersion);
  putLe<std::int64_t>(out, f.stamp_ns);
  putLe<std::uint32_t>(out, f.frame_index);
  putLe<std::uint32_t>(out, scan_index);
  putLe<std::int32_t>(out, f.n_beams);
  putLe<std::int32_t>(out, f.n_samples);
  putLe<double>(out, f.window_start_m);
  putLe<double>(out, f.window_length_m);
  putLe<double>(out, f.sound_speed_mps);
  out.append(reinterpret_cast<const char*>(f.samples.data()), f.samples.size());
  return out;
}

std::string yamlDouble(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

// Writes every stream of a lockstep run to the survey's CSV files and frames.bin.
struct CsvSink final : SimulationSink {
  CsvSink(const std::filesystem::path& dir, int n_beams, const char* pose_cols)
      : gt(dir / "ground_truth.csv", (std::string("stamp_ns,") + pose_cols).c_str()),
        od(dir / "odometry.csv", (std::string("stamp_ns,") + pose_cols).c_str()),
        sc(dir / "scans.csv", scanHeader(n_beams).c_str()),
        sp(dir / "scan_poses.csv",
           "scan_index,stamp_ns,true_x_m,true_y_m,true_z_m,true_roll_rad,true_pitch_rad,true_yaw_rad,"
           "odom_x_m,odom_y_m,odom_z_m,odom_roll_rad,odom_pitch_rad,odom_yaw_rad"),
        dv(dir / "dvl.csv", "stamp_ns,bottom_lock,vx_mps,vy_mps,vz_mps,altitude_m"),
        im(dir / "imu.csv", "stamp_ns,roll_rad,pitch_rad,yaw_rad,wx_radps,wy_radps,wz_radps"),
        de(dir / "depth.csv", "stamp_ns,depth_m"),
        ev(dir / "events.csv", "stamp_ns,event,waypoint_index,x_m,y_m,z_m"),
        frames(dir / "frames.bin", std::ios::binary | std::ios::trunc) {}

  static std::string scanHeader(int n_beams) {
    std::string h = "stamp_ns,scan_index";
    for (int b = 0; b < n_beams; ++b) h += ",r" + std::to_string(b) + "_m";
    return h;
  }

  void truth(const VehicleState& s, const geometry::Pose3& T_odom) override {
    std::fprintf(gt.get(), "%lld", static_cast<long long>(s.stamp_ns));
    writePose(gt.get(), s.T_world_vehicle());
    std::fputc('\n', gt.get());
    std::fprintf(od.get(), "%lld", static_cast<long long>(s.stamp_ns));
    writePose(od.get(), T_odom);
    std::fputc('\n', od.get());
  }
  void imu(const ImuSample& m) override {
    std::fprintf(im.get(), "%lld,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", static_cast<long long>(m.stamp_ns), m.rpy_rad.x(),
                 m.rpy_rad.y(), m.rpy_rad.z(), m.angular_rate_vehicle_radps.x(), m.angular_rate_vehicle_radps.y(),
                 m.angular_rate_vehicle_radps.z());
  }
  void dvl(const DvlSample& m) override {
    std::fprintf(dv.get(), "%lld,%d,%.9g,%.9g,%.9g,%.9g\n", static_cast<long long>(m.stamp_ns), m.bottom_lock ? 1 : 0,
                 m.velocity_vehicle_mps.x(), m.velocity_vehicle_mps.y(), m.velocity_vehicle_mps.z(), m.altitude_m);
  }
  void depth(const DepthSample& m) override {
    std::fprintf(de.get(), "%lld,%.9g\n", static_cast<long long>(m.stamp_ns), m.depth_m);
  }
  void scan(std::uint32_t idx, const SonarPing& p, const geometry::Pose3& T_true,
            const geometry::Pose3& T_odom) override {
    std::fprintf(sc.get(), "%lld,%u", static_cast<long long>(p.scan.stamp_ns), idx);
    for (const float r : p.scan.range_m) std::fprintf(sc.get(), ",%.9g", static_cast<double>(r));
    std::fputc('\n', sc.get());
    std::fprintf(sp.get(), "%u,%lld", idx, static_cast<long long>(p.scan.stamp_ns));
    writePose(sp.get(), T_true);
    writePose(sp.get(), T_odom);
    std::fputc('\n', sp.get());
    if (p.frame.n_samples > 0) {
      const std::string bytes = encodeFrame(p.frame, idx);
      frames.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    }
  }
  Status close(const std::filesystem::path& dir) {
    frames.close();
    if (!frames) return Error{"error while writing " + (dir / "frames.bin").string()};
    for (CsvFile* f : {&gt, &od, &sc, &sp, &dv, &im, &de, &ev})
      if (auto st = f->close(); !st) return st.error();
    return {};
  }

  CsvFile gt, od, sc, sp, dv, im, de, ev;
  std::ofstream frames;
};

}  // namespace

Result<SurveySummary> runSurvey(const World& world, const std::vector<Waypoint>& waypoints, const SurveyConfig& config,
                                const std::string& path_label, const std::filesystem::path& out_dir) {
  if (auto st = config.validate(); !st) return st.error();
  if (waypoints.empty()) return Error{"survey: the path has no waypoints"};
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) return Error{"cannot create output directory " + out_dir.string() + ": " + ec.message()};

  auto sim_r = LockstepSimulation::create(world, config);
  if (!sim_r) return sim_r.error();
  LockstepSimulation sim = std::move(sim_r).value();
  VehicleModel& vehicle = sim.vehicle();
  if (auto st = vehicle.setWaypoints(waypoints); !st) return st.error();
  const Scene& scene = world.scene();

  const char* pose_cols = "x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad";
  CsvSink sink(out_dir, config.sonar.fan.n_beams, pose_cols);
  if (!sink.frames) return Error{"cannot write " + (out_dir / "frames.bin").string()};
  const auto max_ns = static_cast<std::int64_t>(config.max_duration_s * 1e9);

  SurveySummary sum;
  const int n_waypoints = static_cast<int>(waypoints.size());
  auto event = [&](const char* what, int index) {
    const Eigen::Vector3d p = vehicle.state().xyz_world;
    std::fprintf(sink.ev.get(), "%lld,%s,%d,%.9g,%.9g,%.9g\n", static_cast<long long>(vehicle.state().stamp_ns), what,
                 index, p.x(), p.y(), p.z());
  };
  auto frontIndex = [&] { return n_waypoints - static_cast<int>(vehicle.waypointsLeft()); };
  auto legDeadline = [&]() -> std::int64_t {
    if (vehicle.waypointsLeft() == 0) return 0;
    const Waypoint& wp = waypoints[static_cast<std::size_t>(frontIndex())];
    const double t_leg =
        (wp.xyz_world - vehicle.state().xyz_world).norm() / config.vehicle.max_speed_mps +
        std::abs(geometry::wrapAngle(wp.yaw_rad - vehicle.state().yaw_rad)) / config.vehicle.max_yaw_rate_radps;
    return vehicle.state().stamp_ns + static_cast<std::int64_t>((config.waypoint_timeout_factor * t_leg + 30.0) * 1e9);
  };

  sim.start(sink);
  std::int64_t deadline = legDeadline();
  int front = frontIndex();
  while (vehicle.waypointsLeft() > 0) {
    if (vehicle.state().stamp_ns >= max_ns) {
      event("time_limit", frontIndex());
      break;
    }
    const StepResult r = sim.step(sink);
    for (int k = 0; k < r.waypoints_reached; ++k) event("reached", front + k);
    sum.waypoints_reached += r.waypoints_reached;
    if (r.status == MotionStatus::kBlocked ||
        (vehicle.waypointsLeft() > 0 && vehicle.state().stamp_ns > deadline && frontIndex() == front)) {
      event(r.status == MotionStatus::kBlocked ? "blocked" : "timeout", frontIndex());
      event("skipped", frontIndex());
      vehicle.skipWaypoint();
      ++sum.waypoints_skipped;
    }
    if (frontIndex() != front) {
      front = frontIndex();
      deadline = legDeadline();
    }
  }
  if (vehicle.waypointsLeft() == 0) event("done", n_waypoints);
  sum.n_scans = sim.scanCount();
  sum.n_frames = sim.frameCount();
  sum.path_length_m = sim.pathLengthM();
  sum.duration_s = static_cast<double>(vehicle.state().stamp_ns) * 1e-9;
  sum.collisions_refused = vehicle.collisionCount();

  if (auto st = sink.close(out_dir); !st) return st.error();

  // meta.yaml: everything needed to interpret and reproduce the run.
  std::ofstream meta(out_dir / "meta.yaml", std::ios::trunc);
  const auto& fan = config.sonar.fan;
  meta << "format: vog-sim-survey\nformat_version: 1\n"
       << "scene: {name: \"" << scene.name << "\", file: \"" << scene.source_file.filename().string() << "\"}\n"
       << "path: \"" << path_label << "\"\nwaypoints: " << n_waypoints << "\nseed: " << config.seed << "\n"
       << "sim_step_hz: " << yamlDouble(config.odometry.rate_hz) << "\n"
       << "odometry: {profile: " << toString(config.odometry.profile)
       << ", rate_hz: " << yamlDouble(config.odometry.rate_hz)
       << ", sigma2_x_m2ps: " << yamlDouble(config.odometry.sigma2_x_m2ps)
       << ", sigma2_y_m2ps: " << yamlDouble(config.odometry.sigma2_y_m2ps)
       << ", sigma2_yaw_rad2ps: " << yamlDouble(config.odometry.sigma2_yaw_rad2ps)
       << ", z_sigma_m: " << yamlDouble(config.odometry.z_sigma_m)
       << ", roll_pitch_sigma_rad: " << yamlDouble(config.odometry.roll_pitch_sigma_rad) << "}\n"
       << "sonar: {rate_hz: " << yamlDouble(config.sonar_rate_hz) << ", n_beams: " << fan.n_beams
       << ", fov_deg: " << yamlDouble(geometry::rad2deg(fan.fov_rad))
       << ", spread_deg: " << yamlDouble(geometry::rad2deg(fan.spread_rad))
       << ", min_range_m: " << yamlDouble(fan.min_range_m) << ", max_range_m: " << yamlDouble(fan.max_range_m)
       << ", mount_rpy_deg: ["
       << yamlDouble(geometry::rad2deg(geometry::rpyFromRotation(fan.T_vehicle_sensor.linear()).x())) << ", "
       << yamlDouble(geometry::rad2deg(geometry::rpyFromRotation(fan.T_vehicle_sensor.linear()).y())) << ", "
       << yamlDouble(geometry::rad2deg(geometry::rpyFromRotation(fan.T_vehicle_sensor.linear()).z())) << "]"
       << ", mount_xyz_m: [" << yamlDouble(fan.T_vehicle_sensor.translation().x()) << ", "
       << yamlDouble(fan.T_vehicle_sensor.translation().y()) << ", "
       << yamlDouble(fan.T_vehicle_sensor.translation().z()) << "]"
       << ", sub_rays_per_beam: " << config.sonar.sub_rays_per_beam
       << ", range_noise_sigma_m: " << yamlDouble(config.sonar.range_noise_sigma_m)
       << ", frame_samples: " << config.sonar.frame_samples << ", frame_every: " << config.frame_every << "}\n"
       << "nav: {dvl_rate_hz: " << yamlDouble(config.nav.dvl_rate_hz)
       << ", dvl_sigma_mps: " << yamlDouble(config.nav.dvl_sigma_mps)
       << ", imu_rate_hz: " << yamlDouble(config.nav.imu_rate_hz)
       << ", imu_roll_pitch_sigma_rad: " << yamlDouble(config.nav.imu_roll_pitch_sigma_rad)
       << ", imu_yaw_sigma_rad: " << yamlDouble(config.nav.imu_yaw_sigma_rad)
       << ", imu_yaw_drift_rad2ps: " << yamlDouble(config.nav.imu_yaw_drift_rad2ps)
       << ", depth_rate_hz: " << yamlDouble(config.nav.depth_rate_hz)
       << ", depth_sigma_m: " << yamlDouble(config.nav.depth_noise_fraction * config.nav.depth_full_scale_m) << "}\n"
       << "vehicle: {max_speed_mps: " << yamlDouble(config.vehicle.max_speed_mps)
       << ", max_yaw_rate_radps: " << yamlDouble(config.vehicle.max_yaw_rate_radps) << ", collision_box_m: ["
       << yamlDouble(config.vehicle.collision_box_m.x()) << ", " << yamlDouble(config.vehicle.collision_box_m.y())
       << ", " << yamlDouble(config.vehicle.collision_box_m.z()) << "]}\n"
       << "summary: {n_scans: " << sum.n_scans << ", n_frames: " << sum.n_frames
       << ", duration_s: " << yamlDouble(sum.duration_s) << ", path_length_m: " << yamlDouble(sum.path_length_m)
       << ", waypoints_reached: " << sum.waypoints_reached << ", waypoints_skipped: " << sum.waypoints_skipped
       << ", collisions_refused: " << sum.collisions_refused << "}\n";
  meta.close();
  if (!meta) return Error{"error while writing " + (out_dir / "meta.yaml").string()};
  return sum;
}

Result<std::vector<RecordedScan>> readScans(const std::filesystem::path& scans_csv) {
  std::ifstream in(scans_csv);
  if (!in) return Error{"cannot open " + scans_csv.string()};
  std::string line;
  if (!std::getline(in, line) || line.rfind("stamp_ns,scan_index", 0) != 0)
    return Error{scans_csv.string() + ":1: header must start with 'stamp_ns,scan_index'"};
  std::vector<RecordedScan> out;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    const std::string where = scans_csv.string() + ":" + std::to_string(line_no) + ": ";
    std::vector<std::string> fields;
    std::stringstream ss(line);
    for (std::string f; std::getline(ss, f, ',');) fields.push_back(f);
    if (fields.size() < 3) return Error{where + "expected stamp_ns, scan_index and at least one range"};
    RecordedScan r;
    char* end = nullptr;
    r.scan.stamp_ns = std::strtoll(fields[0].c_str(), &end, 10);
    if (*end != '\0') return Error{where + "bad stamp_ns '" + fields[0] + "'"};
    r.scan_index = static_cast<std::uint32_t>(std::strtoul(fields[1].c_str(), &end, 10));
    if (*end != '\0') return Error{where + "bad scan_index '" + fields[1] + "'"};
    for (std::size_t i = 2; i < fields.size(); ++i) {
      const double v = std::strtod(fields[i].c_str(), &end);
      if (*end != '\0' || std::isnan(v) || v < 0.0)
        return Error{where + "bad range '" + fields[i] + "' in column " + std::to_string(i)};
      r.scan.range_m.push_back(static_cast<float>(v));
    }
    out.push_back(std::move(r));
  }
  return out;
}

Result<std::vector<RecordedFrame>> readFrames(const std::filesystem::path& frames_bin) {
  std::ifstream in(frames_bin, std::ios::binary);
  if (!in) return Error{"cannot open " + frames_bin.string()};
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string data = buffer.str();
  const auto* p = reinterpret_cast<const unsigned char*>(data.data());
  std::vector<RecordedFrame> out;
  std::size_t off = 0;
  while (off < data.size()) {
    const std::string where =
        frames_bin.string() + ": frame " + std::to_string(out.size()) + " at byte " + std::to_string(off) + ": ";
    if (data.size() - off < kFrameHeaderBytes) return Error{where + "truncated header"};
    if (std::memcmp(p + off, kFrameMagic, 4) != 0) return Error{where + "bad magic (expected VOGF)"};
    if (getLe<std::uint32_t>(p + off + 4) != kFrameVersion) return Error{where + "unsupported version"};
    RecordedFrame r;
    sonar::SonarFrame& f = r.frame;
    f.stamp_ns = getLe<std::int64_t>(p + off + 8);
    f.frame_index = getLe<std::uint32_t>(p + off + 16);
    r.scan_index = getLe<std::uint32_t>(p + off + 20);
    f.n_beams = getLe<std::int32_t>(p + off + 24);
    f.n_samples = getLe<std::int32_t>(p + off + 28);
    f.window_start_m = getLe<double>(p + off + 32);
    f.window_length_m = getLe<double>(p + off + 40);
    f.sound_speed_mps = getLe<double>(p + off + 48);
    if (f.n_beams < 1 || f.n_beams > 4096 || f.n_samples < 1 || f.n_samples > 65536)
      return Error{where + "n_beams " + std::to_string(f.n_beams) + " or n_samples " + std::to_string(f.n_samples) +
                   " out of range"};
    if (!std::isfinite(f.window_start_m) || !(f.window_length_m > 0.0) || !std::isfinite(f.window_length_m))
      return Error{where + "bad window"};
    const std::size_t n = static_cast<std::size_t>(f.n_beams) * static_cast<std::size_t>(f.n_samples);
    off += kFrameHeaderBytes;
    if (data.size() - off < n) return Error{where + "truncated samples"};
    f.samples.assign(p + off, p + off + n);
    off += n;
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace vog::sim
