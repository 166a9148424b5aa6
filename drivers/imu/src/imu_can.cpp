#include "vog/imu/imu_can.hpp"

#include "vog/core/bytes.hpp"
#include "vog/core/crc.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>

// GCC 12 reports a false -Wmaybe-uninitialized when a std::optional<Eigen::Vector3d> member that
// was never engaged is moved (seen with -O2 and sanitizers); the optional's own flag guards it.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace vog::imu {
namespace {

using codec::BadKind;
using ResultCan = codec::DecodeResult<ImuSample>;
constexpr std::size_t kRecordBytes = sizeof(can_frame);
static_assert(kRecordBytes == 16, "struct can_frame is 16 bytes on Linux");
constexpr std::size_t kCrcCoveredBytes = 8 * 3 + 6;

can_frame recordAt(std::span<const std::uint8_t> b, std::size_t i) {
  can_frame f{};
  std::memcpy(&f, b.data() + i * kRecordBytes, kRecordBytes);
  return f;
}

bool isStandardDataFrame(const can_frame& f) { return (f.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) == 0; }

std::uint16_t sampleCrc(const std::array<can_frame, 4>& frames) {
  std::array<std::uint8_t, kCrcCoveredBytes> covered{};
  for (std::size_t k = 0; k < 3; ++k) std::memcpy(covered.data() + 8 * k, frames[k].data, 8);
  std::memcpy(covered.data() + 24, frames[3].data, 6);
  return crc16CcittFalse(covered);
}

std::string hexId(canid_t id) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%03X", static_cast<unsigned>(id));
  return buf;
}

std::int16_t i16At(const can_frame& f, std::size_t at) {
  return static_cast<std::int16_t>(f.data[at] | (f.data[at + 1] << 8));
}

}  // namespace

Status ImuCanConfig::validate() const {
  if (base_id > CAN_SFF_MASK - 3) {
    return Error{"imu.can.base_id: " + hexId(base_id) + " leaves no room for 4 standard 11-bit IDs"};
  }
  return {};
}

codec::DecodeResult<ImuSample> ImuCanCodec::decode(std::span<const std::uint8_t> b) const {
  if (b.size() < kRecordBytes) return ResultCan::needMore();
  const can_frame first = recordAt(b, 0);
  if (!isStandardDataFrame(first) || (first.can_id & CAN_SFF_MASK) != config_.base_id) {
    return ResultCan::bad(BadKind::kNoSync, kRecordBytes,
                          "IMU CAN: frame " + hexId(first.can_id & CAN_EFF_MASK) + " does not start a sample");
  }
  if (first.len != 8) {
    return ResultCan::bad(BadKind::kMalformed, kRecordBytes,
                          "IMU CAN: first frame has " + std::to_string(first.len) + " bytes, need 8");
  }
  std::array<can_frame, 4> frames{first};
  for (std::size_t k = 1; k < 4; ++k) {
    if (b.size() < (k + 1) * kRecordBytes) return ResultCan::needMore();
    frames[k] = recordAt(b, k);
    const can_frame& f = frames[k];
    if (!isStandardDataFrame(f) || (f.can_id & CAN_SFF_MASK) != config_.base_id + k || f.len != 8 ||
        f.data[0] != first.data[0]) {
      // A frame of this sample was lost: drop the first frame and look again from the next one.
      return ResultCan::bad(BadKind::kMalformed, kRecordBytes,
                            "IMU CAN: sample " + std::to_string(first.data[0]) + " incomplete at frame " +
                                std::to_string(k) + " (id " + hexId(f.can_id & CAN_EFF_MASK) + ", seq " +
                                std::to_string(f.data[0]) + ")");
    }
  }
  const std::uint16_t crc = static_cast<std::uint16_t>(frames[3].data[6] | (frames[3].data[7] << 8));
  const std::uint16_t expected = sampleCrc(frames);
  if (crc != expected) {
    return ResultCan::bad(BadKind::kChecksum, 4 * kRecordBytes,
                          "IMU CAN: CRC mismatch in sample " + std::to_string(first.data[0]));
  }
  const std::uint16_t dt_us = static_cast<std::uint16_t>(frames[3].data[1] | (frames[3].data[2] << 8));
  if (dt_us == 0) return ResultCan::bad(BadKind::kMalformed, 4 * kRecordBytes, "IMU CAN: integration interval of 0 us");

  ImuSample s;
  s.sequence = first.data[0];
  s.attitude = ImuAttitude{i16At(frames[0], 1) * can_layout::kAttitudeScale_rad,
                           i16At(frames[0], 3) * can_layout::kAttitudeScale_rad,
                           i16At(frames[0], 5) * can_layout::kAttitudeScale_rad};
  s.angular_rate_radps =
      Eigen::Vector3d(i16At(frames[1], 1), i16At(frames[1], 3), i16At(frames[1], 5)) * can_layout::kRateScale_radps;
  s.delta_velocity_mps = Eigen::Vector3d(i16At(frames[2], 1), i16At(frames[2], 3), i16At(frames[2], 5)) *
                         can_layout::kDeltaVelocityScale_mps;
  s.dt_s = dt_us * can_layout::kDtScale_s;
  s.status = static_cast<std::uint16_t>(frames[3].data[3] | (frames[3].data[4] << 8));
  return ResultCan::decoded(std::move(s), 4 * kRecordBytes);
}

