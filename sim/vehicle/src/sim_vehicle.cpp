#include "vog/vehicle/sim_vehicle.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <numbers>
#include <sstream>
#include <thread>
#include <variant>

#include <Eigen/Geometry>

#include "vog/backseat/backseat.hpp"
#include "vog/mock/serial_devices.hpp"
#include "vog/mock/socket_devices.hpp"
#include "vog/mock/stream_server.hpp"
#include "vog/vehicle/control.hpp"
#include "vog/backseat/local_tangent_plane.hpp"

namespace vog::vehicle {
namespace {

using backseat::GeoPoint;
using backseat::LocalTangentPlane;

using Clock = std::chrono::steady_clock;

std::string fmt(double v, int decimals = 3) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(decimals);
  os << v;
  return os.str();
}

std::int64_t secondsToNs(double s) { return static_cast<std::int64_t>(std::llround(s * 1e9)); }

}  // namespace

Status SimVehicleConfig::validate() const {
  auto bad = [](const char* key, double v, const char* allowed) {
    return Error{std::string("vehicle.") + key + " must be " + allowed + ", got " + fmt(v, 6)};
  };
  if (!(speedup > 0.0 && speedup <= 1000.0)) return bad("speedup", speedup, "in (0, 1000]");
  if (!(duration_s >= 0.0) || !std::isfinite(duration_s)) return bad("duration_s", duration_s, "finite and >= 0");
  if (run_dir.empty() || !std::filesystem::is_directory(run_dir))
    return Error{"vehicle.run_dir must be an existing folder, got '" + run_dir.string() + "'"};
  if (!(nav_sentence_rate_hz > 0.0 && nav_sentence_rate_hz <= lockstep.odometry.rate_hz))
    return bad("nav_sentence_rate_hz", nav_sentence_rate_hz, "in (0, the simulation step rate]");
  if (!(operating_margin_m >= 0.0) || !std::isfinite(operating_margin_m))
    return bad("operating_margin_m", operating_margin_m, "finite and >= 0");
  if (!(face_target_min_distance_m >= 0.0) || !std::isfinite(face_target_min_distance_m))
    return bad("face_target_min_distance_m", face_target_min_distance_m, "finite and >= 0");
  if (history_steps < 100) return bad("history_steps", static_cast<double>(history_steps), ">= 100");
  if (auto ltp = LocalTangentPlane::create({origin_latitude_deg, origin_longitude_deg}); !ltp)
    return Error{"vehicle." + ltp.error().message};
  if (auto st = lockstep.validate(); !st) return st;
  return wire.validate();
}

// ------------------------------------------------------------------------------------ Impl

class SimVehicle::Impl final : public sim::SimulationSink {
 public:
  Impl(const sim::World& world, SimVehicleConfig config, EventHandler on_event, LocalTangentPlane ltp)
      : world_(world),
        config_(std::move(config)),
        on_event_(std::move(on_event)),
        ltp_(ltp),
        backseat_faults_(config_.seed ^ 0xBAC5EA7ULL) {}

  ~Impl() override {
    stop();
    // The backseat server's thread calls back into this object: close it before any member goes.
    backseat_.reset();
    sonar_.reset();
    aris_sonar_.reset();
    imu_.reset();
    depth_.reset();
    dvl_.reset();
  }

  Status open();
  Status start();
  void stop();
  bool waitFinished(std::chrono::milliseconds timeout) const;
  Result<std::string> control(const std::string& line);
  VehicleEndpoints endpoints() const;
  VehicleSnapshot snapshot() const;
  std::int64_t simStampNs() const { return stamp_ns_.load(std::memory_order_acquire); }
  Result<sim::VehicleState> truthAt(std::int64_t stamp_ns) const;
  std::optional<geometry::RangeScan> scanOfFrame(std::uint32_t frame_index) const;
  std::vector<StampedDepth> depthSamples(std::int64_t from_ns, std::int64_t to_ns) const;

  // SimulationSink (simulation thread).
  void truth(const sim::VehicleState& state, const geometry::Pose3& T_world_vehicle_odom) override;
  void imu(const sim::ImuSample& sample) override;
  void dvl(const sim::DvlSample& sample) override;
  void depth(const sim::DepthSample& sample) override;
  void scan(std::uint32_t scan_index, const sim::SonarPing& ping, const geometry::Pose3& T_true,
            const geometry::Pose3& T_odom) override;

 private:
  struct Window {
    std::optional<mock::Fault> fault;  // active fault, until fault_until_ns
    std::int64_t fault_until_ns = 0;
    bool unplugged = false;  // until replug_at_ns
    std::int64_t replug_at_ns = 0;
  };

