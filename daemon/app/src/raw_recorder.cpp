#include "vog/app/raw_recorder.hpp"

#include "vog/app/scan_record.hpp"

#include <spdlog/spdlog.h>

namespace vog::app {

void RawRecorder::record(std::uint16_t device_id, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) {
  const std::lock_guard lock(mutex_);
  if (failed_) return;
  if (Status st = log_->append(device_id, stamp_ns, bytes); !st) {
    spdlog::error("raw log: {} (recording stops; mapping goes on)", st.error().message);
    failed_ = true;
  }
}

bool RawRecorder::gate(bool enabled, std::int64_t stamp_ns) {
  if (logged_gate_ != enabled) {
    const std::uint8_t byte = enabled ? 1 : 0;
    record(kMappingGateDeviceId, stamp_ns, std::span<const std::uint8_t>(&byte, 1));
    logged_gate_ = enabled;
  }
  return enabled;
}

Status RawRecorder::sync() {
  const std::lock_guard lock(mutex_);
  return log_->sync();
}

}  // namespace vog::app
