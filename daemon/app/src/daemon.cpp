#include "vog/app/daemon.hpp"

#include "vog/app/scan_record.hpp"
#include "vog/app/device_source.hpp"
#include "vog/app/sim_source.hpp"
#include "vog/map/voxel_key.hpp"

#include <asio/executor_work_guard.hpp>
#include <asio/post.hpp>
#include <asio/signal_set.hpp>
#include <asio/steady_timer.hpp>
#include <spdlog/spdlog.h>

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

namespace vog::app {
namespace {

using geometry::Pose3;
using Clock = std::chrono::steady_clock;

// The two enums carry the same values (journal.hpp, domain.hpp); converted by name, not by cast.
api::MissionState toApi(mission::MissionState s) {
  switch (s) {
    case mission::MissionState::kIdle: return api::MissionState::kIdle;
    case mission::MissionState::kExploring: return api::MissionState::kExploring;
    case mission::MissionState::kReturning: return api::MissionState::kReturning;
    case mission::MissionState::kComplete: return api::MissionState::kComplete;
    case mission::MissionState::kPaused: return api::MissionState::kPaused;
    case mission::MissionState::kAborted: return api::MissionState::kAborted;
  }
  return api::MissionState::kIdle;
}

mission::MissionCommandKind toMission(api::MissionCommand::Kind k) {
  switch (k) {
    case api::MissionCommand::Kind::kSetBox: return mission::MissionCommandKind::kSetBox;
    case api::MissionCommand::Kind::kStart: return mission::MissionCommandKind::kStart;
    case api::MissionCommand::Kind::kPause: return mission::MissionCommandKind::kPause;
    case api::MissionCommand::Kind::kResume: return mission::MissionCommandKind::kResume;
    case api::MissionCommand::Kind::kAbort: return mission::MissionCommandKind::kAbort;
    case api::MissionCommand::Kind::kReturnHome: return mission::MissionCommandKind::kReturnHome;
  }
  return mission::MissionCommandKind::kAbort;
}

plan::Waypoint toWaypoint(const Pose3& T) { return {T.translation(), geometry::yawOf(T.linear())}; }
Pose3 fromWaypoint(const Eigen::Vector3d& p, double yaw) {
  return geometry::poseFromXyzRpy(p.x(), p.y(), p.z(), 0.0, 0.0, yaw);
}

class SpdlogApiLogger final : public api::ApiLogger {
 public:
  void log(api::LogLevel level, std::string_view message) override {
    switch (level) {
      case api::LogLevel::kDebug: spdlog::debug("api: {}", message); break;
      case api::LogLevel::kInfo: spdlog::info("api: {}", message); break;
      case api::LogLevel::kWarning: spdlog::warn("api: {}", message); break;
      case api::LogLevel::kError: spdlog::error("api: {}", message); break;
    }
  }
};
SpdlogApiLogger g_api_logger;

Result<std::string> readSecret(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error{"api.secret_file: cannot read " + file.string()};
  std::stringstream ss;
  ss << in.rdbuf();
  std::string secret = ss.str();
  while (!secret.empty() && (secret.back() == '\n' || secret.back() == '\r')) secret.pop_back();
  if (secret.size() < 16) return Error{"api.secret_file: " + file.string() + " holds fewer than 16 bytes"};
  struct stat st {};
  if (::stat(file.c_str(), &st) == 0 && (st.st_mode & (S_IRWXG | S_IRWXO)) != 0)
    spdlog::warn("api.secret_file {} is readable by group or others; chmod 600 it", file.string());
  return secret;
}

}  // namespace

Result<std::unique_ptr<Daemon>> Daemon::create(const VogdConfig& config, const DaemonOptions& options) {
  std::unique_ptr<Daemon> d(new Daemon(config, options));
  if (auto st = d->init(); !st) return st.error();
  return d;
}

Daemon::Daemon(const VogdConfig& config, const DaemonOptions& options)
    : config_(config),
      options_(options),
      mission_(mission::Box{config.mission.box_min_m, config.mission.box_max_m}) {}

Daemon::~Daemon() {
  requestStop();
  if (source_) source_->stop();
  for (std::thread* t : {&planning_thread_, &mapping_thread_}) {
    if (t->joinable()) {
      queue_cv_.notify_all();
      planner_cv_.notify_all();
      t->join();
    }
  }
  if (merge_) merge_->stop();
  if (api_) api_->stop();
  io_.stop();
  if (io_thread_.joinable()) io_thread_.join();
}

Status Daemon::init() {
  mission_dir_ = options_.mission_dir ? *options_.mission_dir : config_.mission.directory / config_.mission.name;
  const map::GridConfig& grid = config_.mapping.builder.grid;
  mission::MissionResume resume;
  auto store = mission::MissionStore::open(mission_dir_, grid, &resume);
  if (!store) return Error{"mission directory " + mission_dir_.string() + ": " + store.error().message};
  store_ = std::move(store).value();
  if (resume.journal_tail.torn || resume.uncommitted_records > 0)
    spdlog::warn("mission {}: discarded a torn journal tail ({} bytes) and {} records of an unfinished submap",
                 mission_dir_.string(), resume.journal_tail.discarded_bytes, resume.uncommitted_records);
  mission::RawLogContents raw_existing;
  auto raw = mission::RawLog::open(mission_dir_ / mission::MissionStore::kRawLogFile, &raw_existing);
  if (!raw) return Error{"raw log: " + raw.error().message};
  raw_log_ = std::move(raw).value();

  const bool resumed = !resume.pipeline.submaps.empty();
  auto pipeline = resumed ? slam::MappingPipeline::restore(config_.mapping, resume.pipeline)
                          : slam::MappingPipeline::create(config_.mapping);
  if (!pipeline) return Error{"mapping: " + pipeline.error().message};
  pipeline_ = std::move(pipeline).value();

  if (resume.state) {
    const mission::MissionState s = resume.state->state;
    mission_ = mission::MissionControl(mission::Box{config_.mission.box_min_m, config_.mission.box_max_m}, s);
    mission_started_ = s == mission::MissionState::kExploring || s == mission::MissionState::kReturning ||
                       s == mission::MissionState::kPaused;
    mapping_enabled_ = mission_started_;
  }
  std::optional<Pose3> sim_start;
  if (resumed) {
    const slam::SubmapRecord& last = pipeline_->submaps().back();
    T_map_resume_ = resume.waypoint ? fromWaypoint(Eigen::Vector3d(resume.waypoint->x_m, resume.waypoint->y_m,
                                                                   resume.waypoint->z_m),
                                                   resume.waypoint->yaw_rad)
                                    : last.T_world_base;
    T_map_home_ = pipeline_->submaps().front().T_world_base;
    pipeline_last_stamp_ns_ = last.last_stamp_ns;
    sim_start = geometry::planarPart(*T_map_resume_) * Pose3(Eigen::Translation3d(0, 0, T_map_resume_->translation().z()));
    spdlog::info("mission {}: resumed {} submaps, {} loop closures, state {}", mission_dir_.string(),
                 pipeline_->submaps().size(), pipeline_->closures().size(), mission::toString(mission_.state()));
  } else {
    spdlog::info("mission {}: new", mission_dir_.string());
  }

  auto openCsv = [&](std::ofstream& f, const char* name, const char* header) -> Status {
    const std::filesystem::path file = mission_dir_ / name;
    const bool fresh = !std::filesystem::exists(file);
    f.open(file, std::ios::app);
    if (!f) return Error{"cannot open " + file.string()};
    if (fresh) f << header << "\n" << std::flush;
    return {};
  };
  if (auto st = openCsv(plans_csv_, "iterations.csv", "iteration,sim_s,n_submaps,plan_ms,status,best_gain,tree_size,coverage"); !st)
    return st;
  if (auto st = openCsv(merges_csv_, "merges.csv", "sim_s,n_submaps,merge_ms,remerged"); !st) return st;

  auto merge = map::MergeWorker::create(grid, config_.merge);
  if (!merge) return Error{"merge: " + merge.error().message};
  merge_ = std::move(merge).value();
  if (resumed) merge_->submit(pipeline_->map().entries());
  publishMappingState();

  if (config_.source == Source::kSim) {
    auto source = SimSource::create(config_.sim, sim_start);
    if (!source) return source.error();
    source_ = std::move(source).value();
  } else {
    auto source = DeviceSource::create(config_.devices);
    if (!source) return source.error();
    source_ = std::move(source).value();
  }

  api::ApiServerConfig ac;
  ac.max_clients = static_cast<std::size_t>(config_.api.max_clients);
  ac.dispatch.max_frame_bytes = config_.api.max_frame_bytes;
  ac.tls.certificate_chain_file = config_.api.tls_certificate_file;
  ac.tls.private_key_file = config_.api.tls_private_key_file;
  if (!config_.api.secret_file.empty()) {
    auto secret = readSecret(config_.api.secret_file);
    if (!secret) return secret.error();
    ac.dispatch.operator_secret = *secret;
  }
  auto server = api::ApiServer::create(io_, *this, ac, &g_api_logger);
  if (!server) return Error{"api: " + server.error().message};
  api_ = std::move(server).value();
  return {};
}

// ---------------------------------------------------------------- source thread

void Daemon::onOdometry(const OdometrySample& odometry) {
  const std::lock_guard lock(state_mutex_);
  if (T_map_resume_ && !have_odometry_) {
    // First sample after a resume. A source with a new frame (the simulator): the vehicle is where
    // it was last sent, in the old odometry frame. A persistent frame continues as it is.
    if (!source_->persistentFrame()) {
      const Pose3 T_oldodom_vehicle = T_map_odom_.inverse() * *T_map_resume_;
      T_oldodom_newodom_ = geometry::planarPart(T_oldodom_vehicle) * geometry::planarPart(odometry.T_odom_vehicle).inverse();
    }
    // A source whose clock restarted (the simulator) continues after the last mapped stamp.
    const std::int64_t last_ns = pipeline_last_stamp_ns_;
    if (odometry.stamp_ns <= last_ns) stamp_offset_ns_ = last_ns - odometry.stamp_ns + 1'000'000'000;
    if (stamp_offset_ns_ != 0) spdlog::info("source clock restarted: stamps shifted by {} ns", stamp_offset_ns_);
  }
  have_odometry_ = true;
  odometry_ = odometry;
  odometry_.stamp_ns += stamp_offset_ns_;
  if (T_oldodom_newodom_) odometry_.T_odom_vehicle = *T_oldodom_newodom_ * odometry.T_odom_vehicle;
}

bool Daemon::onScan(const slam::ScanInput& scan, const std::optional<Pose3>& T_world_vehicle_true) {
  if (config_.source == Source::kDevices && !chunk_gate_) {
    // Outside a mission (idle, complete, aborted) nothing is mapped; the raw log has the bytes.
    const std::lock_guard lock(queue_mutex_);
    ++scans_not_mapped_;
    return !stopping_.load();
  }
  slam::ScanInput aligned = scan;
  {
    const std::lock_guard lock(state_mutex_);
    if (T_oldodom_newodom_) aligned.T_world_vehicle_odom = *T_oldodom_newodom_ * scan.T_world_vehicle_odom;
    aligned.scan.stamp_ns += stamp_offset_ns_;
  }
  std::unique_lock lock(queue_mutex_);
  queue_cv_.wait(lock, [&] { return queue_.size() < kMaxQueuedScans || stopping_.load(); });
  if (stopping_) return false;
  queue_.push_back({std::move(aligned), T_world_vehicle_true});
  ++scans_unmapped_;
  queue_cv_.notify_all();
  return true;
}

void Daemon::onRawBytes(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) {
  chunk_gate_ = mappingGate(stamp_ns);
  recordRaw(device_id, stamp_ns, bytes);
}

bool Daemon::mappingGate(std::int64_t stamp_ns) {
  const bool gate = mapping_enabled_.load();
  if (logged_gate_ != gate) {
    const std::uint8_t byte = gate ? 1 : 0;
    recordRaw(kMappingGateDeviceId, stamp_ns, std::span<const std::uint8_t>(&byte, 1));
    logged_gate_ = gate;
  }
  return gate;
}

void Daemon::recordRaw(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) {
  const std::lock_guard lock(raw_log_mutex_);
  if (raw_log_failed_) return;
  if (Status st = raw_log_->append(device_id, stamp_ns, bytes); !st) {
    spdlog::error("raw log: {} (recording stops; mapping goes on)", st.error().message);
    raw_log_failed_ = true;
  }
}

Status Daemon::syncRawLog() {
  const std::lock_guard lock(raw_log_mutex_);
  return raw_log_->sync();
}

// ---------------------------------------------------------------- mapping thread

void Daemon::mappingLoop() {
  while (true) {
    ++mapping_beat_;
    QueuedScan item;
    {
      std::unique_lock lock(queue_mutex_);
      queue_cv_.wait_for(lock, std::chrono::milliseconds(200), [&] { return !queue_.empty() || stopping_.load(); });
      if (stopping_) break;
      if (queue_.empty()) continue;
      item = std::move(queue_.front());
      queue_.pop_front();
      queue_cv_.notify_all();
    }
    const slam::ScanInput& scan = item.scan;
    bool mapped = true;
    if (config_.source == Source::kSim) {
      // The simulator's "device" output is the scan itself (scan_record.hpp), with its true pose.
      mapped = mappingGate(scan.scan.stamp_ns);
      recordRaw(kSimScanDeviceId, scan.scan.stamp_ns, encodeScanRecord(scan));
      if (item.T_world_vehicle_true)
        recordRaw(kSimTruthDeviceId, scan.scan.stamp_ns, encodeTruthRecord({scan.scan.stamp_ns, *item.T_world_vehicle_true}));
    }
    if (!mapped) {
      const std::lock_guard lock(queue_mutex_);
      ++scans_not_mapped_;
      --scans_unmapped_;
      queue_cv_.notify_all();
      continue;
    }
    auto update = pipeline_->feed(scan);
    if (!update) {
      const std::lock_guard lock(state_mutex_);
      if (mapping_errors_++ < 10) spdlog::warn("mapping: scan at {} ns rejected: {}", scan.scan.stamp_ns, update.error().message);
    } else if (update->closed_submap || !update->moved.empty()) {
      if (auto st = persistUpdate(*update); !st) {
        fail("mission store", st.error());
        break;
      }
    }
    {
      const std::lock_guard lock(queue_mutex_);
      --scans_unmapped_;
    }
    queue_cv_.notify_all();
  }
  // The active submap is closed and stored on a clean shutdown, so nothing mapped is lost.
  if (!failure_) {
    auto update = pipeline_->finish();
    if (!update) {
      spdlog::warn("mapping: closing the active submap at shutdown: {}", update.error().message);
    } else if (update->closed_submap) {
      if (auto st = persistUpdate(*update); !st) spdlog::error("mission store at shutdown: {}", st.error().message);
    }
  }
  if (auto st = syncRawLog(); !st) spdlog::error("raw log: {}", st.error().message);
}

Status Daemon::persistUpdate(const slam::MappingUpdate& update) {
  // Durable first (the journal group is the commit), then visible to the merge and the API.
  if (update.closed_submap) {
    if (auto st = store_->onUpdate(*pipeline_, update); !st) return st;
    if (auto st = syncRawLog(); !st) return st;
    spdlog::info("submap {} closed ({} scans){}", *update.closed_submap, pipeline_->submaps().back().n_scans,
                 update.closures.empty() ? "" : ", " + std::to_string(update.closures.size()) + " loop closures");
  }
  merge_->submit(pipeline_->map().entries());
  publishMappingState();
  planner_cv_.notify_all();
  return {};
}

void Daemon::publishMappingState() {
  auto infos = std::make_shared<std::vector<api::SubmapInfo>>();
  for (const slam::SubmapRecord& r : pipeline_->submaps()) {
    api::SubmapInfo i;
    i.id = static_cast<std::uint32_t>(r.index);
    i.T_world_submap = r.T_world_base;
    i.n_scans = static_cast<std::uint32_t>(r.n_scans);
    i.first_stamp_ns = r.first_stamp_ns;
    i.last_stamp_ns = r.last_stamp_ns;
    i.closed = true;
    infos->push_back(i);
  }
  auto records = std::make_shared<const std::vector<slam::SubmapRecord>>(pipeline_->submaps());
  auto pairs = std::make_shared<const std::vector<slam::ClosurePair>>(slam::closurePairs(pipeline_->closures()));
  const std::lock_guard lock(state_mutex_);
  submap_infos_ = std::move(infos);
  submap_records_ = std::move(records);
  closure_pairs_ = std::move(pairs);
  n_closures_ = static_cast<std::uint32_t>(pipeline_->closures().size());
  if (!pipeline_->submaps().empty()) {
    const slam::SubmapRecord& r = pipeline_->submaps().back();
    T_map_odom_ = r.T_world_base * r.T_world_base_odom.inverse();
  }
}

// ---------------------------------------------------------------- planning thread

Pose3 Daemon::estimatedPose() const { return T_map_odom_ * odometry_.T_odom_vehicle; }

Pose3 Daemon::mapFromSource() const {
  const std::lock_guard lock(state_mutex_);
  return T_map_odom_ * (T_oldodom_newodom_ ? *T_oldodom_newodom_ : Pose3::Identity());
}

Status Daemon::sendWaypoints(const std::vector<plan::Waypoint>& waypoints_map, std::int64_t stamp_ns) {
  const Pose3 T_source_map = mapFromSource().inverse();
  std::vector<SourceWaypoint> out;
  for (const plan::Waypoint& w : waypoints_map) {
    const Pose3 T = T_source_map * fromWaypoint(w.p_world, w.yaw_rad);
    out.push_back({T.translation(), geometry::yawOf(T.linear())});
  }
  if (auto st = source_->setWaypoints(std::move(out)); !st) return st;
  for (const plan::Waypoint& w : waypoints_map) {
    api::Waypoint aw;
    aw.stamp_ns = stamp_ns;
    aw.T_world_target = fromWaypoint(w.p_world, w.yaw_rad);
    aw.speed_mps = config_.planner.v_max_mps;
    api_->publishWaypoint(aw);
    if (auto st = store_->onWaypoint({stamp_ns, w.p_world.x(), w.p_world.y(), w.p_world.z(), w.yaw_rad}); !st) return st;
  }
  return {};
}

void Daemon::recordStateLocked(mission::MissionState state) {
  mapping_enabled_ = state == mission::MissionState::kExploring || state == mission::MissionState::kReturning ||
                     state == mission::MissionState::kPaused;
  spdlog::info("mission: {}{}", mission::toString(state),
               state == mission::MissionState::kAborted ? " (" + mission_.reason() + ")" : std::string());
  if (auto st = store_->onState({odometry_.stamp_ns, state}); !st) spdlog::error("mission store: {}", st.error().message);
}

std::optional<std::vector<plan::Waypoint>> Daemon::pathHome(const std::shared_ptr<const map::MergedMap>& snapshot) {
  Pose3 T_now;
  {
    const std::lock_guard lock(state_mutex_);
    T_now = estimatedPose();
  }
  // A planning pass brings the planner's traversability grid up to this snapshot.
  if (auto r = planner_->plan(snapshot, toWaypoint(T_now)); !r) return std::nullopt;
  const plan::TraversabilityGrid* grid = planner_->traversability();
  if (grid == nullptr) return std::nullopt;
  auto path = grid->findPath(T_now.translation(), T_map_home_.translation());
  if (!path) {
    spdlog::warn("planner: no way home: {}", path.error().message);
    return std::nullopt;
  }
  // Keep the heading while travelling, then turn to the home heading in steps the vehicle may take.
  std::vector<plan::Waypoint> out;
  double yaw = geometry::yawOf(T_now.linear());
  for (std::size_t i = 1; i < path->size(); ++i) out.push_back({(*path)[i], yaw});
  const double home_yaw = geometry::yawOf(T_map_home_.linear());
  const double step = config_.planner.max_heading_change_rad;
  while (std::abs(geometry::wrapAngle(home_yaw - yaw)) > 1e-9) {
    yaw = geometry::wrapAngle(yaw + std::clamp(geometry::wrapAngle(home_yaw - yaw), -step, step));
    out.push_back({T_map_home_.translation(), yaw});
  }
  if (out.empty()) out.push_back(toWaypoint(T_map_home_));
  return out;
}

void Daemon::planningLoop() {
  while (!stopping_) {
    ++planning_beat_;
    bool start_now = false, returning = false, home_sent = false;
    std::size_t n_submaps = 0;
    Pose3 T_now;
    std::int64_t stamp = 0;
    std::shared_ptr<const std::vector<slam::SubmapRecord>> records;
    std::shared_ptr<const std::vector<slam::ClosurePair>> closures;
    {
      std::unique_lock lock(state_mutex_);
      planner_cv_.wait_for(lock, std::chrono::milliseconds(50));
      if (stopping_) break;
      if (!mission_.active()) {
        planner_state_ = mission_.state() == mission::MissionState::kComplete ? api::PlannerState::kFinished
                                                                                : api::PlannerState::kIdle;
        continue;
      }
      // A mission starts once navigation is up: its home and first waypoints are the vehicle's pose.
      start_now = have_odometry_ && std::exchange(mission_started_, false);
      returning = mission_.state() == mission::MissionState::kReturning;
      home_sent = home_path_sent_;
      n_submaps = submap_infos_ ? submap_infos_->size() : 0;
      T_now = estimatedPose();
      stamp = odometry_.stamp_ns;
      records = submap_records_;
      closures = closure_pairs_;
    }
    if (start_now) {
      if (n_submaps == 0) T_map_home_ = T_now;  // home is where a new mission starts
      plan::PlannerConfig pc = config_.planner;
      const mission::Box box = *mission_.box();
      pc.box_min_world_m = box.min_world_m;
      pc.box_max_world_m = box.max_world_m;
      auto planner = plan::NbvPlanner::create(pc, toWaypoint(T_map_home_));
      if (!planner) {
        spdlog::error("planner: {}", planner.error().message);
        const std::lock_guard lock(state_mutex_);
        mission_.setAbortReason("planner: " + planner.error().message);
        recordStateLocked(mission_.event(mission::MissionEvent::kNoPath));
        continue;
      }
      planner_ = std::move(planner).value();
      revisit_.reset();
      if (config_.mapping.loop_closures) {
        auto revisit = slam::RevisitPolicy::create(config_.revisit, stamp);
        if (!revisit) {
          fail("revisit", revisit.error());
          continue;
        }
        revisit_ = std::move(revisit).value();
      }
      if (n_submaps == 0) {
        // A full turn on the spot first: the vertical fan sees nothing ahead until it has swept around,
        // and the planner needs known free space to grow its tree in.
        std::vector<plan::Waypoint> spin;
        const double yaw0 = geometry::yawOf(T_now.linear());
        for (int k = 1; k <= 4; ++k) spin.push_back({T_now.translation(), geometry::wrapAngle(yaw0 + k * std::numbers::pi / 2)});
        if (auto st = sendWaypoints(spin, stamp); !st) fail("waypoints", st.error());
        continue;
      }
    }
    if (auto stopped = source_->takeObstruction(); stopped && planner_) {
      const Pose3 T_map_source = mapFromSource();
      const Eigen::Vector3d p = T_map_source * stopped->p_odom_m;
      if (auto back = planner_->reportObstruction(p, T_map_source * stopped->target_odom_m))
        spdlog::warn("planner: the vehicle was stopped short at ({:.2f}, {:.2f}, {:.2f}); backing off to ({:.2f}, {:.2f}, "
                     "{:.2f})",
                     p.x(), p.y(), p.z(), back->x(), back->y(), back->z());
    }
    if (!planner_ || !source_->idle()) {
      const std::lock_guard lock(state_mutex_);
      planner_state_ = api::PlannerState::kFollowing;
      continue;
    }
    if (returning && home_sent) {
      const std::lock_guard lock(state_mutex_);
      const mission::MissionState s = mission_.event(mission::MissionEvent::kArrivedHome);
      home_path_sent_ = false;
      recordStateLocked(s);
      continue;
    }
    if (config_.source == Source::kSim && config_.sim.speedup == 0.0) {
      // As fast as possible: simulated time stands still while the vehicle waits, so the planner can
      // see every scan taken so far mapped and merged, as in a lockstep run.
      std::unique_lock lock(queue_mutex_);
      queue_cv_.wait(lock, [&] { return scans_unmapped_ == 0 || stopping_.load(); });
      lock.unlock();
      if (stopping_ || !merge_->waitIdle()) continue;
    }
    auto snapshot = merge_->snapshot();
    if (!snapshot) continue;  // the first submap is not merged yet
    {
      const std::lock_guard lock(state_mutex_);
      planner_state_ = api::PlannerState::kPlanning;
    }
    if (!returning && n_submaps >= static_cast<std::size_t>(config_.mission.max_submaps)) {
      spdlog::info("planner: submap budget of {} reached", config_.mission.max_submaps);
      const std::lock_guard lock(state_mutex_);
      recordStateLocked(mission_.event(mission::MissionEvent::kExplorationDone));
      continue;  // the next pass takes the way home
    }
    if (returning) {
      auto home = pathHome(snapshot);
      {
        const std::lock_guard lock(state_mutex_);
        if (!home) {
          mission_.setAbortReason("no collision-free way home");
          recordStateLocked(mission_.event(mission::MissionEvent::kNoPath));
          continue;
        }
        home_path_sent_ = true;
        planner_state_ = api::PlannerState::kFollowing;
      }
      if (auto st = sendWaypoints(*home, stamp); !st) fail("waypoints", st.error());
      continue;
    }
    if (revisit_ && records && closures) {
      std::vector<plan::Waypoint> views;
      for (const Pose3& T : revisit_->due(*records, *closures, T_now.translation(), stamp)) views.push_back(toWaypoint(T));
      if (!views.empty()) {
        spdlog::info("planner: no loop closure to the older map for {:.0f} s; revisiting an old view",
                     config_.revisit.after_s);
        planner_->requestRevisit(std::move(views));
      }
    }
    const Clock::time_point t0 = Clock::now();
    auto result = planner_->plan(snapshot, toWaypoint(T_now));
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (!result) {
      spdlog::warn("planner: {}", result.error().message);
      const std::lock_guard lock(state_mutex_);
      mission_.setAbortReason("planner: " + result.error().message);
      recordStateLocked(mission_.event(mission::MissionEvent::kNoPath));
      continue;
    }
    spdlog::debug("planner: {} in {:.1f} ms, tree {}, gain {:.1f}", plan::toString(result->status), ms,
                  result->tree_size, result->best_gain);
    plans_csv_ << plan_iteration_++ << ',' << 1e-9 * static_cast<double>(stamp) << ',' << n_submaps << ',' << ms << ','
               << plan::toString(result->status) << ',' << result->best_gain << ',' << result->tree_size << ",\n"
               << std::flush;
    if (result->status == plan::PlanStatus::kNoPath) {
      spdlog::warn("planner: no path: {}", result->reason);
      (void)source_->setWaypoints({});
      const std::lock_guard lock(state_mutex_);
      mission_.setAbortReason("no path: " + result->reason);
      recordStateLocked(mission_.event(mission::MissionEvent::kNoPath));
      continue;
    }
    if (result->status == plan::PlanStatus::kComplete) {
      spdlog::info("planner: exploration complete ({}); returning home", result->reason);
      const std::lock_guard lock(state_mutex_);
      recordStateLocked(mission_.event(mission::MissionEvent::kExplorationDone));
      if (mission_.state() != mission::MissionState::kReturning) continue;  // paused or aborted meanwhile
      home_path_sent_ = true;
    }
    if (auto st = sendWaypoints(result->waypoints, stamp); !st) fail("waypoints", st.error());
  }
}

// ---------------------------------------------------------------- main thread

void Daemon::requestStop() {
  {
    const std::lock_guard lock(stop_mutex_);
    stop_requested_ = true;
  }
  stop_cv_.notify_all();
}

void Daemon::fail(const std::string& where, const Error& error) {
  spdlog::error("{}: {}", where, error.message);
  {
    const std::lock_guard lock(state_mutex_);
    if (!failure_) failure_ = Error{where + ": " + error.message};
  }
  requestStop();
}

Status Daemon::run() {
  auto port = api_->listen(config_.api.bind_address, config_.api.port);
  if (!port) return Error{"api: " + port.error().message};
  if (options_.port_file) {
    const std::filesystem::path tmp = options_.port_file->string() + ".tmp";
    std::ofstream(tmp) << *port << "\n";
    std::error_code ec;
    std::filesystem::rename(tmp, *options_.port_file, ec);
    if (ec) return Error{"cannot write the port file " + options_.port_file->string() + ": " + ec.message()};
  }

  asio::signal_set signals(io_, SIGINT, SIGTERM);
  signals.async_wait([this](const std::error_code& ec, int signal) {
    if (ec) return;
    spdlog::info("signal {}: stopping", signal);
    requestStop();
  });
  asio::steady_timer beat(io_);
  std::function<void()> tick = [&] {
    ++io_beat_;
    beat.expires_after(std::chrono::milliseconds(250));
    beat.async_wait([&](const std::error_code& ec) {
      if (!ec) tick();
    });
  };
  tick();
  auto work = asio::make_work_guard(io_);
  io_thread_ = std::thread([this] { io_.run(); });
  mapping_thread_ = std::thread([this] { mappingLoop(); });
  planning_thread_ = std::thread([this] { planningLoop(); });
  if (auto st = source_->start(*this); !st) fail("source", st.error());

  if (config_.mission.start_on_launch) {
    const std::lock_guard lock(state_mutex_);
    if (mission_.state() == mission::MissionState::kIdle) {
      if (auto r = mission_.command(mission::MissionCommandKind::kStart); r) {
        mission_started_ = true;
        recordStateLocked(*r);
      } else {
        spdlog::warn("mission.start_on_launch: {}", r.error().message);
      }
    }
  }
  notifier_.ready("mission " + std::string(mission::toString(mission_.state())));

  // Watchdog: WATCHDOG=1 only while every thread has beaten within the limit; a stuck thread lets
  // systemd restart the daemon (and the mission resumes from its directory).
  struct Beat {
    const char* name;
    std::function<std::uint64_t()> read;
    std::uint64_t last = 0;
    Clock::time_point changed = Clock::now();
  };
  std::vector<Beat> beats = {
      {"io", [this] { return io_beat_.load(); }},
      {"mapping", [this] { return mapping_beat_.load(); }},
      {"merge", [this] { return merge_->heartbeat(); }},
      {"planning", [this] { return planning_beat_.load(); }},
      {"source", [this] { return source_->heartbeat(); }},
  };
  const auto interval = notifier_.watchdogInterval();
  const Clock::duration stall_limit =
      interval ? std::chrono::duration_cast<Clock::duration>(*interval) : Clock::duration(std::chrono::seconds(10));
  Clock::time_point last_ping{}, last_status{}, last_pose{};
  bool stall_reported = false;
  while (true) {
    {
      std::unique_lock lock(stop_mutex_);
      stop_cv_.wait_for(lock, std::chrono::milliseconds(100), [&] { return stop_requested_; });
      if (stop_requested_) break;
    }
    const Clock::time_point now = Clock::now();
    bool alive = true;
    for (Beat& b : beats) {
      const std::uint64_t v = b.read();
      if (v != b.last) {
        b.last = v;
        b.changed = now;
      } else if (now - b.changed > stall_limit) {
        alive = false;
        if (!stall_reported)
          spdlog::error("watchdog: the {} thread has not reported for {} s", b.name,
                        std::chrono::duration_cast<std::chrono::seconds>(now - b.changed).count());
        stall_reported = true;
      }
    }
    if (alive && interval && now - last_ping >= *interval / 2) {
      notifier_.watchdog();
      last_ping = now;
    }
    if (auto st = source_->failure(); !st) fail("source", st.error());
    if (auto e = merge_->error()) fail("merge", *e);
    for (const map::MergeRecord& m : merge_->takeRecords()) {
      const std::lock_guard lock(state_mutex_);
      merges_csv_ << 1e-9 * static_cast<double>(odometry_.stamp_ns) << ',' << m.n_submaps << ',' << m.merge_ms << ','
                  << m.stats.remerged << '\n' << std::flush;
    }
    if (now - last_pose >= std::chrono::milliseconds(200)) {
      api::PoseUpdate p;
      {
        const std::lock_guard lock(state_mutex_);
        p.stamp_ns = odometry_.stamp_ns;
        p.T_world_vehicle = estimatedPose();
      }
      api_->publishPose(p);
      last_pose = now;
    }
    if (now - last_status >= std::chrono::seconds(1)) {
      const api::StatusReport s = status();
      api_->publishStatus(s);
      notifier_.status(std::string("mission ") + api::toString(s.mission_state) + ", " + std::to_string(s.n_submaps) +
                       " submaps, " + std::to_string(s.n_closures) + " loop closures");
      last_status = now;
    }
  }

  // Shutdown, in data-flow order.
  notifier_.stopping();
  const Clock::time_point t_stop = Clock::now();
  stopping_ = true;
  queue_cv_.notify_all();
  planner_cv_.notify_all();
  source_->stop();
  if (planning_thread_.joinable()) planning_thread_.join();
  if (mapping_thread_.joinable()) mapping_thread_.join();
  merge_->stop();
  api_->stop();  // posts the closing of every session; the io thread stops after it ran
  work.reset();
  asio::post(io_, [this] { io_.stop(); });
  if (io_thread_.joinable()) io_thread_.join();
  {
    const std::lock_guard lock(queue_mutex_);
    spdlog::info("stopped in {} ms ({} scans outside a mission were recorded, not mapped)",
                 std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - t_stop).count(), scans_not_mapped_);
  }
  const std::lock_guard lock(state_mutex_);
  if (failure_) return *failure_;
  return {};
}