  void run();
  void event(const std::string& text) {
    if (on_event_) on_event_(text);
  }
  void armFault(Device d, mock::FaultInjector& faults);
  void execute(const ControlCommand& c, std::int64_t now_ns);
  Result<std::string> controlAris(const ControlCommand& c);
  std::string arisStatus() const;
  void serviceTimers(std::int64_t now_ns);
  Status unplug(Device d);
  Status replug(Device d);
  void onBackseatBytes(std::span<const std::uint8_t> bytes);  // server thread
  void handleBackseat(const backseat::BackseatSentence& s);
  void sendBackseat(const backseat::BackseatSentence& s);
  void sendNavSentences();
  backseat::TimeOfDay timeOfDay(std::int64_t stamp_ns) const;

  const sim::World& world_;
  SimVehicleConfig config_;
  EventHandler on_event_;
  LocalTangentPlane ltp_;
  std::optional<sim::LockstepSimulation> sim_;

  std::unique_ptr<mock::DvlMock> dvl_;
  std::unique_ptr<mock::DepthMock> depth_;
  std::unique_ptr<mock::ImuMock> imu_;
  std::unique_ptr<mock::SonarMock> sonar_;           // sonar kind kFragments with a port
  std::unique_ptr<mock::ArisSonarMock> aris_sonar_;  // sonar kind kAris
  std::unique_ptr<mock::StreamServer> backseat_;
  mock::FaultInjector backseat_faults_;
  std::vector<std::uint8_t> backseat_pending_;  // backseat server thread: undecoded payload bytes

  // Simulation thread state.
  std::array<Window, kDeviceCount> windows_{};
  std::uint32_t ensemble_number_ = 0;
  std::uint32_t imu_sequence_ = 0;
  std::int64_t next_nav_ns_ = 0;
  std::int64_t now_ns_ = 0;
  double last_altitude_m_ = 0.0;
  geometry::Pose3 T_odom_ = geometry::Pose3::Identity();
  bool was_blocked_ = false;
  double ping_step_ms_sum_ = 0.0;
  std::uint64_t ping_steps_ = 0;
  Clock::time_point last_lag_event_{};

  // Shared state.
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  bool stop_ = false;                                                       // guarded by mutex_
  bool finished_ = false;                                                   // guarded by mutex_
  bool started_ = false;                                                    // guarded by mutex_
  Clock::time_point t0_{};                                                  // set by start(), read-only afterwards
  std::vector<ControlCommand> control_queue_;                               // guarded by mutex_
  std::vector<backseat::BackseatSentence> backseat_queue_;                  // guarded by mutex_
  VehicleSnapshot snapshot_;                                                // guarded by mutex_
  std::deque<sim::VehicleState> truth_history_;                             // guarded by mutex_
  std::deque<std::pair<std::uint32_t, geometry::RangeScan>> scan_history_;  // guarded by mutex_
  std::deque<StampedDepth> depth_history_;                                  // guarded by mutex_
  std::atomic<std::int64_t> stamp_ns_{0};  // newest step's stamp, published after its truth
  std::thread thread_;
};

Status SimVehicle::Impl::open() {
  sim::LockstepConfig lc = config_.lockstep;
  lc.seed = config_.seed;
  // A frame for every ping that is sent.
  lc.frame_every = config_.sonar_kind == SonarKind::kAris || config_.sonar_port != 0 ? 1 : 0;
  auto sim = sim::LockstepSimulation::create(world_, lc);
  if (!sim) return sim.error();
  sim_.emplace(std::move(sim).value());

  const std::filesystem::path& dir = config_.run_dir;
  auto dvl = mock::DvlMock::create(dir / "dvl", config_.seed + 1);
  if (!dvl) return Error{"dvl: " + dvl.error().message};
  dvl_ = std::move(dvl).value();
  auto depth = mock::DepthMock::create(dir / "depth", config_.wire.depth.units_code, config_.seed + 2);
  if (!depth) return Error{"depth: " + depth.error().message};
  depth_ = std::move(depth).value();
  auto imu = mock::ImuMock::create((dir / "imu.sock").string(), imu::ImuCanConfig{}, config_.seed + 3);
  if (!imu) return Error{"imu: " + imu.error().message};
  imu_ = std::move(imu).value();
  if (config_.sonar_kind == SonarKind::kAris) {
    mock::ArisSonarMockConfig ac;
    ac.serial_number = config_.aris_serial_number;
    ac.command_port = config_.aris_command_port;
    ac.beacon_port = config_.aris_beacon_port;
    ac.seed = config_.seed + 4;
    auto aris = mock::ArisSonarMock::create(ac);
    if (!aris) return Error{"sonar: " + aris.error().message};
    aris_sonar_ = std::move(aris).value();
  } else if (config_.sonar_port != 0) {
    auto sonar = mock::SonarMock::create(config_.sonar_port, config_.seed + 4);
    if (!sonar) return Error{"sonar: " + sonar.error().message};
    sonar_ = std::move(sonar).value();
  }
  mock::StreamServerConfig sc;
  sc.tcp_port = config_.backseat_port;
  auto server = mock::StreamServer::create(sc, [this](std::span<const std::uint8_t> b) { onBackseatBytes(b); });
  if (!server) return Error{"backseat: " + server.error().message};
  backseat_ = std::move(server).value();

  std::lock_guard<std::mutex> lock(mutex_);
  snapshot_.truth = sim_->vehicle().state();
  snapshot_.T_world_vehicle_nav = snapshot_.truth.T_world_vehicle();
  return Status::success();
}

