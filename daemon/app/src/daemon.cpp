#include "vog/app/daemon.hpp"

#include "vog/app/device_source.hpp"
#include "vog/app/sim_source.hpp"
#include "vog/app/watchdog.hpp"
#include "vog/core/atomic_file.hpp"

#include <asio/executor_work_guard.hpp>
#include <asio/post.hpp>
#include <asio/signal_set.hpp>
#include <asio/steady_timer.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
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
    case mission::MissionState::kNearHome: return api::MissionState::kNearHome;
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

}  // namespace

Result<std::unique_ptr<Daemon>> Daemon::create(const VogdConfig& config, const DaemonOptions& options) {
  std::unique_ptr<Daemon> d(new Daemon(config, options));
  if (auto st = d->init(); !st) return st.error();
  return d;
}

Daemon::Daemon(const VogdConfig& config, const DaemonOptions& options)
    : config_(config), options_(options), mission_(mission::Box{config.mission.box_min_m, config.mission.box_max_m}) {}

Daemon::~Daemon() {
  requestStop();
  scans_.stop();
  if (source_) source_->stop();
  for (std::thread* t : {&planning_thread_, &mapping_thread_}) {
    if (t->joinable()) {
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
  auto raw =
      mission::RawLog::open(mission_dir_ / mission::MissionStore::kRawLogFile, config_.mission.raw_log_max_bytes);
  if (!raw) return Error{"raw log: " + raw.error().message};
  raw_ = std::make_unique<RawRecorder>(std::move(raw).value());

  const bool resumed = !resume.pipeline.submaps.empty();
  auto pipeline = resumed ? slam::MappingPipeline::restore(config_.mapping, resume.pipeline)
                          : slam::MappingPipeline::create(config_.mapping);
  if (!pipeline) return Error{"mapping: " + pipeline.error().message};

  explore::ExplorationConfig ec;
  ec.planner = config_.planner;
  ec.revisits = config_.mapping.loop_closures;
  ec.revisit = config_.revisit;
  ec.max_submaps = config_.mission.max_submaps;
  auto controller = explore::ExplorationController::create(ec);
  if (!controller) return Error{"exploration: " + controller.error().message};
  controller_ = std::move(controller).value();

  if (resume.state) {
    const mission::MissionState s = resume.state->state;
    mission_ = mission::MissionControl(mission::Box{config_.mission.box_min_m, config_.mission.box_max_m}, s);
    mission_started_ = s == mission::MissionState::kExploring || s == mission::MissionState::kReturning ||
                       s == mission::MissionState::kPaused;
    mapping_enabled_ = mission_started_;
    raw_->setRecording(!mission_.ended());
  }
  std::optional<Pose3> sim_start;
  if (resumed) {
    // The vehicle is taken to be at the last waypoint sent (where its controller held it) or, without
    // one, at the newest submap's base.
    const slam::SubmapRecord& last = (*pipeline)->submaps().back();
    const Pose3 T_map_resume =
        resume.waypoint
            ? fromWaypoint(Eigen::Vector3d(resume.waypoint->x_m, resume.waypoint->y_m, resume.waypoint->z_m),
                           resume.waypoint->yaw_rad)
            : last.T_world_base;
    alignment_ =
        SourceAlignment(T_map_resume, last.T_world_base * last.T_world_base_odom.inverse(), last.last_stamp_ns);
    T_map_home_ = (*pipeline)->submaps().front().T_world_base;
    sim_start = geometry::planarPart(T_map_resume) * Pose3(Eigen::Translation3d(0, 0, T_map_resume.translation().z()));
    spdlog::info("mission {}: resumed {} submaps, {} loop closures, state {}", mission_dir_.string(),
                 (*pipeline)->submaps().size(), (*pipeline)->closures().size(), mission::toString(mission_.state()));
  } else {
    spdlog::info("mission {}: new", mission_dir_.string());
  }

  auto telemetry = TelemetryFiles::open(mission_dir_);
  if (!telemetry) return telemetry.error();
  telemetry_ = std::move(telemetry).value();

  auto merge = map::MergeWorker::create(grid, config_.merge);
  if (!merge) return Error{"merge: " + merge.error().message};
  merge_ = std::move(merge).value();
  mapping_ = std::make_unique<MappingStage>(config_.source == Source::kSim, std::move(pipeline).value(), *store_, *raw_,
                                            *merge_, [this] { planner_cv_.notify_all(); });

  if (options_.make_source) {
    auto source = options_.make_source();
    if (!source) return source.error();
    source_ = std::move(source).value();
  } else if (config_.source == Source::kSim) {
    auto source = SimSource::create(config_.sim, sim_start);
    if (!source) return source.error();
    source_ = std::move(source).value();
  } else {
    auto source = DeviceSource::create(config_.devices);
    if (!source) return source.error();
    source_ = std::move(source).value();
  }

  api::ApiServerConfig ac = config_.api.server;
  if (!config_.api.secret_file.empty()) {
    auto secret = readSecretFile(config_.api.secret_file);
    if (!secret) return Error{"api.secret_file: " + secret.error().message};
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
  if (!have_odometry_) {
    alignment_.firstSample(odometry, source_->persistentFrame());
    if (alignment_.stampOffsetNs() != 0)
      spdlog::info("source clock restarted: stamps shifted by {} ns", alignment_.stampOffsetNs());
  }
  have_odometry_ = true;
  odometry_ = alignment_.align(odometry);
}

bool Daemon::onScan(const slam::ScanInput& scan, const std::optional<Pose3>& T_world_vehicle_true) {
  if (config_.source == Source::kDevices && !chunk_gate_) {
    // Outside a mission (idle, complete, aborted) nothing is mapped; the raw log has the bytes.
    scans_.skipped();
    return !scans_.stopped();
  }
  slam::ScanInput aligned;
  {
    const std::lock_guard lock(state_mutex_);
    aligned = alignment_.align(scan);
  }
  return scans_.push({std::move(aligned), T_world_vehicle_true});
}

void Daemon::onRawBytes(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) {
  chunk_gate_ = raw_->gate(mapping_enabled_.load(), stamp_ns);
  raw_->record(device_id, stamp_ns, bytes);
}

// ---------------------------------------------------------------- mapping thread

// Maps until the queue ends: at a shutdown, after every scan the source handed over (the raw log
// holds their bytes, so a replay maps them too).
void Daemon::mappingLoop() {
  while (!scans_.ended()) {
    ++mapping_beat_;
    mapping_->retryStorage();
    std::optional<QueuedScan> item = scans_.pop(std::chrono::milliseconds(200));
    if (!item) continue;
    auto mapped = mapping_->process(*item, mapping_enabled_.load());
    if (!mapped) {
      fail("mission store", mapped.error());
      scans_.stop();  // releases a source waiting to queue a scan
      break;
    }
    scans_.done(*mapped);
  }
  bool failed = false;
  {
    const std::lock_guard lock(state_mutex_);
    failed = failure_.has_value();
  }
  mapping_->finish(!failed);
}

// ---------------------------------------------------------------- planning thread

Pose3 Daemon::estimatedPose(const MappingState& mapped) const { return mapped.T_map_odom * odometry_.T_odom_vehicle; }

Pose3 Daemon::mapFromSource() const {
  const std::lock_guard lock(state_mutex_);
  return mapping_->state()->T_map_odom * alignment_.T_oldodom_newodom();
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
    if (auto st = store_->onWaypoint({stamp_ns, w.p_world.x(), w.p_world.y(), w.p_world.z(), w.yaw_rad}); !st)
      return st;
  }
  return {};
}

void Daemon::recordStateLocked(mission::MissionState state) {
  raw_->setRecording(!mission_.ended());  // before the gate opens; stops at the gate that closes
  mapping_enabled_ = state == mission::MissionState::kExploring || state == mission::MissionState::kReturning ||
                     state == mission::MissionState::kPaused;
  spdlog::info("mission: {}{}", mission::toString(state),
               state == mission::MissionState::kAborted ? " (" + mission_.reason() + ")" : std::string());
  const std::lock_guard queue(journal_queue_mutex_);
  journal_queue_.push_back({odometry_.stamp_ns, state});
}

void Daemon::journalStates() {
  const std::lock_guard writer(journal_write_mutex_);
  std::vector<mission::MissionStateRecord> records;
  {
    const std::lock_guard queue(journal_queue_mutex_);
    records.swap(journal_queue_);
  }
  for (const mission::MissionStateRecord& r : records)
    if (auto st = store_->onState(r); !st) spdlog::error("mission store: {}", st.error().message);
}

void Daemon::applyEventLocked(mission::MissionEvent event, const std::string& reason) {
  const mission::MissionState before = mission_.state();
  if (event == mission::MissionEvent::kNoPath && mission_.active()) mission_.setAbortReason(reason);
  const mission::MissionState after = mission_.event(event);
  if (after == before) return;  // raced with a command (MissionControl ignores it): nothing to journal
  if (event == mission::MissionEvent::kExplorationDone)
    spdlog::info("planner: exploration ends ({}); returning home", reason);
  if (event == mission::MissionEvent::kNoPath || event == mission::MissionEvent::kArrivedNearHome)
    spdlog::warn("planner: {}", reason);
  recordStateLocked(after);
}

void Daemon::followControllerLocked() {
  for (const mission::MissionEvent event : controller_->eventsFor(mission_.state()))
    applyEventLocked(event,
                     event == mission::MissionEvent::kExplorationDone ? controller_->reason() : controller_->summary());
}

std::shared_ptr<const map::MergedMap> Daemon::planningSnapshot() {
  if (config_.source == Source::kSim && config_.sim.speedup == 0.0) {
    // As fast as possible: simulated time stands still while the vehicle waits, so the planner can
    // see every scan taken so far mapped and merged, as in a lockstep run.
    if (!scans_.waitDrained() || !merge_->waitIdle()) return nullptr;
  }
  return merge_->snapshot();
}

void Daemon::planningLoop() {
  while (!stopping_) {
    ++planning_beat_;
    journalStates();  // what the last step decided (every path of the loop comes back here)
    bool start_now = false, hold_now = false, returning = false;
    std::uint64_t commands = 0;
    mission::Box box;
    explore::StepInput in;
    const std::shared_ptr<const MappingState> mapped = mapping_->state();
    {
      std::unique_lock lock(state_mutex_);
      planner_cv_.wait_for(lock, std::chrono::milliseconds(50));
      if (stopping_) break;
      if (!mission_.active()) {
        planner_state_ =
            mission_.state() == mission::MissionState::kComplete || mission_.state() == mission::MissionState::kNearHome
                ? api::PlannerState::kFinished
                : api::PlannerState::kIdle;
        continue;
      }
      // A mission starts once navigation is up: its home and first waypoints are the vehicle's pose.
      start_now = have_odometry_ && std::exchange(mission_started_, false);
      hold_now = std::exchange(hold_requested_, false);
      returning = mission_.state() == mission::MissionState::kReturning;
      commands = commands_;
      box = *mission_.box();  // exploring needs a box (MissionControl)
      in.n_submaps = mapped->submaps.size();
      in.T_world_vehicle = estimatedPose(*mapped);  // the same publication as the submaps below
      in.stamp_ns = odometry_.stamp_ns;
    }
    if (start_now) {
      if (in.n_submaps == 0) T_map_home_ = in.T_world_vehicle;  // home is where a new mission starts
      if (auto st = controller_->start(T_map_home_, box, in.stamp_ns, in.n_submaps == 0); !st) {
        const std::lock_guard lock(state_mutex_);
        applyEventLocked(mission::MissionEvent::kNoPath, "planner: " + st.error().message);
        continue;
      }
    }
    if (!controller_->active()) {
      // Ended while a command held the mission (its events were not applied then): end it now.
      const std::lock_guard lock(state_mutex_);
      followControllerLocked();
      continue;
    }
    if (hold_now) controller_->hold();
    if (returning) controller_->returnHome();  // the operator's word, or a mission resumed on its way home
    if (auto stopped = source_->takeObstruction()) {
      const Pose3 T_map_source = mapFromSource();
      in.obstruction = explore::Obstruction{T_map_source * stopped->p_odom_m, T_map_source * stopped->target_odom_m};
      spdlog::warn("planner: the vehicle was stopped short at ({:.2f}, {:.2f}, {:.2f}); backing off",
                   in.obstruction->p_world.x(), in.obstruction->p_world.y(), in.obstruction->p_world.z());
    }
    in.vehicle_idle = source_->idle();
    // The wait for the map (as fast as possible: until mapping has caught up) is not the plan's time.
    Clock::duration map_wait{};
    in.map = [&]() -> Result<std::shared_ptr<const map::MergedMap>> {
      const Clock::time_point t = Clock::now();
      auto snapshot = planningSnapshot();
      map_wait += Clock::now() - t;
      return snapshot;
    };
    in.submaps = &mapped->records;
    in.closures = &mapped->closure_pairs;
    if (in.vehicle_idle || in.obstruction) {
      const std::lock_guard lock(state_mutex_);
      planner_state_ = api::PlannerState::kPlanning;
    }
    const Clock::time_point t0 = Clock::now();
    auto out = controller_->step(in);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0 - map_wait).count();
    if (!out) {
      const std::lock_guard lock(state_mutex_);
      applyEventLocked(mission::MissionEvent::kNoPath, "planner: " + out.error().message);
      continue;
    }
    if (out->plan) {
      const plan::PlanResult& r = *out->plan;
      spdlog::debug("planner: {} in {:.1f} ms, tree {}, gain {:.1f}", plan::toString(r.status), ms, r.tree_size,
                    r.best_gain);
      telemetry_->plan(in.stamp_ns, in.n_submaps, ms, r);
    }
    bool send = false;
    {
      const std::lock_guard lock(state_mutex_);
      followControllerLocked();
      // A command accepted meanwhile (pause, abort, return home) overrides this step's waypoints.
      send = out->waypoints && commands == commands_ && (mission_.active() || out->waypoints->empty());
      if (mission_.active())
        planner_state_ = (send && !out->waypoints->empty()) || !in.vehicle_idle ? api::PlannerState::kFollowing
                                                                                : api::PlannerState::kPlanning;
    }
    if (send)
      if (auto st = sendWaypoints(*out->waypoints, in.stamp_ns); !st) fail("waypoints", st.error());
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
    if (Status st = writeFileAtomically(*options_.port_file, std::to_string(*port) + "\n"); !st)
      return Error{"the port file " + options_.port_file->string() + ": " + st.error().message};
  }

  asio::signal_set signals(io_, SIGINT, SIGTERM);
  signals.async_wait([this](const std::error_code& ec, int signal) {
    if (ec) return;
    spdlog::info("signal {}: stopping", signal);
    requestStop();
  });
  // SIGHUP (a closed terminal, `systemctl reload`, `kill -HUP`) would end the process without a word
  // and lose the active submap: it is logged and ignored. The configuration is read at start only.
  asio::signal_set hangups(io_, SIGHUP);
  std::function<void()> ignoreHangups = [&] {
    hangups.async_wait([&](const std::error_code& ec, int) {
      if (ec) return;
      spdlog::warn("SIGHUP ignored: vogd reads its configuration at start only (restart it to apply a change)");
      ignoreHangups();
    });
  };
  ignoreHangups();
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
  journalStates();
  notifier_.ready("mission " + std::string(mission::toString(mission_.state())));

  // Watchdog: WATCHDOG=1 only while every thread has beaten within the limit; a stuck thread lets
  // systemd restart the daemon (and the mission resumes from its directory).
  const auto interval = notifier_.watchdogInterval();
  Watchdog watchdog(interval ? std::chrono::duration_cast<Clock::duration>(*interval)
                             : Clock::duration(std::chrono::seconds(10)));
  const Clock::time_point t_start = Clock::now();
  watchdog.add(
      "io", [this] { return io_beat_.load(); }, t_start);
  watchdog.add(
      "mapping", [this] { return mapping_beat_.load(); }, t_start);
  watchdog.add(
      "merge", [this] { return merge_->heartbeat(); }, t_start);
  watchdog.add(
      "planning", [this] { return planning_beat_.load(); }, t_start);
  watchdog.add(
      "source", [this] { return source_->heartbeat(); }, t_start);
  Clock::time_point last_ping{}, last_status{}, last_pose{};
  std::uint64_t graph_published = 0;
  while (true) {
    {
      std::unique_lock lock(stop_mutex_);
      stop_cv_.wait_for(lock, std::chrono::milliseconds(100), [&] { return stop_requested_; });
      if (stop_requested_) break;
    }
    const Clock::time_point now = Clock::now();
    const Watchdog::Check check = watchdog.check(now);
    for (const std::string& stalled : check.newly_stalled)
      spdlog::error("watchdog: the {} thread has not reported", stalled);
    if (check.alive && interval && now - last_ping >= *interval / 2) {
      notifier_.watchdog();
      last_ping = now;
    }
    if (auto st = source_->failure(); !st) fail("source", st.error());
    if (auto e = merge_->error()) fail("merge", *e);
    const std::vector<map::MergeRecord> merges = merge_->takeRecords();
    if (!merges.empty()) {
      std::int64_t stamp_ns = 0;
      {
        const std::lock_guard lock(state_mutex_);
        stamp_ns = odometry_.stamp_ns;
      }
      for (const map::MergeRecord& m : merges) telemetry_->merge(stamp_ns, m);
    }
    cloud_.update(merge_->snapshot());  // only when a client asked for a cloud since
    if (const auto graph = mapping_->state()->graph; graph && graph->version != graph_published) {
      api_->publishGraph();
      graph_published = graph->version;
    }
    if (now - last_pose >= std::chrono::milliseconds(200)) {
      api::PoseUpdate p;
      {
        const std::lock_guard lock(state_mutex_);
        p.stamp_ns = odometry_.stamp_ns;
        p.T_world_vehicle = estimatedPose(*mapping_->state());
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
  planner_cv_.notify_all();
  source_->stop();  // mapping goes on, so a source waiting to queue a scan finishes what it recorded
  scans_.close();   // mapping ends once it has mapped every queued scan
  if (planning_thread_.joinable()) planning_thread_.join();
  journalStates();  // the planning thread's last decision
  if (mapping_thread_.joinable()) mapping_thread_.join();
  merge_->stop();
  api_->stop();  // posts the closing of every session; the io thread stops after it ran
  work.reset();
  asio::post(io_, [this] { io_.stop(); });
  if (io_thread_.joinable()) io_thread_.join();
  spdlog::info("stopped in {} ms ({} scans outside a mission were recorded, not mapped)",
               std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - t_stop).count(),
               scans_.notMapped());
  const std::lock_guard lock(state_mutex_);
  if (failure_) return *failure_;
  return {};
}

// ---------------------------------------------------------------- API backend (io thread)

api::StatusReport Daemon::status() const {
  api::StatusReport s;
  s.devices = source_->health();
  s.devices.push_back(mapping_->storageHealth());
  const std::shared_ptr<const MappingState> mapped = mapping_->state();
  const std::lock_guard lock(state_mutex_);
  s.stamp_ns = odometry_.stamp_ns;
  s.mission_state = toApi(mission_.state());
  s.T_world_vehicle = estimatedPose(*mapped);
  s.sigma_xyz_m = odometry_.sigma_xyz_m;
  s.sigma_yaw_rad = odometry_.sigma_yaw_rad;
  s.n_submaps = static_cast<std::uint32_t>(mapped->submaps.size());
  s.n_closures = mapped->n_closures;
  s.graph_version = mapped->graph ? mapped->graph->version : 0;
  if (const std::optional<mission::Box>& box = mission_.box())
    s.box = api::ExplorationBox{box->min_world_m, box->max_world_m};
  s.planner_state = planner_state_;
  if (auto snap = merge_->snapshot()) s.map_version = snap->version();
  return s;
}

std::shared_ptr<const map::MergedMap> Daemon::mapSnapshot() const { return merge_->snapshot(); }

std::vector<api::SubmapInfo> Daemon::submaps() const { return mapping_->state()->submaps; }

std::shared_ptr<const api::GraphState> Daemon::graph() const { return mapping_->state()->graph; }

std::shared_ptr<const map::LocalGrid> Daemon::submapGrid(std::uint32_t id) const {
  const std::shared_ptr<const MappingState> mapped = mapping_->state();
  const auto it = std::lower_bound(mapped->entries.begin(), mapped->entries.end(), id,
                                   [](const map::SubmapEntry& e, std::uint32_t key) { return e.id < key; });
  return it != mapped->entries.end() && it->id == id ? it->grid : nullptr;
}

std::shared_ptr<const api::ServedCloud> Daemon::cloud() const { return cloud_.latest(); }

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
      case api::MissionCommand::Kind::kStart: mission_started_ = true; break;
      case api::MissionCommand::Kind::kPause:
      case api::MissionCommand::Kind::kAbort:
      case api::MissionCommand::Kind::kReturnHome:
        hold = true;  // the vehicle stops; the planning thread plans again when the mission moves
        hold_requested_ = true;
        break;
      case api::MissionCommand::Kind::kSetBox:
      case api::MissionCommand::Kind::kResume: break;
    }
    ++commands_;
    recordStateLocked(*r);
    out = toApi(*r);
  }
  journalStates();  // durable before the reply says the command was done
  if (hold) (void)source_->setWaypoints({});
  planner_cv_.notify_all();
  return out;
}

std::string Daemon::configText() const { return config_.text; }

}  // namespace vog::app
