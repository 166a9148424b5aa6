#pragma once
// Integer voxel coordinates. Global voxel k spans [k * res, (k + 1) * res) on each axis, its centre at
// (k + 0.5) * res: the same grid as OctoMap's keys (octomap key = k + 32768). The conversion below
// is the exact arithmetic of OcTreeBaseImpl::coordToKey (floor of coordinate times 1/res), so a point
// classified here and in an OcTree lands in the same voxel, bit for bit.

#include <Eigen/Core>

#include <cmath>
#include <limits>

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

// The start of an Amanatides & Woo (1987) walk through the voxels a segment crosses, from the voxel
// of `origin` to the voxel of `end`: per axis the step (+1, -1 or 0), the segment parameter (0..1) at
// the next voxel boundary, and the parameter per voxel. MergedMap::traverse and the planner's edge
// check and gain all start here, so they visit the same voxels.
struct VoxelWalk {
  VoxelKey key;   // the current voxel
  VoxelKey last;  // the voxel of the end point
  Eigen::Vector3i step;
  Eigen::Vector3d t_max;
  Eigen::Vector3d t_delta;

  // The axis whose boundary comes next (ties: the lowest axis).
  int nextAxis() const {
    int axis = 0;
    if (t_max[1] < t_max[axis]) axis = 1;
    if (t_max[2] < t_max[axis]) axis = 2;
    return axis;
  }
};

inline VoxelWalk startVoxelWalk(const Eigen::Vector3d& origin, const Eigen::Vector3d& end, double resolution,
                                double inv_resolution) {
  VoxelWalk w;
  w.key = pointToKey(origin, inv_resolution);
  w.last = pointToKey(end, inv_resolution);
  const Eigen::Vector3d d = end - origin;
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0) {
      w.step[i] = 0;
      w.t_max[i] = std::numeric_limits<double>::infinity();
      w.t_delta[i] = std::numeric_limits<double>::infinity();
      continue;
    }
    w.step[i] = d[i] > 0.0 ? 1 : -1;
    const double boundary = (w.key[i] + (w.step[i] > 0 ? 1 : 0)) * resolution;
    w.t_max[i] = (boundary - origin[i]) / d[i];  // in units of the segment (0..1)
    w.t_delta[i] = resolution / std::abs(d[i]);
  }
  return w;
}

// Inclusive integer box of voxel keys; empty when any min > max.
struct KeyBox {
  VoxelKey min = VoxelKey::Constant(1);
  VoxelKey max = VoxelKey::Constant(0);

  bool empty() const { return (min.array() > max.array()).any(); }
  bool contains(const VoxelKey& k) const {
    return (k.array() >= min.array()).all() && (k.array() <= max.array()).all();
  }
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
