#pragma once
// MappingStage: the work of vogd's mapping thread. It owns the mapping pipeline (submaps, loop
// closures, optimisation) and takes the scans the source queued: with the simulator it first records
// each scan (and its true pose) in the raw log behind the mapping gate; a scan outside a mission is
// recorded only. Every closed submap goes to the MissionStore (.ot + journal group, fsync, and the raw
// log synced) before the merge and the API hear of it; then the stage hands the map's entries to the
// merge worker and publishes a MappingState for the other threads. When the store cannot write (a full
// disk) mapping goes on in memory: the store keeps the submaps pending, retryStorage() writes them
// once it can, and storageHealth() reports it.
//
// Threads: process(), finish() and retryStorage() on the mapping thread only (the pipeline is that
// thread's); state() and storageHealth() from any thread (the published state behind its own lock, an
// immutable snapshot; the store and the recorder have their own locks).

#include "vog/api/domain.hpp"
#include "vog/app/raw_recorder.hpp"
#include "vog/app/scan_queue.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/map/merge_worker.hpp"
#include "vog/mission/mission_store.hpp"
#include "vog/slam/mapping_pipeline.hpp"
#include "vog/slam/revisit_policy.hpp"

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

namespace vog::app {

// What the mapping thread last published: the closed submaps (as the API lists them and as the
// revisit policy reads them), the loop closures' submap pairs, and the map frame's offset from the
// odometry frame. Immutable once published.
struct MappingState {
  std::vector<api::SubmapInfo> submaps;
  std::vector<map::SubmapEntry> entries;  // the closed submaps' grids (shared, immutable) and base poses
  // The pose graph as the API serves it: its version grows when a base pose or the closures changed.
  std::shared_ptr<const api::GraphState> graph;
  std::vector<slam::SubmapRecord> records;
  std::vector<slam::ClosurePair> closure_pairs;
  std::uint32_t n_closures = 0;
  // T_map_odom from the newest submap: its optimised base pose times the inverse of its odometry
  // base pose (identity before the first submap).
  geometry::Pose3 T_map_odom = geometry::Pose3::Identity();
};

class MappingStage {
 public:
  // A resumed pipeline's map goes to the merge at once. `published` is called (mapping thread) after
  // each publication, e.g. to wake the planner.
  MappingStage(bool record_scans, std::unique_ptr<slam::MappingPipeline> pipeline, mission::MissionStore& store,
               RawRecorder& raw, map::MergeWorker& merge, std::function<void()> published);

  // One queued scan. `record_scans` (the simulator): the scan and its truth go to the raw log first,
  // and `mapping_enabled` gates it. Returns whether the scan was mapped; a scan the pipeline refuses
  // is logged (the first ten) and counted, not an error. Errors only when the mission store refuses
  // the update as inconsistent (a bug); a write failure is pending in the store, not an error.
  Result<bool> process(const QueuedScan& item, bool mapping_enabled);
  // At a clean shutdown: the active submap is closed and stored, so nothing mapped is lost
  // (`store_active` false after a store failure: then only the raw log is synced).
  void finish(bool store_active);

  // Writes what the store holds pending, at most once a second (the mapping thread calls it on every
  // loop); a closed submap tries at once.
  void retryStorage();
  // The storage as a health entry like the devices': "storage", its state and the error text, e.g.
  // "... No space left on device (2 submaps pending)", or the raw log's dropped segments.
  api::DeviceHealth storageHealth() const;

  std::shared_ptr<const MappingState> state() const;
  std::uint64_t rejectedScans() const { return rejected_scans_; }  // mapping thread

 private:
  Status persist(const slam::MappingUpdate& update);
  void publish();
  // The API's pose graph of `s`: the previous one when nothing in it changed, else the next version.
  std::shared_ptr<const api::GraphState> graphOf(const MappingState& s);
  // Logs a storage fault when it appears and when it is over.
  void logStorage(const mission::StorageHealth& health);

  const bool record_scans_;
  std::unique_ptr<slam::MappingPipeline> pipeline_;  // mapping thread
  mission::MissionStore& store_;
  RawRecorder& raw_;
  map::MergeWorker& merge_;
  const std::function<void()> published_;
  std::uint64_t rejected_scans_ = 0;                    // mapping thread
  std::uint64_t graph_version_ = 0;                     // mapping thread
  bool storage_fault_logged_ = false;                   // mapping thread
  std::chrono::steady_clock::time_point last_retry_{};  // mapping thread

  mutable std::mutex mutex_;
  std::shared_ptr<const MappingState> state_;  // guarded by mutex_
};

}  // namespace vog::app