Status SimVehicle::Impl::start() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (started_) return Error{"vehicle already started"};
  started_ = true;
  t0_ = Clock::now();
  thread_ = std::thread([this] { run(); });
  return Status::success();
}

void SimVehicle::Impl::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::lock_guard<std::mutex> lock(mutex_);
  finished_ = true;
  snapshot_.finished = true;
  cv_.notify_all();
}

bool SimVehicle::Impl::waitFinished(std::chrono::milliseconds timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return cv_.wait_for(lock, timeout, [this] { return finished_; });
}

void SimVehicle::Impl::run() {
  sim::LockstepSimulation& sim = *sim_;
  const std::int64_t duration_ns = secondsToNs(config_.duration_s);
  const std::int64_t nav_period_ns = secondsToNs(1.0 / config_.nav_sentence_rate_hz);
  sim.start(*this);
  sendNavSentences();
  next_nav_ns_ = nav_period_ns;
  for (;;) {
    const std::int64_t next_ns = sim.stampNs() + sim.stepNs();
    if (duration_ns > 0 && next_ns > duration_ns) break;
    const auto due =
        t0_ + std::chrono::nanoseconds(static_cast<std::int64_t>(static_cast<double>(next_ns) / config_.speedup));
    std::vector<ControlCommand> commands;
    std::vector<backseat::BackseatSentence> inbound;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (cv_.wait_until(lock, due, [this] { return stop_; })) break;
      commands.swap(control_queue_);
      inbound.swap(backseat_queue_);
    }
    const auto woke = Clock::now();
    const double lag_ms = std::chrono::duration<double, std::milli>(woke - due).count();
    if (lag_ms > 500.0 && woke - last_lag_event_ > std::chrono::seconds(10)) {
      last_lag_event_ = woke;
      event("simulation is " + fmt(lag_ms, 0) + " ms behind wall time (speedup " + fmt(config_.speedup, 1) +
            " too high for this machine)");
    }
    now_ns_ = sim.stampNs();
    for (const ControlCommand& c : commands) execute(c, now_ns_);
    serviceTimers(now_ns_);
    for (const auto& s : inbound) handleBackseat(s);

    const std::uint64_t scans_before = sim.scanCount();
    const sim::StepResult r = sim.step(*this);
    now_ns_ = sim.stampNs();
    if (sim.scanCount() != scans_before) {
      ping_step_ms_sum_ += std::chrono::duration<double, std::milli>(Clock::now() - woke).count();
      ++ping_steps_;
    }
    if (r.status == sim::MotionStatus::kBlocked && !was_blocked_) {
      const auto& p = sim.vehicle().state().xyz_world;
      event("move refused by the collision check at (" + fmt(p.x(), 2) + ", " + fmt(p.y(), 2) + ", " + fmt(p.z(), 2) +
            "); holding until the next command");
    }
    if (r.waypoints_reached > 0) {
      const auto& p = sim.vehicle().state().xyz_world;
      event("target reached at (" + fmt(p.x(), 2) + ", " + fmt(p.y(), 2) + ", " + fmt(p.z(), 2) + ")");
    }
    if (now_ns_ >= next_nav_ns_) {
      sendNavSentences();
      next_nav_ns_ += nav_period_ns;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (r.status == sim::MotionStatus::kBlocked && !was_blocked_) ++snapshot_.blocked_moves;
    was_blocked_ = r.status == sim::MotionStatus::kBlocked;
    if (r.waypoints_reached > 0 || r.status == sim::MotionStatus::kIdle) snapshot_.target_xyz_world.reset();
    snapshot_.max_lag_ms = std::max(snapshot_.max_lag_ms, lag_ms);
    snapshot_.ping_step_ms_mean = ping_steps_ > 0 ? ping_step_ms_sum_ / static_cast<double>(ping_steps_) : 0.0;
    snapshot_.scans = sim.scanCount();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  finished_ = true;
  snapshot_.finished = true;
  cv_.notify_all();
}

// ----------------------------------------------------------------------- samples to devices

void SimVehicle::Impl::truth(const sim::VehicleState& state, const geometry::Pose3& T_world_vehicle_odom) {
  T_odom_ = T_world_vehicle_odom;
  std::lock_guard<std::mutex> lock(mutex_);
  snapshot_.stamp_ns = state.stamp_ns;
  snapshot_.truth = state;
  snapshot_.T_world_vehicle_nav = T_world_vehicle_odom;
  truth_history_.push_back(state);
  if (truth_history_.size() > config_.history_steps) truth_history_.pop_front();
  stamp_ns_.store(state.stamp_ns, std::memory_order_release);
}

void SimVehicle::Impl::armFault(Device d, mock::FaultInjector& faults) {
  const Window& w = windows_[static_cast<std::size_t>(d)];
  if (w.fault && now_ns_ < w.fault_until_ns && faults.armed() == 0) faults.inject(*w.fault, 1);
}

void SimVehicle::Impl::imu(const sim::ImuSample& sample) {
  auto s = toImuSample(sample, imu_sequence_++, config_.wire);
  if (!s) {
    event("imu sample not encodable: " + s.error().message);
    return;
  }
  armFault(Device::kImu, imu_->faults());
  if (auto st = imu_->send(*s); !st) event("imu: " + st.error().message);
  std::lock_guard<std::mutex> lock(mutex_);
  ++snapshot_.imu_sent;
}

void SimVehicle::Impl::dvl(const sim::DvlSample& sample) {
  if (sample.bottom_lock) last_altitude_m_ = sample.altitude_m;
  auto e = toPd0Ensemble(sample, ++ensemble_number_, config_.wire);
  if (!e) {
    event("dvl sample not encodable: " + e.error().message);
    return;
  }
  armFault(Device::kDvl, dvl_->faults());
  if (auto st = dvl_->sendPd0(*e); !st) event("dvl: " + st.error().message);
  std::lock_guard<std::mutex> lock(mutex_);
  ++snapshot_.dvl_sent;
}

void SimVehicle::Impl::depth(const sim::DepthSample& sample) {
  auto reading = toDigiquartzReading(sample, config_.wire);
  if (!reading) {
    event("depth sample not encodable: " + reading.error().message);
    return;
  }
  armFault(Device::kDepth, depth_->faults());
  depth_->setPressure(*reading);
  std::lock_guard<std::mutex> lock(mutex_);
  ++snapshot_.depth_sent;
  depth_history_.push_back(StampedDepth{sample.stamp_ns, sample.depth_m});
  if (depth_history_.size() > config_.history_steps) depth_history_.pop_front();
}

void SimVehicle::Impl::scan(std::uint32_t /*scan_index*/, const sim::SonarPing& ping, const geometry::Pose3& /*T_true*/,
                            const geometry::Pose3& /*T_odom*/) {
  if ((!sonar_ && !aris_sonar_) || ping.frame.n_samples == 0) return;
  {
    // Kept before sending, so a receiver that looks the scan up on arrival finds it.
    std::lock_guard<std::mutex> lock(mutex_);
    scan_history_.emplace_back(ping.frame.frame_index, ping.scan);
    if (scan_history_.size() > 64) scan_history_.pop_front();
  }
  if (aris_sonar_) {
    if (auto st = aris_sonar_->ping(ping.frame, ping.frame.stamp_ns); !st) event("sonar: " + st.error().message);
    return;
  }
  armFault(Device::kSonar, sonar_->faults());
  if (auto st = sonar_->send(ping.frame); !st) event("sonar: " + st.error().message);
}

// --------------------------------------------------------------------------------- backseat

backseat::TimeOfDay SimVehicle::Impl::timeOfDay(std::int64_t stamp_ns) const {
  constexpr std::int64_t kDayNs = 86'400'000'000'000;
  std::int64_t t = (config_.wire.epoch_unix_ns + stamp_ns) % kDayNs;
  if (t < 0) t += kDayNs;
  return backseat::TimeOfDay{static_cast<double>(t) * 1e-9};
}

void SimVehicle::Impl::sendBackseat(const backseat::BackseatSentence& s) {
  const std::string line = backseat::encodeBackseat(s);
  armFault(Device::kBackseat, backseat_faults_);
  auto out =
      backseat_faults_.apply(std::vector<std::uint8_t>(line.begin(), line.end()), [](std::vector<std::uint8_t>& m) {
        // "*hh\r\n": the first checksum digit becomes another valid hex digit.
        if (m.size() >= 5) {
          std::uint8_t& c = m[m.size() - 4];
          c = c == '0' ? '1' : '0';
        }
      });
  backseat_->send({std::move(out)});
}

void SimVehicle::Impl::sendNavSentences() {
  const sim::VehicleState& truth = sim_->vehicle().state();
  const Eigen::Vector3d ned = vehicle::nedRollPitchHeading(T_odom_.linear());  // roll, pitch, heading
  const Eigen::Vector3d p = T_odom_.translation();
  const GeoPoint g = ltp_.toGeo(p.head<2>());
  const backseat::TimeOfDay tod = timeOfDay(truth.stamp_ns);
  constexpr double kDeg = 180.0 / std::numbers::pi;
  double heading_deg = std::fmod(ned.z() * kDeg, 360.0);
  if (heading_deg < 0.0) heading_deg += 360.0;
  backseat::NavSentence nvg;
  nvg.time = tod;
  nvg.latitude_deg = g.latitude_deg;
  nvg.longitude_deg = g.longitude_deg;
  nvg.quality = 0;  // dead reckoning
  nvg.altitude_m = last_altitude_m_;
  nvg.depth_m = -p.z();
  nvg.heading_deg = heading_deg;
  nvg.roll_deg = ned.x() * kDeg;
  nvg.pitch_deg = ned.y() * kDeg;
  nvg.computed_time = tod;
  sendBackseat(nvg);
  backseat::NavRateSentence nvr;
  nvr.time = tod;
  nvr.east_mps = truth.velocity_world_mps.x();
  nvr.north_mps = truth.velocity_world_mps.y();
  nvr.down_mps = -truth.velocity_world_mps.z();
  nvr.yaw_rate_dps = -truth.yaw_rate_radps * kDeg;  // heading is clockwise, world yaw counter-clockwise
  sendBackseat(nvr);
  std::lock_guard<std::mutex> lock(mutex_);
  snapshot_.nav_sentences_sent += 2;
}

void SimVehicle::Impl::onBackseatBytes(std::span<const std::uint8_t> bytes) {
  backseat_pending_.insert(backseat_pending_.end(), bytes.begin(), bytes.end());
  const backseat::BackseatCodec codec;
  std::size_t pos = 0;
  std::vector<backseat::BackseatSentence> decoded;
  while (pos < backseat_pending_.size()) {
    auto r = codec.decode(std::span<const std::uint8_t>(backseat_pending_).subspan(pos));
    if (r.isNeedMore()) break;
    pos += r.consumed();
    if (r.isFrame()) decoded.push_back(r.frame());
  }
  backseat_pending_.erase(backseat_pending_.begin(), backseat_pending_.begin() + static_cast<std::ptrdiff_t>(pos));
  if (backseat_pending_.size() > 4096) backseat_pending_.clear();  // no sentence is this long: noise
  if (decoded.empty()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  // Bounded: the simulation thread drains the queue every step.
  for (auto& s : decoded) {
    if (backseat_queue_.size() < 1024) backseat_queue_.push_back(std::move(s));
  }
}

void SimVehicle::Impl::handleBackseat(const backseat::BackseatSentence& s) {
  if (std::holds_alternative<backseat::Heartbeat>(s)) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++snapshot_.heartbeats;
    return;
  }
  const auto* cmd = std::get_if<backseat::WaypointCommand>(&s);
  if (cmd == nullptr) return;
  sim::VehicleModel& vehicle = sim_->vehicle();
  const sim::VehicleState& st = vehicle.state();
  std::string reason;
  Eigen::Vector3d target_true = Eigen::Vector3d::Zero();
  if (!std::isfinite(cmd->latitude_deg) || !std::isfinite(cmd->longitude_deg) || !std::isfinite(cmd->depth_m) ||
      !std::isfinite(cmd->speed_mps)) {
    reason = "non-finite field";
  } else if (cmd->depth_m < 0.0) {
    reason = "depth " + fmt(cmd->depth_m, 2) + " m is above the surface";
  } else if (cmd->speed_mps < 0.0) {
    reason = "speed " + fmt(cmd->speed_mps, 2) + " m/s is negative";
  } else {
    const Eigen::Vector2d xy = ltp_.toLocal(GeoPoint{cmd->latitude_deg, cmd->longitude_deg});
    const Eigen::Vector3d target_nav(xy.x(), xy.y(), -cmd->depth_m);
    // The vehicle steers on its own navigation: the true goal is the target moved by the current
    // planar navigation error (x, y, yaw drift; depth is measured absolutely, thesis 4.4.1).
    const double yaw_nav = geometry::yawOf(T_odom_.linear());
    const Eigen::Vector2d rel = Eigen::Rotation2Dd(st.yaw_rad - yaw_nav) * (xy - T_odom_.translation().head<2>());
    target_true = Eigen::Vector3d(st.xyz_world.x() + rel.x(), st.xyz_world.y() + rel.y(), target_nav.z());
    Eigen::AlignedBox3d area = world_.scene().bounds_world;
    area.min().array() -= config_.operating_margin_m;
    area.max().array() += config_.operating_margin_m;
    if (!area.contains(target_true)) {
      reason = "target (" + fmt(target_true.x(), 2) + ", " + fmt(target_true.y(), 2) + ", " + fmt(target_true.z(), 2) +
               ") is outside the operating area";
    }
  }
  backseat::AckSentence ack;
  ack.time = timeOfDay(now_ns_);
  ack.command = "BPGHP";
  ack.command_time = cmd->time;
  ack.command_id = cmd->id;
  if (reason.empty()) {
    const Eigen::Vector2d d = target_true.head<2>() - st.xyz_world.head<2>();
    sim::Waypoint wp;
    wp.xyz_world = target_true;
    if (cmd->heading_deg) {
      // A commanded heading is in the navigation frame too: moved by the navigation's yaw error.
      const double yaw_nav_target = std::numbers::pi / 2 - *cmd->heading_deg * std::numbers::pi / 180.0;
      wp.yaw_rad = geometry::wrapAngle(yaw_nav_target + st.yaw_rad - geometry::yawOf(T_odom_.linear()));
    } else {
      wp.yaw_rad = d.norm() > config_.face_target_min_distance_m ? std::atan2(d.y(), d.x()) : st.yaw_rad;
    }
    if (Status set = vehicle.setWaypoints({wp}); !set) reason = set.error().message;
  }
  ack.status = reason.empty() ? backseat::AckStatus::kAccepted : backseat::AckStatus::kFailed;
  ack.reason = reason.empty() ? "accepted" : reason;
  sendBackseat(ack);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    snapshot_.last_command_id = cmd->id;
    if (reason.empty()) {
      ++snapshot_.commands_accepted;
      snapshot_.target_xyz_world = target_true;
    } else {
      ++snapshot_.commands_rejected;
    }
  }
  event(reason.empty() ? "BPGHP " + std::to_string(cmd->id) + " accepted: going to (" + fmt(target_true.x(), 2) + ", " +
                             fmt(target_true.y(), 2) + ", " + fmt(target_true.z(), 2) + ")"
                       : "BPGHP " + std::to_string(cmd->id) + " rejected: " + reason);
}

