#pragma once
// Eigen matrices and poses as fields of record payloads (layouts in daemon/mission/README.md), on top of
// the core byte fields. Doubles are stored as their IEEE-754 bit pattern, so every value round-trips
// bit for bit.
#include "vog/core/bytes.hpp"
#include "vog/geometry/pose.hpp"

#include <Eigen/Core>

namespace vog::mission::detail {

// Column-major, as Eigen stores it.
template <class Derived>
void writeMatrix(ByteWriter& w, const Eigen::MatrixBase<Derived>& m) {
  for (Eigen::Index c = 0; c < m.cols(); ++c) {
    for (Eigen::Index r = 0; r < m.rows(); ++r) w.f64(m(r, c));
  }
}

// Rotation (column-major 3x3) then translation: 12 doubles.
inline void writePose(ByteWriter& w, const geometry::Pose3& T) {
  writeMatrix(w, T.linear());
  writeMatrix(w, T.translation());
}

template <class M>
void readMatrix(ByteReader& in, M& m, const char* field) {
  for (Eigen::Index c = 0; c < m.cols(); ++c) {
    for (Eigen::Index r = 0; r < m.rows(); ++r) m(r, c) = in.f64(field);
  }
}

inline geometry::Pose3 readPose(ByteReader& in, const char* field) {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  readMatrix(in, R, field);
  readMatrix(in, t, field);
  geometry::Pose3 T = geometry::Pose3::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

}  // namespace vog::mission::detail
