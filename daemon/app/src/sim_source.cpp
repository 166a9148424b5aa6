#include "vog/app/sim_source.hpp"

#include "vog/sim/lockstep.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/world.hpp"

#include <cmath>
#include <utility>

namespace vog::app {
namespace {

// Collects one step's samples; the thread forwards them after the step, outside any lock.
class StepCollector final : public sim::SimulationSink {
 public:
  void truth(const sim::VehicleState& state, const geometry::Pose3& T_odom) override {
    T_true = state.T_world_vehicle();
    T_odom_now = T_odom;
    stamp_ns = state.stamp_ns;
  }
  void scan(std::uint32_t /*scan_index*/, const sim::SonarPing& ping, const geometry::Pose3& T_true_scan,
            const geometry::Pose3& T_odom) override {
    slam::ScanInput in;
    in.T_world_vehicle_odom = T_odom;
    const Eigen::Vector3d rpy = geometry::rpyFromRotation(T_odom.linear());
    in.z_roll_pitch = Eigen::Vector3d(T_odom.translation().z(), rpy.x(), rpy.y());
    in.scan = ping.scan;
    scans.emplace_back(std::move(in), T_true_scan);
  }

  geometry::Pose3 T_true = geometry::Pose3::Identity();
  geometry::Pose3 T_odom_now = geometry::Pose3::Identity();
  std::int64_t stamp_ns = 0;
  std::vector<std::pair<slam::ScanInput, geometry::Pose3>> scans;  // with the true pose
};

}  // namespace

Result<std::unique_ptr<SimSource>> SimSource::create(const SimSection& config,
                                                     const std::optional<geometry::Pose3>& start) {
  if (config.scene.empty()) return Error{"sim.scene: required with source: sim"};
  auto scene = sim::loadScene(config.scene);
  if (!scene) return Error{"sim.scene: " + scene.error().message};
  if (start) {
    if (!geometry::isValidPose(*start)) return Error{"simulator start pose is not a finite rigid pose"};
    scene->T_world_start = *start;
  }
  auto world = sim::World::create(*scene);
  if (!world) return Error{"sim.scene: " + world.error().message};
  std::unique_ptr<SimSource> source(new SimSource(config, std::move(world).value()));

  sim::LockstepConfig sc;
  sc.seed = config.seed;
  sc.frame_every = 0;  // the daemon consumes range scans; intensity frames are for the device path
  sc.odometry.profile = sim::OdometryNoiseProfile::kRandomWalk;
  sc.odometry.sigma2_x_m2ps *= config.odometry_noise_scale;
  sc.odometry.sigma2_y_m2ps *= config.odometry_noise_scale;
  sc.odometry.sigma2_yaw_rad2ps *= config.odometry_noise_scale;
  auto simulation = sim::LockstepSimulation::create(*source->world_, sc);
  if (!simulation) return Error{"simulator: " + simulation.error().message};
  source->simulation_ = std::make_unique<sim::LockstepSimulation>(std::move(simulation).value());
  return source;
}

SimSource::SimSource(const SimSection& config, std::unique_ptr<sim::World> world)
    : config_(config), world_(std::move(world)) {}

SimSource::~SimSource() { stop(); }

Status SimSource::start(SourceSink& sink) {
  if (thread_.joinable()) return Error{"simulator already started"};
  thread_ = std::thread([this, &sink] { run(sink); });
  return {};
}

void SimSource::stop() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

Status SimSource::setWaypoints(std::vector<SourceWaypoint> waypoints) {
  for (const SourceWaypoint& w : waypoints)
    if (!geometry::isFinite(w.p_odom_m) || !std::isfinite(w.yaw_rad)) return Error{"waypoint is not finite"};
  {
    const std::lock_guard lock(mutex_);
    vehicle_idle_ = waypoints.empty();
    pending_ = std::move(waypoints);
  }
  wake_.notify_all();
  return {};
}

bool SimSource::idle() const {
  const std::lock_guard lock(mutex_);
  return !pending_ && vehicle_idle_.load();
}

Status SimSource::failure() const {
  const std::lock_guard lock(mutex_);
  if (failure_) return *failure_;
  return {};
}

std::optional<SourceObstruction> SimSource::takeObstruction() {
  const std::lock_guard lock(mutex_);
  return std::exchange(obstruction_, std::nullopt);
}

double SimSource::pathLengthM() const {
  const std::lock_guard lock(mutex_);
  return path_length_m_;
}

std::vector<api::DeviceHealth> SimSource::health() const {
  api::DeviceHealth h;
  h.name = "simulator";
  h.last_stamp_ns = stamp_ns_.load();
  h.messages = scans_.load();
  h.errors = collisions_.load();
  const std::lock_guard lock(mutex_);
  if (failure_) {
    h.state = api::DeviceState::kFailed;
    h.detail = failure_->message;
  } else {
    h.detail = "scene " + config_.scene.filename().string() + ", seed " + std::to_string(config_.seed) +
               (collisions_.load() > 0 ? ", " + std::to_string(collisions_.load()) + " collisions" : "");
    if (collisions_.load() > 0) h.state = api::DeviceState::kDegraded;
  }
  return {h};
}

void SimSource::run(SourceSink& sink) {
  sim::LockstepSimulation& simulation = *simulation_;
  StepCollector step_samples;
  // Odometry variance grows linearly in time for the random walk (thesis Eq. 4.1 rates, scaled).
  const double s2x = sim::OdometryNoiseConfig{}.sigma2_x_m2ps * config_.odometry_noise_scale;
  const double s2y = sim::OdometryNoiseConfig{}.sigma2_y_m2ps * config_.odometry_noise_scale;
  const double s2yaw = sim::OdometryNoiseConfig{}.sigma2_yaw_rad2ps * config_.odometry_noise_scale;
  const std::int64_t t0_ns = simulation.stampNs();
  auto forward = [&]() -> bool {
    const double t = 1e-9 * static_cast<double>(step_samples.stamp_ns - t0_ns);
    OdometrySample o;
    o.stamp_ns = step_samples.stamp_ns;
    o.T_odom_vehicle = step_samples.T_odom_now;
    o.sigma_xyz_m = Eigen::Vector3d(std::sqrt(s2x * t), std::sqrt(s2y * t), sim::OdometryNoiseConfig{}.z_sigma_m);
    o.sigma_yaw_rad = std::sqrt(s2yaw * t);
    sink.onOdometry(o);
    stamp_ns_ = step_samples.stamp_ns;
    for (const auto& [scan, T_true] : step_samples.scans) {
      if (!sink.onScan(scan, T_true)) return false;
      ++scans_;
    }
    step_samples.scans.clear();
    return true;
  };

  simulation.start(step_samples);
  if (!forward()) return;
  const auto wall0 = std::chrono::steady_clock::now();
  while (true) {
    ++heartbeat_;
    std::optional<std::vector<SourceWaypoint>> waypoints;
    {
      std::unique_lock lock(mutex_);
      if (config_.speedup == 0.0 && !pending_ && vehicle_idle_) {
        // As fast as possible: time stands still while the vehicle waits for its next waypoint.
        wake_.wait_for(lock, kMaxIdleWait, [&] { return stopping_ || pending_.has_value(); });
      }
      if (stopping_) return;
      waypoints = std::exchange(pending_, std::nullopt);
    }
    if (waypoints) {
      // A waypoint in the odometry frame, reached through the current odometry error.
      const geometry::Pose3 T_true_odom = step_samples.T_true * step_samples.T_odom_now.inverse();
      std::vector<sim::Waypoint> out;
      for (const SourceWaypoint& w : *waypoints) {
        const geometry::Pose3 T =
            T_true_odom * geometry::poseFromXyzRpy(w.p_odom_m.x(), w.p_odom_m.y(), w.p_odom_m.z(), 0.0, 0.0, w.yaw_rad);
        out.push_back({T.translation(), geometry::yawOf(T.linear())});
      }
      if (auto st = simulation.vehicle().setWaypoints(std::move(out)); !st) {
        const std::lock_guard lock(mutex_);
        failure_ = Error{"simulator: " + st.error().message};
        return;
      }
    }
    const sim::StepResult step = simulation.step(step_samples);
    if (step.status == sim::MotionStatus::kBlocked) {
      ++collisions_;  // the vehicle stopped short of the scene; it holds until the next waypoint
      if (const auto next = simulation.vehicle().nextWaypoint()) {
        // Reported as the vehicle knows it: in its odometry frame.
        const geometry::Pose3 T_odom_true = step_samples.T_odom_now * step_samples.T_true.inverse();
        const std::lock_guard lock(mutex_);
        obstruction_ = SourceObstruction{step_samples.T_odom_now.translation(), T_odom_true * next->xyz_world};
      }
      (void)simulation.vehicle().setWaypoints({});
    }
    {
      const std::lock_guard lock(mutex_);
      path_length_m_ = simulation.pathLengthM();
      if (!pending_) vehicle_idle_ = simulation.vehicle().waypointsLeft() == 0;
    }
    if (!forward()) return;
    if (config_.speedup > 0.0) {
      const auto due = wall0 + std::chrono::nanoseconds(static_cast<std::int64_t>(
                                   static_cast<double>(step_samples.stamp_ns - t0_ns) / config_.speedup));
      std::unique_lock lock(mutex_);
      wake_.wait_until(lock, due, [&] { return stopping_; });
    }
  }
}

}  // namespace vog::app