// ----------------------------------------------------------------------------------- control

Result<std::string> SimVehicle::Impl::control(const std::string& line) {
  auto c = parseControlCommand(line);
  if (!c) return c.error();
  if (c->kind == ControlCommand::Kind::kStatus) {
    const VehicleSnapshot s = snapshot();
    const auto& p = s.truth.xyz_world;
    std::string out = "ok t_s=" + fmt(static_cast<double>(s.stamp_ns) * 1e-9, 2) + " x=" + fmt(p.x()) +
                      " y=" + fmt(p.y()) + " z=" + fmt(p.z()) +
                      " yaw_deg=" + fmt(s.truth.yaw_rad * 180.0 / std::numbers::pi, 2) +
                      " commands=" + std::to_string(s.commands_accepted) + "/" +
                      std::to_string(s.commands_accepted + s.commands_rejected) + " scans=" + std::to_string(s.scans) +
                      " max_lag_ms=" + fmt(s.max_lag_ms, 1);
    if (s.target_xyz_world) {
      out += " target=" + fmt(s.target_xyz_world->x()) + "," + fmt(s.target_xyz_world->y()) + "," +
             fmt(s.target_xyz_world->z());
    }
    if (aris_sonar_) out += " " + arisStatus();
    return out;
  }
  if (c->kind == ControlCommand::Kind::kAris) return controlAris(*c);
  if (c->device == Device::kSonar && aris_sonar_) {
    return Error{"the sonar is an ARIS: use aris loss|dup|reorder <probability> or aris reboot <seconds>"};
  }
  if (c->device == Device::kSonar && !sonar_) return Error{"sonar is off (no --sonar-port)"};
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_ || stop_) return Error{"vehicle is not running"};
  control_queue_.push_back(*c);
  return std::string("ok ") + (c->kind == ControlCommand::Kind::kFault ? "fault " : "unplug ") + toString(c->device) +
         (c->kind == ControlCommand::Kind::kFault ? std::string(" ") + faultName(c->fault) : std::string()) + " for " +
         fmt(c->seconds, 2) + " s";
}

