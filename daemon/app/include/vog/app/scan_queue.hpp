#pragma once
// ScanQueue: the bounded queue from vogd's source thread to its mapping thread, with the count of
// scans taken but not yet mapped (so a run as fast as possible can wait until the map has caught up
// with the vehicle) and of scans recorded outside a mission (not mapped).
//
// Back-pressure: push() waits while the queue is full, so a source never runs ahead of mapping by
// more than `capacity` scans. close() ends the input at a shutdown: push() refuses, and pop() hands
// out what is queued, so every scan a source handed over is mapped. stop() drops them instead and
// releases every waiter: push() refuses and pop() returns nothing. Thread-safe (one lock, below).

#include "vog/geometry/pose.hpp"
#include "vog/slam/submap_builder.hpp"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>

namespace vog::app {

struct QueuedScan {
  slam::ScanInput scan;
  std::optional<geometry::Pose3> T_world_vehicle_true;  // simulator only, recorded for evaluation
};

class ScanQueue {
 public:
  explicit ScanQueue(std::size_t capacity) : capacity_(capacity) {}

  // Appends a scan, waiting while the queue is full; false once stopped.
  bool push(QueuedScan scan);
  // The oldest scan, waiting up to `timeout`; nothing on a timeout or once stopped. The caller
  // reports it done() when it has been mapped (or skipped).
  std::optional<QueuedScan> pop(std::chrono::milliseconds timeout);
  // A popped scan was mapped (or, `mapped` false, recorded only).
  void done(bool mapped);
  // A scan that arrived outside a mission was recorded only and never queued.
  void skipped();
  // Waits until every pushed scan is done(); false when stopped first.
  bool waitDrained();
  // No more scans come; the queued ones are still popped.
  void close();
  void stop();
  bool stopped() const;
  // Nothing more to pop: stopped, or closed and empty.
  bool ended() const;
  std::uint64_t notMapped() const;

 private:
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<QueuedScan> queue_;  // guarded by mutex_
  std::size_t unmapped_ = 0;      // pushed and not yet done(), guarded by mutex_
  std::uint64_t not_mapped_ = 0;  // recorded only, guarded by mutex_
  bool closed_ = false;           // guarded by mutex_
  bool stopped_ = false;          // guarded by mutex_
};

}  // namespace vog::app
