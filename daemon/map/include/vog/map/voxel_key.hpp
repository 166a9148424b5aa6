#pragma once
// Integer voxel coordinates. Global voxel k spans [k * res, (k + 1) * res) on each axis, its centre at
// (k + 0.5) * res: the same grid as OctoMap's keys (octomap key = k + 32768). The conversion below
// is the exact arithmetic of OcTreeBaseImpl::coordToKey (floor of coordinate times 1/res), so a point
// classified here and in an OcTree lands in the same voxel, bit for bit.

#include <Eigen/Core>

#include <cmath>
#include <cstdint>

namespace vog::map {

using VoxelKey = Eigen::Vector3i;

// floor(inv_resolution * coordinate) for finite values within int range. Written as truncate-and-fix
// because std::floor compiles to a slow bit-twiddling sequence on baseline x86-64; the integer result
// is identical to floor's for every such input.
inline int coordToIndex(double coordinate, double inv_resolution) {
  const double x = inv_resolution * coordinate;
  const int truncated = static_cast<int>(x);
  return truncated - (x < static_cast<double>(truncated) ? 1 : 0);
}

inline VoxelKey pointToKey(const Eigen::Vector3d& p, double inv_resolution) {
  return {coordToIndex(p.x(), inv_resolution), coordToIndex(p.y(), inv_resolution),
          coordToIndex(p.z(), inv_resolution)};
}

inline Eigen::Vector3d keyToCentre(const VoxelKey& k, double resolution) {
  return {(k.x() + 0.5) * resolution, (k.y() + 0.5) * resolution, (k.z() + 0.5) * resolution};
}

// Inclusive integer box of voxel keys; empty when any min > max.
struct KeyBox {
  VoxelKey min = VoxelKey::Constant(1);
  VoxelKey max = VoxelKey::Constant(0);

  bool empty() const { return (min.array() > max.array()).any(); }
  bool contains(const VoxelKey& k) const { return (k.array() >= min.array()).all() && (k.array() <= max.array()).all(); }
  void extend(const VoxelKey& lo, const VoxelKey& hi) {
    if (empty()) {
      min = lo;
      max = hi;
    } else {
      min = min.cwiseMin(lo);
      max = max.cwiseMax(hi);
    }
  }
};

}  // namespace vog::map