namespace {

// Counts for `value / scale`, or an error naming the field when it does not fit an i16.
Result<std::int16_t> toCount(double value, double scale, const char* field) {
  const double count = std::round(value / scale);
  if (!std::isfinite(count) || count < -32768.0 || count > 32767.0) {
    return Error{std::string("IMU CAN: ") + field + " = " + std::to_string(value) + " outside the wire range +-" +
                 std::to_string(32767 * scale)};
  }
  return static_cast<std::int16_t>(count);
}

void putI16(can_frame& f, std::size_t at, std::int16_t v) {
  f.data[at] = static_cast<std::uint8_t>(static_cast<std::uint16_t>(v) & 0xFFU);
  f.data[at + 1] = static_cast<std::uint8_t>(static_cast<std::uint16_t>(v) >> 8);
}

}  // namespace

Result<std::array<can_frame, can_layout::kFramesPerSample>> encodeImuCan(const ImuSample& s,
                                                                         const ImuCanConfig& config) {
  if (auto st = config.validate(); !st.ok()) return st.error();
  if (!s.attitude) return Error{"IMU CAN: the layout carries attitude; sample has none"};
  if (!s.angular_rate_radps) return Error{"IMU CAN: the layout carries angular rates; sample has none"};
  if (s.status > 0xFFFFU) return Error{"IMU CAN: status " + std::to_string(s.status) + " does not fit 16 bits"};
  const double dt_us = std::round(s.dt_s / can_layout::kDtScale_s);
  if (!(dt_us >= 1.0 && dt_us <= 65535.0))
    return Error{"IMU CAN: dt_s = " + std::to_string(s.dt_s) + " outside (0, 0.065535]"};

  std::array<can_frame, 4> frames{};
  for (std::size_t k = 0; k < 4; ++k) {
    frames[k].can_id = config.base_id + static_cast<canid_t>(k);
    frames[k].len = 8;
    frames[k].data[0] = static_cast<std::uint8_t>(s.sequence & 0xFFU);
  }
  // Yaw wrapped to [-pi, pi) so any heading fits the i16 range.
  const double yaw = std::remainder(s.attitude->yaw_rad, 2.0 * std::numbers::pi);
  const std::array<std::pair<double, const char*>, 3> att = {std::pair{s.attitude->roll_rad, "roll_rad"},
                                                             std::pair{s.attitude->pitch_rad, "pitch_rad"},
                                                             std::pair{yaw, "yaw_rad"}};
  for (std::size_t i = 0; i < 3; ++i) {
    auto c = toCount(att[i].first, can_layout::kAttitudeScale_rad, att[i].second);
    if (!c.ok()) return c.error();
    putI16(frames[0], 1 + 2 * i, *c);
    auto r = toCount((*s.angular_rate_radps)[static_cast<Eigen::Index>(i)], can_layout::kRateScale_radps,
                     "angular_rate_radps");
    if (!r.ok()) return r.error();
    putI16(frames[1], 1 + 2 * i, *r);
    auto v = toCount(s.delta_velocity_mps[static_cast<Eigen::Index>(i)], can_layout::kDeltaVelocityScale_mps,
                     "delta_velocity_mps");
    if (!v.ok()) return v.error();
    putI16(frames[2], 1 + 2 * i, *v);
  }
  const auto dt = static_cast<std::uint16_t>(dt_us);
  frames[3].data[1] = static_cast<std::uint8_t>(dt & 0xFFU);
  frames[3].data[2] = static_cast<std::uint8_t>(dt >> 8);
  frames[3].data[3] = static_cast<std::uint8_t>(s.status & 0xFFU);
  frames[3].data[4] = static_cast<std::uint8_t>((s.status >> 8) & 0xFFU);
  const std::uint16_t crc = sampleCrc(frames);
  frames[3].data[6] = static_cast<std::uint8_t>(crc & 0xFFU);
  frames[3].data[7] = static_cast<std::uint8_t>(crc >> 8);
  return frames;
}

std::vector<std::uint8_t> canFramesToBytes(std::span<const can_frame> frames) {
  std::vector<std::uint8_t> out(frames.size() * kRecordBytes);
  if (!frames.empty()) std::memcpy(out.data(), frames.data(), out.size());
  return out;
}

}  // namespace vog::imu