Result<std::string> SimVehicle::Impl::controlAris(const ControlCommand& c) {
  if (!aris_sonar_) return Error{"the sonar is not an ARIS (sonar kind fragments)"};
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (finished_ || stop_) return Error{"vehicle is not running"};
  }
  const char* name = arisActionName(c.aris_action);
  if (c.aris_action == ArisAction::kReboot) {
    // The mock's timers run on the wall clock: simulated seconds / speedup.
    if (Status st = aris_sonar_->reboot(c.seconds / config_.speedup); !st) return st.error();
    event("aris sonar rebooting for " + fmt(c.seconds, 2) + " s");
    return "ok aris reboot for " + fmt(c.seconds, 2) + " s";
  }
  mock::ArisLinkFaults f = aris_sonar_->faults();
  double& target = c.aris_action == ArisAction::kLoss        ? f.loss
                   : c.aris_action == ArisAction::kDuplicate ? f.duplicate
                                                             : f.reorder;
  target = c.probability;
  if (Status st = aris_sonar_->setFaults(f); !st) return st.error();
  event(std::string("aris ") + name + " probability " + fmt(c.probability, 3));
  return std::string("ok aris ") + name + " " + fmt(c.probability, 3);
}

std::string SimVehicle::Impl::arisStatus() const {
  const mock::ArisSonarMockStats a = aris_sonar_->stats();
  const mock::ArisMockSettings s = aris_sonar_->appliedSettings();
  const mock::ArisLinkFaults f = aris_sonar_->faults();
  std::string out =
      "aris_connected=" + std::to_string(s.connected ? 1 : 0) +
      " aris_rebooting=" + std::to_string(s.rebooting ? 1 : 0) +
      " aris_cookie=" + std::to_string(s.acoustics ? s.acoustics->cookie : 0) +
      " aris_commands=" + std::to_string(a.commands_applied) + "/" +
      std::to_string(a.commands_applied + a.refusedTotal()) + " aris_connections=" + std::to_string(a.connections) +
      " aris_frames_sent=" + std::to_string(a.frames_sent) +
      " aris_frames_finished=" + std::to_string(a.frames_finished) +
      " aris_frames_given_up=" + std::to_string(a.frames_given_up) +
      " aris_datagrams=" + std::to_string(a.datagrams_sent) + " aris_resent=" + std::to_string(a.datagrams_resent) +
      " aris_lost=" + std::to_string(a.datagrams_lost) + " aris_acks=" + std::to_string(a.acks_received) +
      " aris_loss=" + fmt(f.loss, 3) + " aris_dup=" + fmt(f.duplicate, 3) + " aris_reorder=" + fmt(f.reorder, 3);
  for (std::size_t r = 0; r < sonar::kArisCommandRefusalCount; ++r) {
    if (a.commands_refused[r] != 0) {
      out += " aris_refused_" + std::string(sonar::arisCommandRefusalName(static_cast<sonar::ArisCommandRefusal>(r))) +
             "=" + std::to_string(a.commands_refused[r]);
    }
  }
  for (std::size_t r = 0; r < mock::kArisPingSkipCount; ++r) {
    if (a.pings_skipped[r] != 0) {
      out += " aris_skipped_" + std::string(mock::arisPingSkipName(static_cast<mock::ArisPingSkip>(r))) + "=" +
             std::to_string(a.pings_skipped[r]);
    }
  }
  return out;
}

