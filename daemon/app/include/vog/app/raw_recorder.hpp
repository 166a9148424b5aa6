#pragma once
// RawRecorder: the mission's raw log as vogd writes it. The source thread records device bytes
// before they are decoded, the mapping thread the simulator's scans; both share one log behind one
// lock. The first write error stops recording (logged once, and in health()) and mapping goes on: the
// submaps and the journal matter more than the raw bytes. Recording also stops when the mission ends
// (setRecording(false), effective at the next closed gate), and starts again with a new one.
//
// The mapping gate: whether inputs recorded now are mapped (the mission is exploring, returning or
// paused). A gate record is written whenever it changes, and again at the start of every segment of
// the log, so that a replay of the segments left after the oldest were dropped maps what the live run
// mapped. gate() is called by the one thread that records inputs (the source thread with devices,
// the mapping thread with the simulator), before it records them.

#include "vog/mission/raw_log.hpp"

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>

namespace vog::app {

class RawRecorder {
 public:
  explicit RawRecorder(std::unique_ptr<mission::RawLog> log);

  void record(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes);
  // `enabled` as the input at stamp_ns sees it, recorded when it changed; returns it.
  bool gate(bool enabled, std::int64_t stamp_ns);
  // Off: records are dropped once the gate is closed (the gate record that closes it is the last one
  // kept, so that every input mapped live is in the log); on: recorded again. Call it with on before
  // the gate opens.
  void setRecording(bool on);
  // Makes everything recorded so far durable; a failure stops recording.
  void sync();

  struct Health {
    std::optional<std::string> fault;  // the write error that stopped recording
    bool recording = true;
    std::uint64_t dropped_segments = 0;  // oldest segments deleted to stay within the cap
    std::uint64_t dropped_bytes = 0;
  };
  Health health() const;

 private:
  void appendLocked(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes);

  mutable std::mutex mutex_;
  std::unique_ptr<mission::RawLog> log_;     // guarded by mutex_
  std::optional<std::string> fault_;         // guarded by mutex_
  bool recording_ = true;                    // guarded by mutex_
  std::optional<std::uint8_t> gate_record_;  // the last gate recorded, guarded by mutex_
  std::optional<bool> logged_gate_;          // the input-recording thread only
};

}  // namespace vog::app
