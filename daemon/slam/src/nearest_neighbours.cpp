#include "vog/slam/nearest_neighbours.hpp"

#include <nanoflann.hpp>

namespace vog::slam {

// The k-d tree over the points, with its nanoflann adaptor.
struct NearestNeighbours::Impl {
  struct CloudAdaptor {
    const std::vector<Eigen::Vector3d>& points;
    std::size_t kdtree_get_point_count() const { return points.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i](static_cast<Eigen::Index>(dim)); }
    template <class Box>
    bool kdtree_get_bbox(Box& /*box*/) const {
      return false;
    }
  };
  using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, CloudAdaptor>, CloudAdaptor,
                                                     3, std::size_t>;

  explicit Impl(const std::vector<Eigen::Vector3d>& points)
      : adaptor{points}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
  CloudAdaptor adaptor;
  KdTree tree;
};

// GCC 12 at -O3 reports a false -Wnull-dereference inside the std::vector resize that nanoflann's
// buildIndex() inlines here.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
NearestNeighbours::NearestNeighbours(const std::vector<Eigen::Vector3d>& points)
    : impl_(std::make_unique<Impl>(points)), n_points_(points.size()) {}
#pragma GCC diagnostic pop

NearestNeighbours::~NearestNeighbours() = default;

std::pair<std::size_t, double> NearestNeighbours::nearest(const Eigen::Vector3d& q) const {
  std::size_t index = 0;
  double dist_sq = 0.0;
  impl_->tree.knnSearch(q.data(), 1, &index, &dist_sq);
  return {index, dist_sq};
}

void NearestNeighbours::nearestK(const Eigen::Vector3d& q, std::size_t k, std::vector<std::size_t>& index,
                                 std::vector<double>& dist_sq) const {
  index.resize(k);
  dist_sq.resize(k);
  const std::size_t found = impl_->tree.knnSearch(q.data(), k, index.data(), dist_sq.data());
  index.resize(found);
  dist_sq.resize(found);
}

}  // namespace vog::slam