Status SimVehicle::Impl::unplug(Device d) {
  switch (d) {
    case Device::kDvl: return dvl_->pty().unplug();
    case Device::kDepth: return depth_->pty().unplug();
    case Device::kImu: imu_->server().disappear(); return Status::success();
    case Device::kSonar: sonar_->disappear(); return Status::success();
    case Device::kBackseat: backseat_->disappear(); return Status::success();
  }
  return Status::success();
}

Status SimVehicle::Impl::replug(Device d) {
  switch (d) {
    case Device::kDvl: return dvl_->pty().replug();
    case Device::kDepth: return depth_->pty().replug();
    case Device::kImu: return imu_->server().reappear();
    case Device::kSonar: return sonar_->reappear();
    case Device::kBackseat: return backseat_->reappear();
  }
  return Status::success();
}

void SimVehicle::Impl::execute(const ControlCommand& c, std::int64_t now_ns) {
  Window& w = windows_[static_cast<std::size_t>(c.device)];
  const std::int64_t until = now_ns + secondsToNs(c.seconds);
  if (c.kind == ControlCommand::Kind::kFault) {
    w.fault = c.fault;
    w.fault_until_ns = until;
    event(std::string("fault ") + faultName(c.fault) + " on " + toString(c.device) + " for " + fmt(c.seconds, 2) +
          " s");
    return;
  }
  if (!w.unplugged) {
    if (Status st = unplug(c.device); !st) {
      event(std::string("unplug ") + toString(c.device) + " failed: " + st.error().message);
      return;
    }
    w.unplugged = true;
  }
  w.replug_at_ns = std::max(w.replug_at_ns, until);
  event(std::string(toString(c.device)) + " unplugged for " + fmt(c.seconds, 2) + " s");
}

