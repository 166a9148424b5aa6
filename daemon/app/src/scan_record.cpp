#include "vog/app/scan_record.hpp"

#include "vog/core/bytes.hpp"

#include <cmath>
#include <string>

namespace vog::app {
namespace {

constexpr std::size_t kPoseValues = 15;  // rotation (9, row-major), translation (3), z roll pitch (3)
constexpr std::size_t kHeaderBytes = 8 + kPoseValues * 8 + 4;
constexpr std::uint32_t kMaxBeams = 4096;

void putF64(std::vector<std::uint8_t>& out, double v) {
  const std::size_t at = out.size();
  out.resize(at + 8);
  writeU64LE(out, at, std::bit_cast<std::uint64_t>(v));
}

// The rotation matrix itself, not a quaternion: a replay must see bit-identical input.
void putPose(std::vector<std::uint8_t>& out, const geometry::Pose3& T) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) putF64(out, T.linear()(r, c));
  for (int i = 0; i < 3; ++i) putF64(out, T.translation()[i]);
}

// Reads 12 values at `at` into a rigid pose.
Result<geometry::Pose3> getPose(std::span<const std::uint8_t> bytes, std::size_t at, const char* what) {
  geometry::Pose3 T = geometry::Pose3::Identity();
  for (std::size_t i = 0; i < 12; ++i) {
    const double v = readF64LE(bytes, at + 8 * i);
    if (!std::isfinite(v)) return Error{std::string(what) + ": pose value " + std::to_string(i) + " is not finite"};
    if (i < 9)
      T.linear()(static_cast<int>(i / 3), static_cast<int>(i % 3)) = v;
    else
      T.translation()[static_cast<int>(i - 9)] = v;
  }
  if (!geometry::isValidPose(T)) return Error{std::string(what) + ": the pose is not a rigid transform"};
  return T;
}

}  // namespace

std::vector<std::uint8_t> encodeScanRecord(const slam::ScanInput& scan) {
  std::vector<std::uint8_t> out;
  out.reserve(kHeaderBytes + 4 * scan.scan.range_m.size());
  out.resize(8);
  writeU64LE(out, 0, static_cast<std::uint64_t>(scan.scan.stamp_ns));
  putPose(out, scan.T_world_vehicle_odom);
  for (int i = 0; i < 3; ++i) putF64(out, scan.z_roll_pitch[i]);
  const std::size_t at = out.size();
  out.resize(at + 4 + 4 * scan.scan.range_m.size());
  writeU32LE(out, at, static_cast<std::uint32_t>(scan.scan.range_m.size()));
  for (std::size_t i = 0; i < scan.scan.range_m.size(); ++i) writeF32LE(out, at + 4 + 4 * i, scan.scan.range_m[i]);
  return out;
}

Result<slam::ScanInput> decodeScanRecord(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kHeaderBytes)
    return Error{"scan record: " + std::to_string(bytes.size()) + " bytes, shorter than its " +
                 std::to_string(kHeaderBytes) + "-byte header"};
  slam::ScanInput in;
  in.scan.stamp_ns = readI64LE(bytes, 0);
  auto T = getPose(bytes, 8, "scan record");
  if (!T) return T.error();
  in.T_world_vehicle_odom = *T;
  for (std::size_t i = 0; i < 3; ++i) {
    in.z_roll_pitch[static_cast<int>(i)] = readF64LE(bytes, 8 + 8 * (12 + i));
    if (!std::isfinite(in.z_roll_pitch[static_cast<int>(i)])) return Error{"scan record: z/roll/pitch is not finite"};
  }
  const std::uint32_t n = readU32LE(bytes, kHeaderBytes - 4);
  if (n > kMaxBeams) return Error{"scan record: " + std::to_string(n) + " beams, at most " + std::to_string(kMaxBeams)};
  if (bytes.size() != kHeaderBytes + 4 * static_cast<std::size_t>(n))
    return Error{"scan record: " + std::to_string(bytes.size()) + " bytes for " + std::to_string(n) + " beams (want " +
                 std::to_string(kHeaderBytes + 4 * static_cast<std::size_t>(n)) + ")"};
  in.scan.range_m.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) in.scan.range_m[i] = readF32LE(bytes, kHeaderBytes + 4 * i);
  return in;
}

std::vector<std::uint8_t> encodeTruthRecord(const TruthRecord& truth) {
  std::vector<std::uint8_t> out(8);
  writeU64LE(out, 0, static_cast<std::uint64_t>(truth.stamp_ns));
  putPose(out, truth.T_world_vehicle);
  return out;
}

Result<TruthRecord> decodeTruthRecord(std::span<const std::uint8_t> bytes) {
  if (bytes.size() != 8 + 12 * 8)
    return Error{"truth record: " + std::to_string(bytes.size()) + " bytes, want " + std::to_string(8 + 12 * 8)};
  TruthRecord t;
  t.stamp_ns = readI64LE(bytes, 0);
  auto T = getPose(bytes, 8, "truth record");
  if (!T) return T.error();
  t.T_world_vehicle = *T;
  return t;
}

}  // namespace vog::app
