#pragma once
// Daemon: vogd's wiring (DESIGN "Threads in vogd"). One process, these threads:
//   io        Asio io_context: the API server, signals (SIGTERM/SIGINT stop the daemon; SIGHUP is logged
//             and ignored)
//   source    the vehicle source producing odometry and scans: SimSource (the simulator) or
//             DeviceSource (the vehicle's devices on their own io_context; raw bytes to the raw log)
//   mapping   scans -> MappingPipeline (submaps, loop closures, optimisation); every closed submap is
//             made durable (MissionStore: .ot + journal group, fsync) before the merge hears of it
//   merge     MergeWorker: keeps the merged map current and publishes immutable snapshots
//   planning  the mission's closed loop (explore::ExplorationController: spin, NBV plans on the newest
//             snapshot, revisits, obstructions, the way home, the ending), the mission state machine
//             fed by its events; waypoints to the vehicle, the API and the journal
//   main      run(): systemd notify (READY, WATCHDOG while every thread beats, STOPPING), status, and
//             the API's reconstruction cloud when one was asked for
// Queues: source -> mapping (bounded; the source waits when mapping is behind), mapping -> merge
// (coalescing), merge -> planning/API (snapshots). Slow API clients never block any of them (the
// server's per-client queues drop or coalesce).
//
// Frames: the planner works in the map frame (the optimised estimate); the vehicle steers in its odometry
// frame. T_map_odom comes from the newest submap (its optimised base pose times the inverse of its
// odometry base pose). After a restart SourceAlignment brings the source's new frame and clock into
// the mission's.
//
// Parts with their own state: MappingStage (the mapping thread's pipeline, persistence and published
// state), ExplorationController (the loop's policy), ScanQueue (source -> mapping), RawRecorder (the
// raw log and the mapping gate), SourceAlignment, TelemetryFiles (iterations.csv, merges.csv),
// ReconstructionCloud (the API's cloud) and Watchdog (thread heartbeats for systemd).
//
// Lifecycle: create() opens (or resumes) the mission directory and builds every component; run() blocks
// until requestStop() or a signal, then shuts down in order (source, planning, mapping with every queued
// scan mapped and the active submap closed and stored, merge, API) and returns.

#include "vog/api/api_server.hpp"
#include "vog/api/domain.hpp"
#include "vog/app/mapping_stage.hpp"
#include "vog/app/raw_recorder.hpp"
#include "vog/app/reconstruction_cloud.hpp"
#include "vog/app/scan_queue.hpp"
#include "vog/app/source_alignment.hpp"
#include "vog/app/systemd_notify.hpp"
#include "vog/app/telemetry.hpp"
#include "vog/app/vehicle_source.hpp"
#include "vog/app/vogd_config.hpp"
#include "vog/explore/exploration_controller.hpp"
#include "vog/map/merge_worker.hpp"
#include "vog/mission/mission_control.hpp"
#include "vog/mission/mission_store.hpp"
#include "vog/slam/mapping_pipeline.hpp"
#include "vog/slam/revisit_policy.hpp"

#include <asio/io_context.hpp>

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

namespace vog::app {

struct DaemonOptions {
  std::optional<std::filesystem::path> mission_dir;  // replaces mission.directory/mission.name
  std::optional<std::filesystem::path> port_file;    // the bound API port is written here (port 0 picks one)
  // Builds the vehicle source instead of the one config.source names (a scripted vehicle in tests);
  // with `source: sim`, its scans are recorded as the simulator's are.
  std::function<Result<std::unique_ptr<VehicleSource>>()> make_source;
};

class Daemon final : public api::ApiBackend, private SourceSink {
 public:
  static Result<std::unique_ptr<Daemon>> create(const VogdConfig& config, const DaemonOptions& options = {});
  ~Daemon() override;

  // Blocks until stopped; the error that stopped it, if any.
  Status run();
  // Thread-safe.
  void requestStop();

  const std::filesystem::path& missionDir() const { return mission_dir_; }

  // --- api::ApiBackend (io thread) ---
  api::StatusReport status() const override;
  std::shared_ptr<const map::MergedMap> mapSnapshot() const override;
  std::vector<api::SubmapInfo> submaps() const override;
  std::shared_ptr<const api::GraphState> graph() const override;
  std::shared_ptr<const map::LocalGrid> submapGrid(std::uint32_t id) const override;
  std::shared_ptr<const api::ServedCloud> cloud() const override;
  Result<api::MissionState> command(const api::MissionCommand& command) override;
  std::string configText() const override;

