#pragma once
// RawRecorder: the mission's raw log as vogd writes it. The source thread records device bytes
// before they are decoded, the mapping thread the simulator's scans; both share one log behind one
// lock. The first write error stops recording (logged once) and mapping goes on: the submaps and
// the journal matter more than the raw bytes.
//
// The mapping gate: whether inputs recorded now are mapped (the mission is exploring, returning or
// paused). A gate record is written whenever it changes, so a replay maps what the live run
// mapped. gate() is called by the one thread that records inputs (the source thread with devices,
// the mapping thread with the simulator), before it records them.

#include "vog/mission/raw_log.hpp"

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>

namespace vog::app {

class RawRecorder {
 public:
  explicit RawRecorder(std::unique_ptr<mission::RawLog> log) : log_(std::move(log)) {}

  void record(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes);
  // `enabled` as the input at stamp_ns sees it, recorded when it changed; returns it.
  bool gate(bool enabled, std::int64_t stamp_ns);
  // Makes everything recorded so far durable.
  Status sync();

 private:
  std::mutex mutex_;
  std::unique_ptr<mission::RawLog> log_;  // guarded by mutex_
  bool failed_ = false;                   // guarded by mutex_
  std::optional<bool> logged_gate_;       // the input-recording thread only
};

}  // namespace vog::app
