#pragma once
// Shared helpers of the mission tests: sample journal records with awkward values (negative zero,
// subnormals, full-precision doubles), bitwise record equality and raw file access.
#include "vog/mission/journal.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <vector>

namespace vog::mission::testing {

inline std::vector<std::uint8_t> readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void writeBytes(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

inline geometry::Pose3 randomPose(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  return geometry::poseFromXyzRpy(u(rng) * 10.0, u(rng) * 10.0, u(rng), u(rng) * 0.1, u(rng) * 0.1, u(rng));
}

inline SubmapClosedRecord sampleSubmap(std::int64_t index, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  SubmapClosedRecord r;
  r.index = index;
  r.first_stamp_ns = 1'700'000'000'000'000'000 + index * 8'000'000'000;
  r.last_stamp_ns = r.first_stamp_ns + 7'800'000'000;
  r.n_scans = 40;
  r.reason = slam::CloseReason::kHeadingChange;
  r.T_world_base_odom = randomPose(rng);
  r.base_z_roll_pitch = Eigen::Vector3d(-2.0 + u(rng), -0.0, std::numeric_limits<double>::denorm_min());
  r.has_previous = index > 0;
  r.odometry_from_previous = Eigen::Vector3d(u(rng), u(rng), u(rng));
  r.odometry_covariance = Eigen::Vector3d(0.011, 0.011, 8e-7).asDiagonal();
  r.odometry_covariance(0, 1) = 1e-300;
  r.ot_file = "00000" + std::to_string(index % 10) + ".ot";
  r.ot_size_bytes = 123456 + static_cast<std::uint64_t>(index);
  r.ot_crc32c = 0xDEADBEEFU ^ static_cast<std::uint32_t>(index);
  for (std::int64_t i = 0; i < 3 * (index % 3); ++i) r.sensor_origins.emplace_back(u(rng), u(rng) * 5.0, -0.0);
  return r;
}

inline LoopClosureRecord sampleClosure(std::int64_t from, std::int64_t to, int rank, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  LoopClosureRecord r;
  r.from = from;
  r.to = to;
  r.T_from_to = randomPose(rng);
  r.T_from_to_prior = randomPose(rng);
  for (int i = 0; i < 6; ++i) r.factor.x_icp(i) = u(rng);
  r.factor.V_u = Eigen::MatrixXd::Zero(rank, 6);
  for (int i = 0; i < rank; ++i) r.factor.V_u(i, i) = 1.0;
  r.factor.V_u(0, 5) = 1e-17;
  r.factor.measurement = Eigen::VectorXd::NullaryExpr(rank, [&] { return u(rng); });
  r.factor.covariance = Eigen::MatrixXd::Identity(rank, rank) * 0.003;
  if (rank > 1) r.factor.covariance(0, 1) = r.factor.covariance(1, 0) = 1e-4;
  return r;
}

inline OptimizedPosesRecord sampleEstimates(int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  OptimizedPosesRecord r;
  for (int i = 0; i < n; ++i) {
    slam::Vector6d x;
    for (int k = 0; k < 6; ++k) x(k) = u(rng);
    r.estimates.emplace_back(i, x);
  }
  return r;
}

// Every record type once (two closures of different rank).
inline std::vector<JournalRecord> sampleRecords(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<JournalRecord> out;
  out.push_back(MissionStateRecord{1'000, MissionState::kExploring});
  out.push_back(sampleSubmap(0, rng));
  out.push_back(sampleEstimates(1, rng));
  out.push_back(WaypointRecord{2'000, 1.5, -2.25, -3.0, -0.0});
  out.push_back(sampleSubmap(1, rng));
  out.push_back(sampleClosure(0, 1, 3, rng));
  out.push_back(sampleClosure(0, 1, 6, rng));
  out.push_back(sampleEstimates(2, rng));
  out.push_back(MissionStateRecord{3'000, MissionState::kAborted});
  return out;
}

template <class M>
bool bitEqual(const M& a, const M& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
  for (Eigen::Index c = 0; c < a.cols(); ++c) {
    for (Eigen::Index r = 0; r < a.rows(); ++r) {
      if (std::bit_cast<std::uint64_t>(a(r, c)) != std::bit_cast<std::uint64_t>(b(r, c))) return false;
    }
  }
  return true;
}

inline bool same(const SubmapClosedRecord& a, const SubmapClosedRecord& b) {
  return a.index == b.index && a.first_stamp_ns == b.first_stamp_ns && a.last_stamp_ns == b.last_stamp_ns &&
         a.n_scans == b.n_scans && a.reason == b.reason &&
         bitEqual(a.T_world_base_odom.matrix(), b.T_world_base_odom.matrix()) &&
         bitEqual(a.base_z_roll_pitch, b.base_z_roll_pitch) && a.has_previous == b.has_previous &&
         bitEqual(a.odometry_from_previous, b.odometry_from_previous) &&
         bitEqual(a.odometry_covariance, b.odometry_covariance) && a.ot_file == b.ot_file &&
         a.ot_size_bytes == b.ot_size_bytes && a.ot_crc32c == b.ot_crc32c &&
         a.sensor_origins.size() == b.sensor_origins.size() &&
         std::equal(a.sensor_origins.begin(), a.sensor_origins.end(), b.sensor_origins.begin(),
                    [](const Eigen::Vector3d& x, const Eigen::Vector3d& y) { return bitEqual(x, y); });
}
inline bool same(const LoopClosureRecord& a, const LoopClosureRecord& b) {
  return a.from == b.from && a.to == b.to && bitEqual(a.T_from_to.matrix(), b.T_from_to.matrix()) &&
         bitEqual(a.T_from_to_prior.matrix(), b.T_from_to_prior.matrix()) && bitEqual(a.factor.V_u, b.factor.V_u) &&
         bitEqual(a.factor.x_icp, b.factor.x_icp) && bitEqual(a.factor.measurement, b.factor.measurement) &&
         bitEqual(a.factor.covariance, b.factor.covariance);
}
inline bool same(const OptimizedPosesRecord& a, const OptimizedPosesRecord& b) {
  if (a.estimates.size() != b.estimates.size()) return false;
  for (std::size_t i = 0; i < a.estimates.size(); ++i) {
    if (a.estimates[i].first != b.estimates[i].first || !bitEqual(a.estimates[i].second, b.estimates[i].second)) {
      return false;
    }
  }
  return true;
}
inline bool same(const WaypointRecord& a, const WaypointRecord& b) {
  return a.stamp_ns == b.stamp_ns &&
         bitEqual(Eigen::Vector4d(a.x_m, a.y_m, a.z_m, a.yaw_rad), Eigen::Vector4d(b.x_m, b.y_m, b.z_m, b.yaw_rad));
}
inline bool same(const MissionStateRecord& a, const MissionStateRecord& b) {
  return a.stamp_ns == b.stamp_ns && a.state == b.state;
}
inline bool same(const JournalRecord& a, const JournalRecord& b) {
  if (a.index() != b.index()) return false;
  return std::visit(
      [&b](const auto& x) {
        using T = std::decay_t<decltype(x)>;
        return same(x, std::get<T>(b));
      },
      a);
}

}  // namespace vog::mission::testing
