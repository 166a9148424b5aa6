#pragma once
// Loop-closure candidate gating (thesis Alg. 6 lines 4-8, Fig. 4.6), on plain inputs so it does not
// depend on how submaps are stored: a pair of non-consecutive submaps is a candidate when, under the
// current base-pose estimates, the centroid of either cloud lies inside the axis-aligned bounding box
// of the other (the box is axis-aligned in its own submap frame, the centroid is mapped into it).
// An optional Mahalanobis gate compares a registration with the odometry prediction.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"

#include <Eigen/Core>

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

namespace vog::slam {

struct SubmapFootprint {
  std::int64_t index = 0;  // submap sequence number (consecutive submaps differ by 1)
  geometry::Pose3 T_world_submap = geometry::Pose3::Identity();
  Eigen::Vector3d aabb_min_submap = Eigen::Vector3d::Zero();
  Eigen::Vector3d aabb_max_submap = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid_submap = Eigen::Vector3d::Zero();
  std::size_t n_points = 0;
};

struct CandidateConfig {
  // Pairs whose indices differ by less than this are not candidates (consecutive submaps are
  // already tied by odometry).
  std::int64_t min_index_gap = 2;
  std::size_t min_points = 30;  // Alg. 6 line 4: enough points in both clouds
  Status validate() const;
};

// Errors naming the submap when its pose, box or centroid is not finite, the pose not rigid, or the box
// has min > max: the checks every function below makes of each footprint it is given.
Status checkFootprint(const SubmapFootprint& footprint);

// True when b's centroid, mapped into a's frame, lies inside a's AABB.
bool centroidInside(const SubmapFootprint& a, const SubmapFootprint& b);

// All candidate pairs (i, j) with i < j as positions in `submaps`. Errors on a bad config, a
// non-finite pose/box/centroid or a box with min > max (naming the submap index).
Result<std::vector<std::pair<std::size_t, std::size_t>>> findLoopCandidates(const std::vector<SubmapFootprint>& submaps,
                                                                            const CandidateConfig& config = {});

// The candidates that involve submaps[newest]: every position k != newest such that the pair
// (min(k, newest), max(k, newest)) is in findLoopCandidates(submaps, config), in ascending k, which is
// the order findLoopCandidates lists those pairs in. The same gate tests on the same values, so the same
// set: O(N) tests for the newest submap instead of O(N^2) over all pairs. The same errors (every
// footprint is checked), and an error when `newest` is out of range.
Result<std::vector<std::size_t>> findLoopCandidatesOf(const std::vector<SubmapFootprint>& submaps, std::size_t newest,
                                                      const CandidateConfig& config = {});

// The gate of findLoopCandidatesOf for a new submap against every earlier one, over a hash of world
// x-y cells, so that the search costs what lies near the new submap rather than a test of every submap
// (a survey of 1000 submaps revisits each place a few times). Each footprint is registered in the cells
// of two world boxes: its known box's world bounding box and its cloud centroid, each grown by
// margin_m; the gate's two tests can only pass for a footprint whose box covers the new centroid's cell
// or whose centroid lies in a cell of the new box, so only those are tested, exactly as
// findLoopCandidatesOf tests them. A pose change re-registers a footprint only when it leaves its
// grown boxes: after a whole-graph solve, where every pose moves by centimetres, an update is a
// containment test. Footprints whose grown box spans more than kMaxCellsPerAxis cells per axis are
// kept apart and tested on every search (a huge box cannot make an update cost millions of cells).
class CandidateIndex {
 public:
  static constexpr std::int64_t kMaxCellsPerAxis = 64;
  // cell_m > 0 and margin_m >= 0; gate as findLoopCandidatesOf takes it.
  static Result<CandidateIndex> create(const CandidateConfig& gate, double cell_m = 4.0, double margin_m = 1.0);

  // Appends the footprint of the next position (size()); checked as findLoopCandidates checks (errors
  // name the submap; a failed add changes nothing).
  Status add(const SubmapFootprint& footprint);
  // Moves the footprint at `position` (error on a position out of range or a non-finite pose).
  Status setPose(std::size_t position, const geometry::Pose3& T_world_submap);
  const std::vector<SubmapFootprint>& footprints() const { return footprints_; }
  std::size_t size() const { return footprints_.size(); }

  // The candidates of a new submap that is to follow the indexed ones: findLoopCandidatesOf(footprints()
  // + {newest}, size(), gate), the positions in ascending order. Errors on a bad `newest`, as that does.
  Result<std::vector<std::size_t>> candidatesOf(const SubmapFootprint& newest) const;

 private:
  struct Registered {
    Eigen::AlignedBox2d box;       // grown world box of the known box; empty: not in the cells (wide_)
    Eigen::AlignedBox2d centroid;  // grown world box of the centroid
    bool wide = false;             // in wide_ rather than in the cells
  };
  using Cells = std::unordered_map<std::uint64_t, std::vector<std::uint32_t>>;
  CandidateIndex(const CandidateConfig& gate, double cell_m, double margin_m)
      : gate_(gate), cell_m_(cell_m), margin_m_(margin_m) {}
  Registered grownBoxes(const SubmapFootprint& f) const;
  void insert(std::uint32_t position, const Registered& r);
  void erase(std::uint32_t position, const Registered& r);

  CandidateConfig gate_;
  double cell_m_;
  double margin_m_;
  std::vector<SubmapFootprint> footprints_;
  std::vector<Registered> registered_;
  Cells box_cells_;                  // cell -> positions whose grown box covers it
  Cells centroid_cells_;             // cell -> positions whose grown centroid box covers it
  std::vector<std::uint32_t> wide_;  // positions tested on every search
};

// Squared Mahalanobis distance of the (x, y, yaw) difference between a registration and the odometry
// prediction (yaw wrapped) under the relative-pose covariance (3x3, x, y, yaw); errors when the
// covariance is not positive definite. Gate with a chi-square quantile, e.g. 7.81 (3 DOF, 95 %).
Result<double> planarMahalanobisSquared(const geometry::Pose3& T_registered, const geometry::Pose3& T_predicted,
                                        const Eigen::Matrix3d& covariance);

}  // namespace vog::slam