// ---------------------------------------------------------------- API backend (io thread)

api::StatusReport Daemon::status() const {
  api::StatusReport s;
  s.devices = source_->health();
  const std::lock_guard lock(state_mutex_);
  s.stamp_ns = odometry_.stamp_ns;
  s.mission_state = toApi(mission_.state());
  s.T_world_vehicle = estimatedPose();
  s.sigma_xyz_m = odometry_.sigma_xyz_m;
  s.sigma_yaw_rad = odometry_.sigma_yaw_rad;
  s.n_submaps = submap_infos_ ? static_cast<std::uint32_t>(submap_infos_->size()) : 0;
  s.n_closures = n_closures_;
  s.planner_state = planner_state_;
  if (auto snap = merge_->snapshot()) s.map_version = snap->version();
  return s;
}

std::shared_ptr<const map::MergedMap> Daemon::mapSnapshot() const { return merge_->snapshot(); }

std::vector<api::SubmapInfo> Daemon::submaps() const {
  const std::lock_guard lock(state_mutex_);
  return submap_infos_ ? *submap_infos_ : std::vector<api::SubmapInfo>{};
}

std::shared_ptr<const api::Cloud> Daemon::cloud() const {
  // The reconstruction: centres of the merged map's occupied voxels, built once per map version.
  const auto snap = merge_->snapshot();
  if (!snap) return nullptr;
  {
    const std::lock_guard lock(state_mutex_);
    if (cloud_ && cloud_version_ == snap->version()) return cloud_;
  }
  auto cloud = std::make_shared<api::Cloud>();
  const double res = snap->resolution();
  snap->forEachKnown([&](const map::VoxelKey& key, const map::VoxelValue& value) {
    if (value.status != map::Occupancy::kOccupied) return;
    api::CloudPoint p;
    p.p_world_m = map::keyToCentre(key, res).cast<float>();
    cloud->push_back(p);
  });
  const std::lock_guard lock(state_mutex_);
  cloud_ = std::move(cloud);
  cloud_version_ = snap->version();
  return cloud_;
}

