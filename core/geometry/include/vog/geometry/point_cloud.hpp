#pragma once
// A point cloud with optional per-point unit normals, in the frame its owner names
// (a LocalGrid's cloud is in the submap frame). normals is empty or the same size as points.

#include <Eigen/Core>

#include <vector>

namespace vog::geometry {

struct PointCloud {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool hasNormals() const { return !normals.empty() && normals.size() == points.size(); }
};

}  // namespace vog::geometry
