#include "vog/app/raw_recorder.hpp"

#include "vog/app/scan_record.hpp"

#include <spdlog/spdlog.h>

namespace vog::app {

RawRecorder::RawRecorder(std::unique_ptr<mission::RawLog> log) : log_(std::move(log)) {}

void RawRecorder::appendLocked(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) {
  // Off, recording stops at the first closed gate, so that every input mapped live is in the log.
  if (fault_ || (!recording_ && gate_record_ != 1)) return;
  const std::uint64_t segment = log_->segmentIndex();
  const std::uint64_t dropped = log_->droppedSegments();
  Status st = log_->append(device_id, stamp_ns, bytes);
  if (device_id == kMappingGateDeviceId && bytes.size() == 1) gate_record_ = bytes[0];
  if (st && log_->droppedSegments() != dropped)
    spdlog::warn("raw log: dropped its {} oldest segments ({} bytes) to stay within mission.raw_log_max_bytes",
                 log_->droppedSegments(), log_->droppedBytes());
  // A new segment starts with the gate, so that it replays alone.
  if (st && log_->segmentIndex() != segment && gate_record_)
    st = log_->append(kMappingGateDeviceId, stamp_ns, std::span<const std::uint8_t>(&*gate_record_, 1));
  if (!st) {
    spdlog::error("raw log: {} (recording stops; mapping goes on)", st.error().message);
    fault_ = st.error().message;
  }
}

void RawRecorder::record(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) {
  const std::lock_guard lock(mutex_);
  appendLocked(device_id, stamp_ns, bytes);
}

bool RawRecorder::gate(bool enabled, std::int64_t stamp_ns) {
  if (logged_gate_ != enabled) {
    const std::uint8_t byte = enabled ? 1 : 0;
    record(kMappingGateDeviceId, stamp_ns, std::span<const std::uint8_t>(&byte, 1));
    logged_gate_ = enabled;
  }
  return enabled;
}

void RawRecorder::setRecording(bool on) {
  {
    const std::lock_guard lock(mutex_);
    if (recording_ == on) return;
    recording_ = on;
  }
  if (!on) sync();
  spdlog::info("raw log: recording {}", on ? "starts" : "stops (the mission ended)");
}

void RawRecorder::sync() {
  const std::lock_guard lock(mutex_);
  if (fault_) return;
  if (Status st = log_->sync(); !st) {
    spdlog::error("raw log: {} (recording stops; mapping goes on)", st.error().message);
    fault_ = st.error().message;
  }
}

RawRecorder::Health RawRecorder::health() const {
  const std::lock_guard lock(mutex_);
  return {fault_, recording_, log_->droppedSegments(), log_->droppedBytes()};
}

}  // namespace vog::app