Result<api::MissionState> Daemon::command(const api::MissionCommand& command) {
  std::optional<mission::Box> box;
  if (command.kind == api::MissionCommand::Kind::kSetBox)
    box = mission::Box{command.box.min_world_m, command.box.max_world_m};
  bool hold = false;
  api::MissionState out;
  {
    const std::lock_guard lock(state_mutex_);
    auto r = mission_.command(toMission(command.kind), box);
    if (!r) {
      spdlog::warn("mission: {}", r.error().message);
      return r.error();
    }
    switch (command.kind) {
      case api::MissionCommand::Kind::kStart:
        mission_started_ = true;
        home_path_sent_ = false;
        break;
      case api::MissionCommand::Kind::kPause:
      case api::MissionCommand::Kind::kAbort:
        hold = true;
        home_path_sent_ = false;
        break;
      case api::MissionCommand::Kind::kReturnHome:
        hold = true;
        home_path_sent_ = false;
        break;
      case api::MissionCommand::Kind::kSetBox:
      case api::MissionCommand::Kind::kResume:
        break;
    }
    recordStateLocked(*r);
    out = toApi(*r);
  }
  if (hold) (void)source_->setWaypoints({});
  planner_cv_.notify_all();
  return out;
}

std::string Daemon::configText() const { return config_.text; }

}  // namespace vog::app
