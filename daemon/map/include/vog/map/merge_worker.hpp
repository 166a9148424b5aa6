#pragma once
// MergeWorker: the merge thread (thesis 4.5.5, DESIGN "Threads in vogd" 3). The mapping side submits
// the VogMap's current entries after every change; the worker brings its MergedMap in line with the
// newest submitted set (MergedMap::sync: new submaps merged in, moved ones re-merged) and publishes an
// immutable snapshot. A sync that deferred moves (MergeConfig::max_moves_per_sync) is followed by
// another on the same set, unless a newer one has arrived: each publishes its snapshot, the first with
// the submaps around the vehicle moved. Readers (planner, API) take snapshot() at any time and never
// wait for a merge.
//
// Lifecycle: create() starts the thread; submit() any number of times from any thread; the destructor
// (or stop()) finishes the merge in progress, drops what is still queued and joins. Submissions
// coalesce: a set submitted while an older one waits replaces it (sync() is idempotent on the newest
// set, so nothing is lost). A failed merge is kept as error() and the worker stops merging; the last
// good snapshot stays readable.
// Threads: the merge thread owns merged_ and, inside each sync(), lends it MergeConfig::threads - 1
// helper threads (see MergedMap: each task owns a disjoint set of the map's shards for that call); the
// helpers are started and joined within the call, so between merges the merge thread is alone.
// Determinism: waitIdle() returns once every submitted set is merged and published. A lockstep caller
// that calls it at fixed points of simulated time (e.g. right before each submit) sees snapshots that
// depend only on its inputs, while the merge still overlaps with its own work in between.

#include "vog/core/result.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/map/vog_map.hpp"

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace vog::map {

// MergeConfig::threads resolved: 0 becomes std::thread::hardware_concurrency() (1 when unknown), at most 4.
int mergeThreadCount(const MergeConfig& config);

// Threads for MergedMap::sync: `tasks` tasks, task 0 on the calling thread, the others on threads
// started for the call and joined before it returns (a merge takes milliseconds, starting a thread tens
// of microseconds). A thread that cannot be started has its task run on the calling thread.
MergeThreads spawnMergeThreads(int tasks);

// One completed merge (a set whose moves were deferred has one record per sync).
struct MergeRecord {
  std::uint64_t sequence = 0;  // of the submitted set (1, 2, ...)
  std::size_t n_submaps = 0;
  double merge_ms = 0.0;  // wall time of sync() + snapshot()
  SyncStats stats;
};

class MergeWorker {
 public:
  static Result<std::unique_ptr<MergeWorker>> create(const GridConfig& grid, const MergeConfig& merge);
  ~MergeWorker();
  MergeWorker(const MergeWorker&) = delete;
  MergeWorker& operator=(const MergeWorker&) = delete;

  // Hands over the newest submap set; returns at once. Returns its sequence number.
  std::uint64_t submit(std::vector<SubmapEntry> entries);
  // The newest published snapshot; null before the first merge completes.
  std::shared_ptr<const MergedMap> snapshot() const;
  // Sequence number of the newest set the current snapshot reflects wholly (0: none yet).
  std::uint64_t mergedSequence() const;
  // Blocks until every set submitted so far is merged with nothing deferred (or the worker
  // failed/stopped): the error of a failed merge, else ok.
  Status waitIdle();
  // Completed merges since the last call (for timing figures).
  std::vector<MergeRecord> takeRecords();
  // The first merge error, if any.
  std::optional<Error> error() const;
  // Ends the thread (idempotent); queued sets are dropped.
  void stop();
  // Heartbeat for a watchdog: increases whenever the thread wakes up or finishes a merge.
  std::uint64_t heartbeat() const;

 private:
  MergeWorker(std::unique_ptr<MergedMap> merged, const MergeConfig& merge);
  void run();

  const MergeConfig config_;
  const MergeThreads threads_;         // how sync() runs in parallel (immutable)
  std::unique_ptr<MergedMap> merged_;  // merge thread only
  mutable std::mutex mutex_;
  std::condition_variable wake_;                     // work arrived or stop
  std::condition_variable idle_;                     // a merge finished
  std::optional<std::vector<SubmapEntry>> pending_;  // guarded by mutex_
  std::uint64_t submitted_ = 0;                      // guarded by mutex_
  std::uint64_t merged_sequence_ = 0;                // guarded by mutex_
  std::shared_ptr<const MergedMap> snapshot_;        // guarded by mutex_
  std::vector<MergeRecord> records_;                 // guarded by mutex_
  std::optional<Error> error_;                       // guarded by mutex_
  std::uint64_t heartbeat_ = 0;                      // guarded by mutex_
  bool stopping_ = false;                            // guarded by mutex_
  std::atomic<bool> cancel_{false};  // set by stop() with mutex_ held (with stopping_); read by the merge in progress
  std::thread thread_;
};

}  // namespace vog::map
