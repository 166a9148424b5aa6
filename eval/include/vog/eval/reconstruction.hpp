#pragma once
// Reconstruction error against ground truth (thesis Table 4.3): the distance from each reconstructed
// point to the nearest point of a reference reconstruction, after a rigid ICP alignment of the two
// (as the thesis registers its reconstructions against the ground-truth cloud), and without it.
// Reconstructions are occupied-voxel centres, so a perfect pose estimate gives an error of zero
// when both are built from the same scans.

#include "vog/core/result.hpp"
#include "vog/geometry/point_cloud.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/map/local_grid.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/slam/nearest_neighbours.hpp"

#include <Eigen/Core>

#include <memory>
#include <vector>

namespace vog::eval {

// Appends the centres of the occupied voxels of a finalized grid, mapped to the world by T_world_grid.
void appendOccupiedCentres(const map::LocalGrid& grid, const geometry::Pose3& T_world_grid,
                           std::vector<Eigen::Vector3d>& out_world);

// Appends the centres of the occupied voxels of a merged map (world frame).
void appendOccupiedCentres(const map::MergedMap& map, std::vector<Eigen::Vector3d>& out_world);

// The reference: occupied voxel centres (for distances) and the grid's downsampled cloud with
// normals (the ICP target), both in the world frame.
class ReferenceReconstruction {
 public:
  // `grid` is finalized and holds every scan at its ground-truth pose; its frame is the world.
  explicit ReferenceReconstruction(const map::LocalGrid& grid);

  const std::vector<Eigen::Vector3d>& points() const { return points_; }
  const geometry::PointCloud& cloud() const { return cloud_; }
  const slam::NearestNeighbours& index() const { return *index_; }

 private:
  std::vector<Eigen::Vector3d> points_;
  geometry::PointCloud cloud_;
  std::unique_ptr<slam::NearestNeighbours> index_;
};

struct ReconstructionError {
  double rmse_m = 0.0;                                                 // after the rigid alignment
  double rmse_unaligned_m = 0.0;                                       // as reconstructed
  geometry::Pose3 T_reference_estimate = geometry::Pose3::Identity();  // the alignment
  std::size_t n_points = 0;
};

// Errors when the estimate is empty or the alignment ICP fails (too few points or correspondences).
Result<ReconstructionError> reconstructionError(const std::vector<Eigen::Vector3d>& estimate_world,
                                                const ReferenceReconstruction& reference);

// Coverage: the share of `points` (world frame) within `radius_m` of an occupied voxel of `map`;
// `flags`, when given, receives one covered flag per point.
double coverageOf(const map::MergedMap& map, const std::vector<Eigen::Vector3d>& points, double radius_m,
                  std::vector<bool>* flags = nullptr);

}  // namespace vog::eval
