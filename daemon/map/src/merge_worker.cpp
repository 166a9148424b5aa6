#include "vog/map/merge_worker.hpp"

#include <algorithm>
#include <chrono>
#include <system_error>
#include <utility>

namespace vog::map {

int mergeThreadCount(const MergeConfig& config) {
  constexpr int kMaxDefault = 4;
  if (config.threads > 0) return config.threads;
  const auto hardware = static_cast<int>(std::thread::hardware_concurrency());
  return std::clamp(hardware, 1, kMaxDefault);
}

MergeThreads spawnMergeThreads(int tasks) {
  MergeThreads threads;
  threads.tasks = std::max(1, tasks);
  if (threads.tasks == 1) return threads;
  threads.run = [n = threads.tasks](const std::function<void(int)>& task) {
    std::vector<std::thread> helpers;
    helpers.reserve(static_cast<std::size_t>(n - 1));
    std::vector<int> inline_tasks{0};
    for (int t = 1; t < n; ++t) {
      try {
        helpers.emplace_back(task, t);
      } catch (const std::system_error&) {
        inline_tasks.push_back(t);
      }
    }
    for (int t : inline_tasks) task(t);
    for (std::thread& h : helpers) h.join();
  };
  return threads;
}

Result<std::unique_ptr<MergeWorker>> MergeWorker::create(const GridConfig& grid, const MergeConfig& merge) {
  if (auto st = merge.validate(); !st) return st.error();
  auto merged = MergedMap::create(grid);
  if (!merged) return merged.error();
  std::unique_ptr<MergeWorker> worker(new MergeWorker(std::move(merged).value(), merge));
  worker->thread_ = std::thread([w = worker.get()] { w->run(); });
  return worker;
}

MergeWorker::MergeWorker(std::unique_ptr<MergedMap> merged, const MergeConfig& merge)
    : config_(merge), threads_(spawnMergeThreads(mergeThreadCount(merge))), merged_(std::move(merged)) {}

MergeWorker::~MergeWorker() { stop(); }

void MergeWorker::stop() {
  {
    // cancel_ is set under the lock: a merge that saw it and then takes the lock sees stopping_ too, so
    // its cancellation is never reported as a failed merge.
    const std::lock_guard lock(mutex_);
    stopping_ = true;
    cancel_ = true;
    pending_.reset();
  }
  wake_.notify_all();
  idle_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::uint64_t MergeWorker::submit(std::vector<SubmapEntry> entries) {
  std::uint64_t sequence = 0;
  {
    const std::lock_guard lock(mutex_);
    pending_ = std::move(entries);
    sequence = ++submitted_;
  }
  wake_.notify_one();
  return sequence;
}

std::shared_ptr<const MergedMap> MergeWorker::snapshot() const {
  const std::lock_guard lock(mutex_);
  return snapshot_;
}

std::uint64_t MergeWorker::mergedSequence() const {
  const std::lock_guard lock(mutex_);
  return merged_sequence_;
}

Status MergeWorker::waitIdle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [&] { return merged_sequence_ == submitted_ || error_ || stopping_; });
  if (error_) return *error_;
  return {};
}

std::vector<MergeRecord> MergeWorker::takeRecords() {
  const std::lock_guard lock(mutex_);
  return std::exchange(records_, {});
}

std::optional<Error> MergeWorker::error() const {
  const std::lock_guard lock(mutex_);
  return error_;
}

std::uint64_t MergeWorker::heartbeat() const {
  const std::lock_guard lock(mutex_);
  return heartbeat_;
}

void MergeWorker::run() {
  std::unique_lock lock(mutex_);
  // The set of the last sync when it deferred moves (MergeConfig::max_moves_per_sync), synced again
  // until nothing is deferred or a newer set replaces it (merge thread only; `lock` is not needed).
  std::optional<std::vector<SubmapEntry>> unfinished;
  std::uint64_t unfinished_sequence = 0;
  while (true) {
    // A periodic wake-up keeps the heartbeat moving while there is nothing to merge.
    wake_.wait_for(lock, std::chrono::milliseconds(200),
                   [&] { return stopping_ || ((pending_ || unfinished) && !error_); });
    ++heartbeat_;
    if (stopping_) return;
    if ((!pending_ && !unfinished) || error_) continue;
    std::vector<SubmapEntry> entries;
    std::uint64_t sequence = 0;
    if (pending_) {
      entries = std::move(*pending_);
      pending_.reset();
      sequence = submitted_;
    } else {
      entries = std::move(*unfinished);
      sequence = unfinished_sequence;
    }
    unfinished.reset();
    lock.unlock();

    const auto t0 = std::chrono::steady_clock::now();
    // A shutdown does not wait for a whole re-merge: the merged map is rebuilt from the submaps on resume.
    auto stats = merged_->sync(
        entries, config_, [this] { return cancel_.load(); }, threads_);
    std::shared_ptr<const MergedMap> snapshot;
    if (stats) snapshot = merged_->snapshot();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

    lock.lock();
    ++heartbeat_;
    if (stopping_) return;  // cancelled, or finished after stop(): nothing more is published
    if (!stats) {
      error_ = Error{"merge of submap set " + std::to_string(sequence) + ": " + stats.error().message};
      merged_sequence_ = sequence;
    } else {
      snapshot_ = std::move(snapshot);
      records_.push_back({sequence, entries.size(), ms, *stats});
      if (stats->deferred > 0) {
        unfinished = std::move(entries);
        unfinished_sequence = sequence;
      } else {
        merged_sequence_ = sequence;
      }
    }
    idle_.notify_all();
  }
}

}  // namespace vog::map