void SimVehicle::Impl::serviceTimers(std::int64_t now_ns) {
  for (int i = 0; i < kDeviceCount; ++i) {
    Window& w = windows_[static_cast<std::size_t>(i)];
    const Device d = static_cast<Device>(i);
    if (w.fault && now_ns >= w.fault_until_ns) {
      w.fault.reset();
      event(std::string("fault on ") + toString(d) + " ended");
    }
    if (w.unplugged && now_ns >= w.replug_at_ns) {
      if (Status st = replug(d); !st) {
        // Retry on the next step (e.g. the port is briefly taken): the device stays out meanwhile.
        event(std::string("replug ") + toString(d) + " failed, retrying: " + st.error().message);
        w.replug_at_ns = now_ns + sim_->stepNs() * 10;
        continue;
      }
      w.unplugged = false;
      event(std::string(toString(d)) + " plugged back in");
    }
  }
}

// ---------------------------------------------------------------------------------- queries

VehicleEndpoints SimVehicle::Impl::endpoints() const {
  VehicleEndpoints e;
  const sim::Scene& scene = world_.scene();
  e.scene_name = scene.name;
  e.scene_file = scene.source_file.string();
  e.seed = config_.seed;
  e.pid = static_cast<std::int64_t>(::getpid());
  e.speedup = config_.speedup;
  {
    std::lock_guard<std::mutex> lock(mutex_);  // t0_ is set by start()
    e.steady_ns_at_sim_zero = std::chrono::duration_cast<std::chrono::nanoseconds>(t0_.time_since_epoch()).count();
  }
  e.epoch_unix_ns = config_.wire.epoch_unix_ns;
  e.origin_latitude_deg = config_.origin_latitude_deg;
  e.origin_longitude_deg = config_.origin_longitude_deg;
  e.start_xyz_world = scene.T_world_start.translation();
  e.start_yaw_deg = geometry::yawOf(scene.T_world_start.linear()) * 180.0 / std::numbers::pi;
  e.dvl_device = dvl_->pty().linkPath().string();
  e.dvl_mount_yaw_deg = config_.wire.dvl_mount_yaw_rad * 180.0 / std::numbers::pi;
  e.depth_device = depth_->pty().linkPath().string();
  e.depth_units_code = config_.wire.depth.units_code;
  e.depth_latitude_deg = config_.wire.depth.latitude_deg;
  e.depth_atmospheric_pressure_pa = config_.wire.depth.atmospheric_pressure_pa;
  e.depth_reading_is_absolute = config_.wire.depth.reading_is_absolute;
  e.imu_unix_seqpacket = (config_.run_dir / "imu.sock").string();
  e.imu_base_id = imu::can_layout::kDefaultBaseId;
  e.sonar_kind = config_.sonar_kind;
  if (aris_sonar_) {
    e.sonar_command_port = aris_sonar_->commandPort();
    e.sonar_beacon_port = config_.aris_beacon_port;
    e.sonar_serial_number = config_.aris_serial_number;
  } else {
    e.sonar_port = config_.sonar_port;
  }
  e.backseat_port = backseat_->port();
  return e;
}

