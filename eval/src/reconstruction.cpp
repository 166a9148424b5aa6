#include "vog/eval/reconstruction.hpp"

#include "vog/geometry/sonar.hpp"
#include "vog/map/voxel_key.hpp"
#include "vog/slam/icp.hpp"

#include <cmath>
#include <numbers>

namespace vog::eval {

void appendOccupiedCentres(const map::LocalGrid& grid, const geometry::Pose3& T_world_grid,
                           std::vector<Eigen::Vector3d>& out_world) {
  const float occupied = static_cast<float>(grid.config().bounds().occupied);
  const double res = grid.resolution();
  grid.forEachLeaf([&](const map::LocalGrid::Leaf& leaf) {
    if (!(leaf.log_odds > occupied)) return;
    for (int z = leaf.min.z(); z <= leaf.max.z(); ++z)
      for (int y = leaf.min.y(); y <= leaf.max.y(); ++y)
        for (int x = leaf.min.x(); x <= leaf.max.x(); ++x)
          out_world.push_back(T_world_grid * map::keyToCentre(map::VoxelKey(x, y, z), res));
  });
}

void appendOccupiedCentres(const map::MergedMap& map, std::vector<Eigen::Vector3d>& out_world) {
  const double res = map.resolution();
  map.forEachKnown([&](const map::VoxelKey& key, const map::VoxelValue& value) {
    if (value.status == map::Occupancy::kOccupied) out_world.push_back(map::keyToCentre(key, res));
  });
}

ReferenceReconstruction::ReferenceReconstruction(const map::LocalGrid& grid) : cloud_(grid.cloud()) {
  appendOccupiedCentres(grid, geometry::Pose3::Identity(), points_);
  index_ = std::make_unique<slam::NearestNeighbours>(points_);
}

namespace {

double rmseTo(const std::vector<Eigen::Vector3d>& points, const geometry::Pose3& T,
              const slam::NearestNeighbours& index) {
  double sum_sq = 0.0;
  for (const Eigen::Vector3d& p : points) sum_sq += index.nearest(T * p).second;
  return std::sqrt(sum_sq / static_cast<double>(points.size()));
}

}  // namespace

Result<ReconstructionError> reconstructionError(const std::vector<Eigen::Vector3d>& estimate_world,
                                                const ReferenceReconstruction& reference) {
  if (estimate_world.empty()) return Error{"reconstruction error: the estimate has no occupied voxel"};
  if (reference.points().empty()) return Error{"reconstruction error: the reference has no occupied voxel"};
  // ICP source: an even subsample of the estimate (at most 20000 points keeps the alignment cheap).
  geometry::PointCloud source;
  const std::size_t stride = 1 + estimate_world.size() / 20000;
  for (std::size_t i = 0; i < estimate_world.size(); i += stride) source.points.push_back(estimate_world[i]);
  // Full 6-DoF point-to-plane ICP, stepping along every direction (a rigid registration, not a loop
  // closure): the reference is a closed 3-D object, so no direction is degenerate.
  slam::PointToPlaneConfig icp;
  icp.dofs = slam::IcpDofs::kFull;
  icp.degeneracy_aware = false;
  icp.max_iterations = 50;
  icp.max_correspondence_distance_m = 1.0;
  icp.min_correspondence_distance_m = 1.0;      // a fixed bound: the error figures stay comparable across changes
  icp.max_normal_angle_rad = std::numbers::pi;  // the estimate's voxel centres carry no normals
  auto aligned = slam::icpPointToPlane(source, reference.cloud(), geometry::Pose3::Identity(), icp);
  if (!aligned) return Error{"reconstruction error: alignment: " + aligned.error().message};
  ReconstructionError out;
  out.n_points = estimate_world.size();
  out.T_reference_estimate = aligned->T_target_source;
  out.rmse_unaligned_m = rmseTo(estimate_world, geometry::Pose3::Identity(), reference.index());
  out.rmse_m = rmseTo(estimate_world, out.T_reference_estimate, reference.index());
  return out;
}

double coverageOf(const map::MergedMap& map, const std::vector<Eigen::Vector3d>& points, double radius_m,
                  std::vector<bool>* flags) {
  if (flags != nullptr) flags->assign(points.size(), false);
  if (points.empty()) return 0.0;
  const double res = map.resolution();
  const int reach = static_cast<int>(std::ceil(radius_m / res));
  std::size_t covered = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& p = points[i];
    const map::VoxelKey centre = map::pointToKey(p, 1.0 / res);
    bool hit = false;
    for (int dz = -reach; dz <= reach && !hit; ++dz)
      for (int dy = -reach; dy <= reach && !hit; ++dy)
        for (int dx = -reach; dx <= reach && !hit; ++dx) {
          const map::VoxelKey k = centre + map::VoxelKey(dx, dy, dz);
          if ((map::keyToCentre(k, res) - p).norm() > radius_m) continue;
          hit = map.at(k).status == map::Occupancy::kOccupied;
        }
    if (hit) ++covered;
    if (flags != nullptr) (*flags)[i] = hit;
  }
  return static_cast<double>(covered) / static_cast<double>(points.size());
}

}  // namespace vog::eval
