#pragma once
// The simulator's scans as raw-log records (daemon/mission raw_log.hpp): with `source: sim` the
// "device" is the simulator, and what the mapping side received from it is exactly one ScanInput per
// ping, so that is what the raw log keeps and what `vogd --replay` feeds back.
// Payload, little-endian: [i64 stamp_ns][f64 R x 9, row-major][f64 t x 3] (T_world_vehicle_odom)
// [f64 z roll pitch][u32 n][f32 range_m x n] (+inf = no return).

#include "vog/core/result.hpp"
#include "vog/slam/submap_builder.hpp"

#include <cstdint>
#include <span>
#include <vector>

namespace vog::app {

inline constexpr std::uint16_t kSimScanDeviceId = 0x0100;
// The true vehicle pose of the scan with the same stamp (evaluation only): [i64 stamp_ns][f64 R x 9][f64 t x 3].
inline constexpr std::uint16_t kSimTruthDeviceId = 0x0101;
// The mapping gate: scans after this record are mapped ([u8 1]) or not ([u8 0]). vogd maps only
// while a mission is exploring, returning or paused; the record is written by the thread that
// writes the inputs, at the point where its decision changes, so a replay applies the same gate to
// the same inputs. A log without one maps everything.
inline constexpr std::uint16_t kMappingGateDeviceId = 0x0102;

std::vector<std::uint8_t> encodeScanRecord(const slam::ScanInput& scan);
// Errors name the problem (short, trailing bytes, beam count, non-finite pose).
Result<slam::ScanInput> decodeScanRecord(std::span<const std::uint8_t> bytes);

struct TruthRecord {
  std::int64_t stamp_ns = 0;
  geometry::Pose3 T_world_vehicle = geometry::Pose3::Identity();
};
std::vector<std::uint8_t> encodeTruthRecord(const TruthRecord& truth);
Result<TruthRecord> decodeTruthRecord(std::span<const std::uint8_t> bytes);

}  // namespace vog::app
