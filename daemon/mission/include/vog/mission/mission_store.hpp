#pragma once
// MissionStore: one mission directory, everything needed to resume after a crash:
//   <dir>/journal.vogj    the journal (journal.hpp): submap groups, waypoints, mission states
//   <dir>/submaps/*.ot     the closed submaps' grids (submap_store.hpp)
// (the raw device log, raw_log.hpp, lives next to them as <dir>/raw.vogr, owned by the drivers' side).
//
// Write order per closed submap (the mapping thread, after MappingPipeline::feed() closed one):
// onSubmapClosed() stages its record and grid, onClosures() stages the accepted closures, onOptimized()
// stages the new estimates and queues the group; then the queue is written in order: the .ot durably
// and verified (submap_store.hpp), then the whole group appended and the journal fsync'ed. The
// OptimizedPoses record is the group's commit: a group without it at the end of the journal (a crash in
// the middle of an append) is dropped on open() and cut from the file; anywhere else it is an error.
// onUpdate() does the three steps from a MappingUpdate. Waypoints are appended and become durable with
// the next sync (next group or state change); state changes are synced at once.
//
// A failed write (a full disk, an I/O error) is not an error of the hooks: what failed stays queued in
// memory with everything after it (waypoints coalesced to the newest), the journal is rolled back to
// the end of the last written item (no record naming a bad file survives), health() reports the fault,
// and the queue is written again, oldest first, by the next hook or retryPending(). Errors of the hooks
// are only bad input (out of order, non-finite), which changes nothing.
//
// Resume: open() of an existing directory reads the journal (a torn last record is discarded and the
// file truncated), loads every committed submap's grid (checking size and CRC-32C) and returns the
// PipelineState for MappingPipeline::restore() plus the last mission state and waypoint. The submap that
// was active at the crash is lost by design: the next scan fed to the restored pipeline starts a new one.
//
// Lifecycle: open(), then the write hooks in any interleaving from any thread (a mutex serialises
// them). Invariants: the journal on disk always ends with a committed group or a non-group record after
// every sync; a submap's record is never synced before its .ot file is durable and verified; submap
// indices are consecutive from 0; the journal holds its items in the order the hooks queued them.
#include "vog/core/result.hpp"
#include "vog/map/grid_config.hpp"
#include "vog/mission/journal.hpp"
#include "vog/mission/submap_store.hpp"
#include "vog/slam/mapping_pipeline.hpp"

#include <cstdint>
#include <deque>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace vog::mission {

struct MissionResume {
  slam::PipelineState pipeline;             // committed submaps, closures, current estimates
  std::optional<MissionStateRecord> state;  // last mission state change
  std::optional<WaypointRecord> waypoint;   // last waypoint sent
  TailRecovery journal_tail;                // a torn last record, discarded
  std::size_t uncommitted_records = 0;      // records of an unfinished submap group, discarded
  std::size_t journal_records = 0;          // records kept
};

// What the store has not written yet.
struct StorageHealth {
  std::optional<Error> fault;       // the last write failure, while anything is pending
  std::size_t pending_submaps = 0;  // closed submaps queued, not yet committed
  std::size_t pending_records = 0;  // other journal records (waypoints, states) queued behind them
};

class MissionStore {
 public:
  static constexpr const char* kJournalFile = "journal.vogj";
  static constexpr const char* kRawLogFile = "raw.vogr";

  // Creates `dir` (and its parent directories) if missing, or resumes it; `resume` (optional)
  // receives what was there. `grid` is the mapping configuration's grid (the stored .ot files must
  // match its resolution).
  static Result<std::unique_ptr<MissionStore>> open(const std::filesystem::path& dir, const map::GridConfig& grid,
                                                    MissionResume* resume = nullptr);

  Status onSubmapClosed(const slam::ClosedSubmap& closed);
  Status onClosures(const std::vector<slam::LoopClosure>& closures);
  Status onOptimized(const std::vector<std::pair<slam::NodeId, slam::Vector6d>>& estimates);
  // The three hooks for one MappingUpdate (nothing when it closed no submap): all node estimates when
  // the graph was optimised, else only the new node's.
  Status onUpdate(const slam::MappingPipeline& pipeline, const slam::MappingUpdate& update);
  Status onWaypoint(const WaypointRecord& waypoint);
  Status onState(const MissionStateRecord& state);
  Status sync();
  // Writes what is pending (after a failed write), oldest first; what health() then says.
  StorageHealth retryPending();
  StorageHealth health() const;

  const std::filesystem::path& dir() const { return dir_; }
  std::int64_t nextSubmapIndex() const;

 private:
  // One item of the write queue: a submap group (its grid goes to its .ot file first, whose name, size
  // and CRC then complete the first record), a waypoint or a state change.
  struct PendingWrite {
    std::shared_ptr<const map::LocalGrid> grid;  // null once the .ot file is written, or no submap
    std::vector<JournalRecord> records;
    bool sync = true;  // waypoints are appended unsynced
  };

  MissionStore(std::filesystem::path dir, SubmapStore submaps, std::unique_ptr<Journal> journal,
               std::int64_t next_index)
      : dir_(std::move(dir)),
        submaps_(std::move(submaps)),
        journal_(std::move(journal)),
        written_bytes_(journal_->sizeBytes()),
        next_index_(next_index) {}
  // Queues `write` and writes the queue.
  void queueLocked(PendingWrite write);
  void flushLocked();
  StorageHealth healthLocked() const;

  const std::filesystem::path dir_;
  const SubmapStore submaps_;
  mutable std::mutex mutex_;
  std::unique_ptr<Journal> journal_;                   // guarded by mutex_
  std::uint64_t written_bytes_ = 0;                    // journal size after the last written item, guarded by mutex_
  bool journal_failed_ = false;                        // a write failed since; roll back first, guarded by mutex_
  std::vector<JournalRecord> staged_;                  // the open submap group, guarded by mutex_
  std::shared_ptr<const map::LocalGrid> staged_grid_;  // its grid, guarded by mutex_
  std::deque<PendingWrite> pending_;                   // not yet written, oldest first, guarded by mutex_
  std::optional<Error> fault_;                         // the last write failure, guarded by mutex_
  std::int64_t next_index_ = 0;                        // index the next onSubmapClosed must carry, guarded by mutex_
};

}  // namespace vog::mission
