#include "vog/app/scan_record.hpp"

#include "vog/codec/bytes.hpp"

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
  codec::writeU64LE(out, at, std::bit_cast<std::uint64_t>(v));
}

}  // namespace

std::vector<std::uint8_t> encodeScanRecord(const slam::ScanInput& scan) {
  std::vector<std::uint8_t> out;
  out.reserve(kHeaderBytes + 4 * scan.scan.range_m.size());
  out.resize(8);
  codec::writeU64LE(out, 0, static_cast<std::uint64_t>(scan.scan.stamp_ns));
  // The rotation matrix itself, not a quaternion: a replay must see bit-identical input.
  const Eigen::Matrix3d R = scan.T_world_vehicle_odom.linear();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) putF64(out, R(r, c));
  for (int i = 0; i < 3; ++i) putF64(out, scan.T_world_vehicle_odom.translation()[i]);
  for (int i = 0; i < 3; ++i) putF64(out, scan.z_roll_pitch[i]);
  const std::size_t at = out.size();
  out.resize(at + 4 + 4 * scan.scan.range_m.size());
  codec::writeU32LE(out, at, static_cast<std::uint32_t>(scan.scan.range_m.size()));
  for (std::size_t i = 0; i < scan.scan.range_m.size(); ++i) codec::writeF32LE(out, at + 4 + 4 * i, scan.scan.range_m[i]);
  return out;
}

Result<slam::ScanInput> decodeScanRecord(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kHeaderBytes)
    return Error{"scan record: " + std::to_string(bytes.size()) + " bytes, shorter than its " +
                 std::to_string(kHeaderBytes) + "-byte header"};
  slam::ScanInput in;
  in.scan.stamp_ns = codec::readI64LE(bytes, 0);
  double v[kPoseValues];
  for (std::size_t i = 0; i < kPoseValues; ++i) {
    v[i] = codec::readF64LE(bytes, 8 + 8 * i);
    if (!std::isfinite(v[i])) return Error{"scan record: pose value " + std::to_string(i) + " is not finite"};
  }
  in.T_world_vehicle_odom = geometry::Pose3::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) in.T_world_vehicle_odom.linear()(r, c) = v[3 * r + c];
  in.T_world_vehicle_odom.translation() = Eigen::Vector3d(v[9], v[10], v[11]);
  if (!geometry::isValidPose(in.T_world_vehicle_odom)) return Error{"scan record: the pose is not a rigid transform"};
  in.z_roll_pitch = Eigen::Vector3d(v[12], v[13], v[14]);
  const std::uint32_t n = codec::readU32LE(bytes, kHeaderBytes - 4);
  if (n > kMaxBeams) return Error{"scan record: " + std::to_string(n) + " beams, at most " + std::to_string(kMaxBeams)};
  if (bytes.size() != kHeaderBytes + 4 * static_cast<std::size_t>(n))
    return Error{"scan record: " + std::to_string(bytes.size()) + " bytes for " + std::to_string(n) + " beams (want " +
                 std::to_string(kHeaderBytes + 4 * static_cast<std::size_t>(n)) + ")"};
  in.scan.range_m.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) in.scan.range_m[i] = codec::readF32LE(bytes, kHeaderBytes + 4 * i);
  return in;
}

}  // namespace vog::app
