#pragma once
// Nearest-neighbour index over a point set (a k-d tree, nanoflann), used by ICP for correspondences
// and by the reconstruction evaluation for point-to-surface distances.
// Lifecycle: built once from points that must outlive it; read-only afterwards, so concurrent
// queries are safe.

#include <Eigen/Core>

#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

namespace vog::slam {

class NearestNeighbours {
 public:
  explicit NearestNeighbours(const std::vector<Eigen::Vector3d>& points);
  ~NearestNeighbours();
  NearestNeighbours(const NearestNeighbours&) = delete;
  NearestNeighbours& operator=(const NearestNeighbours&) = delete;

  // Index of the nearest point and its squared distance. The index set must not be empty.
  std::pair<std::size_t, double> nearest(const Eigen::Vector3d& q) const;
  // The nearest k points (fewer when the set is smaller), nearest first: their indices in `index` and
  // squared distances in `dist_sq`, both resized to the count found.
  void nearestK(const Eigen::Vector3d& q, std::size_t k, std::vector<std::size_t>& index,
                std::vector<double>& dist_sq) const;
  std::size_t size() const { return n_points_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t n_points_ = 0;
};

}  // namespace vog::slam
