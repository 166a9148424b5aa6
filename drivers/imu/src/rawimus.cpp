#include "vog/imu/rawimus.hpp"

#include "vog/core/bytes.hpp"
#include "vog/core/crc.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

// GCC 12 reports a false -Wmaybe-uninitialized when a std::optional<Eigen::Vector3d> member that
// was never engaged is moved (seen with -O2 and sanitizers); the optional's own flag guards it.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace vog::imu {
namespace {

using codec::BadKind;
using ResultRaw = codec::DecodeResult<ImuSample>;

constexpr std::uint8_t kSync[3] = {0xAA, 0x44, 0x13};  // short binary header sync
constexpr std::int64_t kGpsEpochUnix_s = 315964800;    // 1980-01-06T00:00:00Z
constexpr std::int64_t kSecondsPerWeek = 604800;

std::size_t skipToSync(std::span<const std::uint8_t> b) {
  for (std::size_t i = 1; i < b.size(); ++i) {
    std::size_t k = 0;
    while (k < 3 && i + k < b.size() && b[i + k] == kSync[k]) ++k;
    if (k == 3 || i + k == b.size()) return i;  // full sync, or a sync prefix at the end
  }
  return b.size();
}

std::int32_t toCount(double value, double scale) {
  const double c = std::round(value / scale);
  if (!std::isfinite(c)) return 0;
  return static_cast<std::int32_t>(std::clamp(c, static_cast<double>(std::numeric_limits<std::int32_t>::min()),
                                              static_cast<double>(std::numeric_limits<std::int32_t>::max())));
}

}  // namespace

codec::DecodeResult<ImuSample> RawImusCodec::decode(std::span<const std::uint8_t> b) const {
  if (b.empty()) return ResultRaw::needMore();
  for (std::size_t k = 0; k < 3 && k < b.size(); ++k) {
    if (b[k] != kSync[k]) return ResultRaw::bad(BadKind::kNoSync, skipToSync(b), "RAWIMUS: no AA 44 13 sync");
  }
  if (b.size() < rawimus::kHeaderBytes) return ResultRaw::needMore();
  const std::size_t body_bytes = b[3];
  const std::uint16_t id = readU16LE(b, 4);
  if (id != rawimus::kMessageId || body_bytes != rawimus::kBodyBytes) {
    return ResultRaw::bad(BadKind::kMalformed, 3,
                          "RAWIMUS: message id " + std::to_string(id) + " with " + std::to_string(body_bytes) +
                              "-byte body, expected id 325 with 40 bytes");
  }
  if (b.size() < rawimus::kRecordBytes) return ResultRaw::needMore();
  const auto record = b.first(rawimus::kHeaderBytes + rawimus::kBodyBytes);
  if (crc32Novatel(record) != readU32LE(b, rawimus::kHeaderBytes + rawimus::kBodyBytes)) {
    return ResultRaw::bad(BadKind::kChecksum, 3, "RAWIMUS: CRC mismatch");
  }
  const std::size_t body = rawimus::kHeaderBytes;
  const std::uint32_t week = readU32LE(b, body);
  const double seconds = readF64LE(b, body + 4);
  if (!std::isfinite(seconds) || seconds < 0.0 || seconds >= static_cast<double>(kSecondsPerWeek) || week > 10000) {
    return ResultRaw::bad(
        BadKind::kMalformed, rawimus::kRecordBytes,
        "RAWIMUS: GPS time week " + std::to_string(week) + " seconds " + std::to_string(seconds) + " out of range");
  }
  ImuSample s;
  const double t_s = static_cast<double>(kGpsEpochUnix_s + static_cast<std::int64_t>(week) * kSecondsPerWeek);
  s.stamp_ns = static_cast<std::int64_t>(std::llround((t_s + seconds) * 1e9));
  s.status = readU32LE(b, body + 12);
  // Body order (OEM7 manual, RAWIMUS): Z accel, -(Y accel), X accel, Z gyro, -(Y gyro), X gyro.
  const double a = config_.accel_scale_mps_per_count;
  const double g = config_.gyro_scale_rad_per_count;
  s.delta_velocity_mps = Eigen::Vector3d(readI32LE(b, body + 24) * a, -static_cast<double>(readI32LE(b, body + 20)) * a,
                                         readI32LE(b, body + 16) * a);
  s.delta_angle_rad = Eigen::Vector3d(readI32LE(b, body + 36) * g, -static_cast<double>(readI32LE(b, body + 32)) * g,
                                      readI32LE(b, body + 28) * g);
  s.dt_s = 1.0 / config_.rate_hz;
  s.sequence = 0;
  return ResultRaw::decoded(std::move(s), rawimus::kRecordBytes);
}

std::vector<std::uint8_t> encodeRawImus(const ImuSample& s, const RawImusConfig& config) {
  const std::int64_t gps_ns = s.stamp_ns - kGpsEpochUnix_s * 1'000'000'000LL;
  const std::int64_t week_ns = kSecondsPerWeek * 1'000'000'000LL;
  const std::int64_t week = gps_ns >= 0 ? gps_ns / week_ns : 0;
  const std::int64_t in_week_ns = gps_ns >= 0 ? gps_ns % week_ns : 0;
  std::vector<std::uint8_t> out;
  ByteWriter w(out);
  w.u8(kSync[0]);
  w.u8(kSync[1]);
  w.u8(kSync[2]);
  w.u8(static_cast<std::uint8_t>(rawimus::kBodyBytes));
  w.u16(rawimus::kMessageId);
  w.u16(static_cast<std::uint16_t>(week));
  w.u32(static_cast<std::uint32_t>(in_week_ns / 1'000'000));
  w.u32(static_cast<std::uint32_t>(week));
  w.f64(static_cast<double>(in_week_ns) * 1e-9);
  w.u32(s.status);
  const double a = config.accel_scale_mps_per_count;
  const double g = config.gyro_scale_rad_per_count;
  const Eigen::Vector3d dv = s.delta_velocity_mps;
  const Eigen::Vector3d da = s.delta_angle_rad.value_or(Eigen::Vector3d::Zero());
  w.i32(toCount(dv.z(), a));
  w.i32(toCount(-dv.y(), a));
  w.i32(toCount(dv.x(), a));
  w.i32(toCount(da.z(), g));
  w.i32(toCount(-da.y(), g));
  w.i32(toCount(da.x(), g));
  w.u32(crc32Novatel(out));
  return out;
}

}  // namespace vog::imu