 private:
  Daemon(const VogdConfig& config, const DaemonOptions& options);
  Status init();

  // --- SourceSink (source thread) ---
  void onOdometry(const OdometrySample& odometry) override;
  bool onScan(const slam::ScanInput& scan, const std::optional<geometry::Pose3>& T_world_vehicle_true) override;
  void onRawBytes(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) override;

  void mappingLoop();
  void planningLoop();
  // The vehicle in the map frame, by the given published mapping state; the caller holds state_mutex_.
  geometry::Pose3 estimatedPose(const MappingState& mapped) const;
  geometry::Pose3 mapFromSource() const;  // T_map_source: the source's odometry frame in the map (locks state)
  Status sendWaypoints(const std::vector<plan::Waypoint>& waypoints_map, std::int64_t stamp_ns);
  // Logs a mission state and queues it for the journal; the caller holds state_mutex_.
  void recordStateLocked(mission::MissionState state);
  // Writes the queued mission states to the journal (fsync), in the order they were decided; called
  // without state_mutex_, so the journal's I/O never holds up the threads that take it.
  void journalStates();
  // Applies an event of the exploration (with its reason for kNoPath), journalling the state when it
  // changed; the caller holds state_mutex_.
  void applyEventLocked(mission::MissionEvent event, const std::string& reason);
  // Applies what the mission state machine has not heard from the controller yet (its events raced
  // with a command such as a pause are applied once the mission moves again); the caller holds
  // state_mutex_.
  void followControllerLocked();
  // The merged map the planner plans on; as fast as possible (simulator, speedup 0) it first waits
  // until every scan taken so far is mapped and merged, as in a lockstep run. Planning thread.
  std::shared_ptr<const map::MergedMap> planningSnapshot();
  void fail(const std::string& where, const Error& error);

  const VogdConfig config_;
  const DaemonOptions options_;
  std::filesystem::path mission_dir_;
  SystemdNotifier notifier_;

  // Components.
  std::unique_ptr<mission::MissionStore> store_;
  std::unique_ptr<RawRecorder> raw_;          // the raw log (its own lock)
  std::atomic<bool> mapping_enabled_{false};  // the mission is exploring, returning or paused
  bool chunk_gate_ = false;                   // source thread: the gate of the chunk being decoded
  std::unique_ptr<MappingStage> mapping_;     // process()/finish(): mapping thread; state(): any
  std::unique_ptr<map::MergeWorker> merge_;
  std::optional<explore::ExplorationController> controller_;  // planning thread
  geometry::Pose3 T_map_home_ = geometry::Pose3::Identity();  // planning thread (set by init() on a resume)
  std::unique_ptr<VehicleSource> source_;
  asio::io_context io_;
  std::unique_ptr<api::ApiServer> api_;

  ScanQueue scans_{256};               // source -> mapping (its own lock)
  mutable ReconstructionCloud cloud_;  // the API's cloud (its own lock; built by the main thread)

  // Shared state, guarded by state_mutex_.
  mutable std::mutex state_mutex_;
  std::condition_variable planner_cv_;
  mission::MissionControl mission_;
  bool mission_started_ = false;  // the controller must (re)start for a new mission
  bool hold_requested_ = false;   // a command stopped the vehicle; the controller plans again
  std::uint64_t commands_ = 0;    // mission commands accepted (a step's waypoints older than one are dropped)
  api::PlannerState planner_state_ = api::PlannerState::kIdle;
  SourceAlignment alignment_;   // a resumed source's frame and clock
  bool have_odometry_ = false;  // a sample arrived since launch
  OdometrySample odometry_;     // newest, aligned
  std::optional<Error> failure_;

  // Mission states decided under state_mutex_ and not yet journalled (journalStates()).
  std::mutex journal_queue_mutex_;  // guards journal_queue_; taken inside state_mutex_, never around it
  std::vector<mission::MissionStateRecord> journal_queue_;
  std::mutex journal_write_mutex_;  // one writer at a time: records reach the journal in their order

  std::unique_ptr<TelemetryFiles> telemetry_;  // iterations.csv (planning thread), merges.csv (main thread)

  // Threads and their heartbeats.
  std::atomic<bool> stopping_{false};
  std::atomic<std::uint64_t> mapping_beat_{0}, planning_beat_{0}, io_beat_{0};
  std::thread io_thread_, mapping_thread_, planning_thread_;
  std::mutex stop_mutex_;
  std::condition_variable stop_cv_;
  bool stop_requested_ = false;  // guarded by stop_mutex_
};

}  // namespace vog::app
