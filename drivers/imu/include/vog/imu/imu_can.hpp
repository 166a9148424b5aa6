#pragma once
// IMU samples over classic CAN: four 8-byte frames per sample, layout in drivers/imu/README.md.
// The decoder reads a stream of `struct can_frame` records (16 bytes each, host byte order, as
// read() returns them from a CAN_RAW socket or the SOCK_SEQPACKET stand-in).

#include "vog/codec/decode_result.hpp"
#include "vog/core/result.hpp"
#include "vog/imu/imu_types.hpp"

#include <linux/can.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace vog::imu {

namespace can_layout {
constexpr canid_t kDefaultBaseId = 0x180;  // frames use base_id + 0..3 (11-bit standard IDs)
constexpr int kFramesPerSample = 4;
constexpr double kAttitudeScale_rad = 1e-4;       // i16 count
constexpr double kRateScale_radps = 1e-4;         // i16 count, +-3.27 rad/s
constexpr double kDeltaVelocityScale_mps = 1e-5;  // i16 count, +-0.327 m/s per interval
constexpr double kDtScale_s = 1e-6;               // u16 microseconds
}  // namespace can_layout

struct ImuCanConfig {
  canid_t base_id = can_layout::kDefaultBaseId;
  Status validate() const;
};

class ImuCanCodec {
 public:
  using Frame = ImuSample;
  explicit ImuCanCodec(ImuCanConfig config = {}) : config_(config) {}
  // `bytes` hold whole can_frame records (a multiple of 16 bytes is not required: a trailing
  // partial record is "need more").
  codec::DecodeResult<ImuSample> decode(std::span<const std::uint8_t> bytes) const;
  const ImuCanConfig& config() const { return config_; }

 private:
  ImuCanConfig config_;
};

// The four frames of one sample. Values outside the wire range are an error naming the field.
Result<std::array<can_frame, can_layout::kFramesPerSample>> encodeImuCan(const ImuSample& sample,
                                                                         const ImuCanConfig& config = {});
// The records as bytes (what a recording file or the seqpacket stand-in carries).
std::vector<std::uint8_t> canFramesToBytes(std::span<const can_frame> frames);

}  // namespace vog::imu
