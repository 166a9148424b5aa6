#include "vog/slam/loop_candidates.hpp"

#include "vog/slam/information.hpp"

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

namespace vog::slam {

Status CandidateConfig::validate() const {
  if (min_index_gap < 1) {
    return Error{"candidate config: min_index_gap must be >= 1, got " + std::to_string(min_index_gap)};
  }
  return Status::success();
}

bool centroidInside(const SubmapFootprint& a, const SubmapFootprint& b) {
  const Eigen::Vector3d c_a = a.T_world_submap.inverse() * (b.T_world_submap * b.centroid_submap);
  return (c_a.array() >= a.aabb_min_submap.array()).all() && (c_a.array() <= a.aabb_max_submap.array()).all();
}

namespace {

Status checkFootprints(const std::vector<SubmapFootprint>& submaps, const CandidateConfig& config) {
  if (Status s = config.validate(); !s) return s.error();
  for (const SubmapFootprint& s : submaps) {
    const std::string name = "loop candidates: submap " + std::to_string(s.index);
    if (!geometry::isValidPose(s.T_world_submap)) return Error{name + " has a non-finite or non-rigid pose"};
    if (!s.aabb_min_submap.allFinite() || !s.aabb_max_submap.allFinite() || !s.centroid_submap.allFinite()) {
      return Error{name + " has a non-finite bounding box or centroid"};
    }
    if ((s.aabb_min_submap.array() > s.aabb_max_submap.array()).any()) {
      return Error{name + " has a bounding box with min > max"};
    }
  }
  return Status::success();
}

// The gate of one pair (a before b in the list): Alg. 6 lines 4-8.
bool isCandidatePair(const SubmapFootprint& a, const SubmapFootprint& b, const CandidateConfig& config) {
  if (std::llabs(a.index - b.index) < config.min_index_gap) return false;
  if (a.n_points < config.min_points || b.n_points < config.min_points) return false;
  return centroidInside(a, b) || centroidInside(b, a);
}

}  // namespace

Result<std::vector<std::pair<std::size_t, std::size_t>>> findLoopCandidates(const std::vector<SubmapFootprint>& submaps,
                                                                            const CandidateConfig& config) {
  if (Status s = checkFootprints(submaps, config); !s) return s.error();
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t i = 0; i < submaps.size(); ++i) {
    for (std::size_t j = i + 1; j < submaps.size(); ++j) {
      if (isCandidatePair(submaps[i], submaps[j], config)) pairs.emplace_back(i, j);
    }
  }
  return pairs;
}

Result<std::vector<std::size_t>> findLoopCandidatesOf(const std::vector<SubmapFootprint>& submaps, std::size_t newest,
                                                      const CandidateConfig& config) {
  if (Status s = checkFootprints(submaps, config); !s) return s.error();
  if (newest >= submaps.size()) {
    return Error{"loop candidates: newest position " + std::to_string(newest) + " is out of range (" +
                 std::to_string(submaps.size()) + " submaps)"};
  }
  std::vector<std::size_t> partners;
  const SubmapFootprint& n = submaps[newest];
  if (n.n_points < config.min_points) return partners;  // no pair with it passes line 4
  for (std::size_t k = 0; k < submaps.size(); ++k) {
    if (k == newest) continue;
    // The pair as findLoopCandidates orders it: the earlier position first.
    const bool candidate = k < newest ? isCandidatePair(submaps[k], n, config) : isCandidatePair(n, submaps[k], config);
    if (candidate) partners.push_back(k);
  }
  return partners;
}

Result<double> planarMahalanobisSquared(const geometry::Pose3& T_registered, const geometry::Pose3& T_predicted,
                                        const Eigen::Matrix3d& covariance) {
  if (!geometry::isValidPose(T_registered) || !geometry::isValidPose(T_predicted)) {
    return Error{"mahalanobis gate: pose is not a finite rigid transform"};
  }
  const auto info = informationFromCovariance(covariance, "mahalanobis gate covariance");
  if (!info) return info.error();
  Eigen::Vector3d d;
  d.head<2>() = T_registered.translation().head<2>() - T_predicted.translation().head<2>();
  d(2) = geometry::wrapAngle(geometry::yawOf(T_registered.linear()) - geometry::yawOf(T_predicted.linear()));
  return d.dot(*info * d);
}

}  // namespace vog::slam
