#pragma once
// Loop-closure candidate gating (thesis Alg. 6 lines 4-8, Fig. 4.6), on plain inputs so it does not
// depend on how submaps are stored: a pair of non-consecutive submaps is a candidate when, under the
// current base-pose estimates, the centroid of either cloud lies inside the axis-aligned bounding box
// of the other (the box is axis-aligned in its own submap frame, the centroid is mapped into it).
// An optional Mahalanobis gate compares a registration with the odometry prediction.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
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

// Squared Mahalanobis distance of the (x, y, yaw) difference between a registration and the odometry
// prediction (yaw wrapped) under the relative-pose covariance (3x3, x, y, yaw); errors when the
// covariance is not positive definite. Gate with a chi-square quantile, e.g. 7.81 (3 DOF, 95 %).
Result<double> planarMahalanobisSquared(const geometry::Pose3& T_registered, const geometry::Pose3& T_predicted,
                                        const Eigen::Matrix3d& covariance);

}  // namespace vog::slam