VehicleSnapshot SimVehicle::Impl::snapshot() const {
  VehicleSnapshot out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    out = snapshot_;
  }
  if (aris_sonar_) out.aris = aris_sonar_->stats();  // thread-safe on its own
  return out;
}

Result<sim::VehicleState> SimVehicle::Impl::truthAt(std::int64_t stamp_ns) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (truth_history_.empty()) return Error{"no truth yet"};
  const std::int64_t first = truth_history_.front().stamp_ns;
  const std::int64_t last = truth_history_.back().stamp_ns;
  const std::int64_t step = sim_->stepNs();
  if (stamp_ns < first - step || stamp_ns > last + step)
    return Error{"stamp " + std::to_string(stamp_ns) + " ns is outside the kept truth [" + std::to_string(first) +
                 ", " + std::to_string(last) + "] ns"};
  const std::int64_t k = std::clamp<std::int64_t>((stamp_ns - first + step / 2) / step, 0,
                                                  static_cast<std::int64_t>(truth_history_.size()) - 1);
  return truth_history_[static_cast<std::size_t>(k)];
}

std::optional<geometry::RangeScan> SimVehicle::Impl::scanOfFrame(std::uint32_t frame_index) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [index, scan] : scan_history_) {
    if (index == frame_index) return scan;
  }
  return std::nullopt;
}

std::vector<StampedDepth> SimVehicle::Impl::depthSamples(std::int64_t from_ns, std::int64_t to_ns) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<StampedDepth> out;
  for (const StampedDepth& d : depth_history_) {
    if (d.stamp_ns >= from_ns && d.stamp_ns <= to_ns) out.push_back(d);
  }
  return out;
}

// ----------------------------------------------------------------------------------- facade

SimVehicle::SimVehicle(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SimVehicle::~SimVehicle() = default;

Result<std::unique_ptr<SimVehicle>> SimVehicle::create(const sim::World& world, SimVehicleConfig config,
                                                       EventHandler on_event) {
  if (Status st = config.validate(); !st) return st.error();
  auto ltp = LocalTangentPlane::create({config.origin_latitude_deg, config.origin_longitude_deg});
  if (!ltp) return ltp.error();
  auto impl = std::make_unique<Impl>(world, std::move(config), std::move(on_event), *ltp);
  if (Status st = impl->open(); !st) return st.error();
  return std::unique_ptr<SimVehicle>(new SimVehicle(std::move(impl)));
}

Status SimVehicle::start() { return impl_->start(); }
void SimVehicle::stop() { impl_->stop(); }
bool SimVehicle::waitFinished(std::chrono::milliseconds timeout) const { return impl_->waitFinished(timeout); }
Result<std::string> SimVehicle::control(const std::string& line) { return impl_->control(line); }
VehicleEndpoints SimVehicle::endpoints() const { return impl_->endpoints(); }
VehicleSnapshot SimVehicle::snapshot() const { return impl_->snapshot(); }
std::int64_t SimVehicle::simStampNs() const { return impl_->simStampNs(); }
Result<sim::VehicleState> SimVehicle::truthAt(std::int64_t stamp_ns) const { return impl_->truthAt(stamp_ns); }
std::optional<geometry::RangeScan> SimVehicle::scanOfFrame(std::uint32_t frame_index) const {
  return impl_->scanOfFrame(frame_index);
}
std::vector<StampedDepth> SimVehicle::depthSamples(std::int64_t from_ns, std::int64_t to_ns) const {
  return impl_->depthSamples(from_ns, to_ns);
}

}  // namespace vog::vehicle
