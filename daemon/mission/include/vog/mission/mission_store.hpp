#pragma once
// MissionStore: one mission directory, everything needed to resume after a crash:
//   <dir>/journal.vogj    the journal (journal.hpp): submap groups, waypoints, mission states
//   <dir>/submaps/*.ot     the closed submaps' grids (submap_store.hpp)
// (the raw device log, raw_log.hpp, lives next to them as <dir>/raw.vogr, owned by the drivers' side).
//
// Write order per closed submap (the mapping thread, after MappingPipeline::feed() closed one):
// onSubmapClosed() writes the .ot durably and stages its record, onClosures() stages the accepted
// closures, onOptimized() stages the new estimates and then appends the whole group and fsyncs the
// journal. The OptimizedPoses record is the group's commit: a group without it at the end of the journal
// (a crash in the middle of an append) is dropped on open() and cut from the file; anywhere else it is
// an error. onUpdate() does the three steps from a MappingUpdate. Waypoints are appended and become
// durable with the next sync (next group or state change); state changes are synced at once.
//
// Resume: open() of an existing directory reads the journal (a torn last record is discarded and the
// file truncated), loads every committed submap's grid (checking size and CRC-32C) and returns the
// PipelineState for MappingPipeline::restore() plus the last mission state and waypoint. The submap that
// was active at the crash is lost by design: the next scan fed to the restored pipeline starts a new one.
//
// Lifecycle: open(), then the write hooks in any interleaving from any thread (a mutex serialises
// them). Invariants: the journal on disk always ends with a committed group or a non-group record after
// every sync; a submap's record is never synced before its .ot file is durable; submap indices are
// consecutive from 0. After a failed write the store refuses further writes (reopen to recover).
#include "vog/core/result.hpp"
#include "vog/map/grid_config.hpp"
#include "vog/mission/journal.hpp"
#include "vog/mission/submap_store.hpp"
#include "vog/slam/mapping_pipeline.hpp"

#include <cstdint>
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

  const std::filesystem::path& dir() const { return dir_; }
  std::int64_t nextSubmapIndex() const;

 private:
  MissionStore(std::filesystem::path dir, SubmapStore submaps, std::unique_ptr<Journal> journal,
               std::int64_t next_index)
      : dir_(std::move(dir)), submaps_(std::move(submaps)), journal_(std::move(journal)), next_index_(next_index) {}
  Status appendLocked(const JournalRecord& record);

  const std::filesystem::path dir_;
  const SubmapStore submaps_;
  mutable std::mutex mutex_;
  std::unique_ptr<Journal> journal_;   // guarded by mutex_
  std::vector<JournalRecord> staged_;  // the open submap group, guarded by mutex_
  std::int64_t next_index_ = 0;        // index the next onSubmapClosed must carry, guarded by mutex_
  std::optional<Error> failed_;        // guarded by mutex_
};

}  // namespace vog::mission
