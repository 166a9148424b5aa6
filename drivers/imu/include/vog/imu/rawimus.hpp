#pragma once
// NovAtel RAWIMUS (message ID 325) with a short binary header (OEM7 Commands and Logs manual,
// "RAWIMUS" and "Binary message short header"): sync AA 44 13, u8 body length, u16 message ID,
// u16 GPS week, u32 GPS milliseconds; body: u32 week, f64 seconds of week, u32 IMU status,
// i32 Z accel, -(Y accel), X accel, Z gyro, -(Y gyro), X gyro (delta counts); then a 32-bit CRC.
// Scale factors of the Honeywell HG1700 (AG58): gyro 2^-33 rad/count, accel 2^-27 ft/s per count.

#include "vog/codec/decode_result.hpp"
#include "vog/imu/imu_types.hpp"

#include <cstdint>
#include <span>
#include <vector>

namespace vog::imu {

namespace rawimus {
constexpr std::uint16_t kMessageId = 325;
constexpr std::size_t kHeaderBytes = 12;
constexpr std::size_t kBodyBytes = 40;
constexpr std::size_t kRecordBytes = kHeaderBytes + kBodyBytes + 4;
}  // namespace rawimus

struct RawImusConfig {
  double gyro_scale_rad_per_count = 1.0 / 8589934592.0;     // 2^-33
  double accel_scale_mps_per_count = 0.3048 / 134217728.0;  // 2^-27 ft/s
  double rate_hz = 100.0;                                   // HG1700 data rate
};

class RawImusCodec {
 public:
  using Frame = ImuSample;
  explicit RawImusCodec(RawImusConfig config = {}) : config_(config) {}
  codec::DecodeResult<ImuSample> decode(std::span<const std::uint8_t> bytes) const;

 private:
  RawImusConfig config_;
};

// stamp_ns is encoded as GPS week + seconds of week (GPS epoch 1980-01-06, no leap seconds applied).
std::vector<std::uint8_t> encodeRawImus(const ImuSample& sample, const RawImusConfig& config = {});

}  // namespace vog::imu
