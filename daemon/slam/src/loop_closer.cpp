#include "vog/slam/loop_closer.hpp"

#include "vog/slam/pose_vector.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>

namespace vog::slam {

namespace {

// Summary key of a rejection, so statistics group by cause rather than by the numbers in a message.
std::string reasonKey(const IcpResult& r, const IcpAcceptance& a) {
  if (!r.converged) return "not_converged";
  if (a.reason.rfind("fitness", 0) == 0) return "fitness";
  if (a.reason.rfind("disagrees", 0) == 0) return "odometry_disagreement";
  return "acceptance";
}

// LoopCloserConfig::max_revisits: `candidates` (positions in `submaps`, ascending) split into runs
// whose indices differ by at most `gap`; all but the first run and the newest max_revisits - 1 are
// erased. Returns how many were erased.
int dropMiddleRevisits(const std::vector<LoopSubmap>& submaps, int max_revisits, int gap,
                       std::vector<std::size_t>& candidates) {
  std::vector<std::size_t> run_start;
  for (std::size_t i = 0; i < candidates.size(); ++i)
    if (i == 0 || submaps[candidates[i]].index - submaps[candidates[i - 1]].index > gap) run_start.push_back(i);
  const auto runs = static_cast<std::size_t>(max_revisits);
  if (run_start.size() <= runs) return 0;
  const auto first_end = static_cast<std::ptrdiff_t>(run_start[1]);
  const auto newest_begin = static_cast<std::ptrdiff_t>(run_start[run_start.size() - (runs - 1)]);
  candidates.erase(candidates.begin() + first_end, candidates.begin() + newest_begin);
  return static_cast<int>(newest_begin - first_end);
}

}  // namespace

SubmapFootprint footprintOf(const LoopSubmap& s) {
  SubmapFootprint f;
  f.index = s.index;
  f.T_world_submap = s.T_world_submap;
  const Eigen::AlignedBox3d box = s.grid->knownBox();
  if (!box.isEmpty()) {
    f.aabb_min_submap = box.min();
    f.aabb_max_submap = box.max();
  }
  f.centroid_submap = s.grid->cloud().empty() ? Eigen::Vector3d::Zero() : s.grid->cloudCentroid();
  f.n_points = s.grid->cloud().size();
  return f;
}

const char* toString(LoopClosureMode mode) { return mode == LoopClosureMode::kPointToPoint2d ? "p2p" : "degenerate"; }

Result<LoopClosureMode> parseLoopClosureMode(std::string_view name) {
  if (name == "p2p") return LoopClosureMode::kPointToPoint2d;
  if (name == "degenerate") return LoopClosureMode::kDegenerate;
  return Error{"loop closure mode '" + std::string(name) + "' is not one of: p2p, degenerate"};
}

Status LoopCloserConfig::validate() const {
  if (Status s = candidates.validate(); !s.ok()) return Error{"loop closer config: candidates: " + s.error().message};
  if (Status s = p2p.validate(); !s.ok()) return Error{"loop closer config: p2p: " + s.error().message};
  if (Status s = point_to_plane.validate(); !s.ok()) {
    return Error{"loop closer config: point_to_plane: " + s.error().message};
  }
  if (Status s = acceptance.validate(); !s.ok()) return Error{"loop closer config: acceptance: " + s.error().message};
  if (!(p2p_max_fitness_m2 > 0.0) || !std::isfinite(p2p_max_fitness_m2)) {
    return Error{"loop closer config: p2p_max_fitness_m2 = " + std::to_string(p2p_max_fitness_m2) +
                 " must be positive"};
  }
  if (!(max_heading_difference_rad > 0.0 && max_heading_difference_rad <= std::numbers::pi)) {
    return Error{"loop closer config: max_heading_difference_rad = " + std::to_string(max_heading_difference_rad) +
                 " must be in (0, pi]"};
  }
  if (!(max_yaw_disagreement_rad > 0.0 && max_yaw_disagreement_rad <= std::numbers::pi)) {
    return Error{"loop closer config: max_yaw_disagreement_rad = " + std::to_string(max_yaw_disagreement_rad) +
                 " must be in (0, pi]"};
  }
  if (max_revisits < 0 || max_revisits == 1) {
    return Error{"loop closer config: max_revisits = " + std::to_string(max_revisits) +
                 " must be 0 (no limit) or >= 2 (the oldest and the newest)"};
  }
  if (revisit_gap < 1) {
    return Error{"loop closer config: revisit_gap = " + std::to_string(revisit_gap) + " must be >= 1"};
  }
  if (max_registrations < 0) {
    return Error{"loop closer config: max_registrations = " + std::to_string(max_registrations) +
                 " must be >= 0 (0: no limit)"};
  }
  if (!(min_overlap_fraction >= 0.0 && min_overlap_fraction <= 1.0)) {
    return Error{"loop closer config: min_overlap_fraction = " + std::to_string(min_overlap_fraction) +
                 " must be in [0, 1]"};
  }
  if (!(p2p_min_overlap_fraction >= 0.0 && p2p_min_overlap_fraction <= 1.0)) {
    return Error{"loop closer config: p2p_min_overlap_fraction = " + std::to_string(p2p_min_overlap_fraction) +
                 " must be in [0, 1]"};
  }
  if (!(odometry_yaw_sigmas >= 0.0) || !std::isfinite(odometry_yaw_sigmas)) {
    return Error{"loop closer config: odometry_yaw_sigmas = " + std::to_string(odometry_yaw_sigmas) +
                 " must be finite and >= 0 (0: off)"};
  }
  if (!(odometry_cov_yaw_rad2_per_s >= 0.0) || !std::isfinite(odometry_cov_yaw_rad2_per_s) ||
      !(registration_yaw_stddev_rad > 0.0) || !std::isfinite(registration_yaw_stddev_rad)) {
    return Error{"loop closer config: odometry_cov_yaw_rad2_per_s = " + std::to_string(odometry_cov_yaw_rad2_per_s) +
                 " must be finite and >= 0, registration_yaw_stddev_rad = " +
                 std::to_string(registration_yaw_stddev_rad) + " finite and > 0"};
  }
  return Status::success();
}

void LoopCloseStats::add(const LoopCloseStats& other) {
  tried += other.tried;
  accepted += other.accepted;
  rejected += other.rejected;
  skipped_heading += other.skipped_heading;
  skipped_budget += other.skipped_budget;
  skipped_revisits += other.skipped_revisits;
  ambiguous_directions += other.ambiguous_directions;
  switched_off += other.switched_off;
  switched_on += other.switched_on;
  for (const auto& [k, n] : other.rejected_by_reason) rejected_by_reason[k] += n;
}

Result<LoopCloser> LoopCloser::create(const LoopCloserConfig& config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  return LoopCloser(config);
}

Result<LoopCloseOutcome> LoopCloser::closeLoops(const std::vector<LoopSubmap>& submaps, std::size_t newest) const {
  if (newest >= submaps.size()) {
    return Error{"loop closer: newest position " + std::to_string(newest) + " is out of range (" +
                 std::to_string(submaps.size()) + " submaps)"};
  }
  for (const LoopSubmap& s : submaps) {
    if (!s.grid || !s.grid->finalized()) {
      return Error{"loop closer: submap " + std::to_string(s.index) + " has no finalized grid"};
    }
  }
  std::vector<SubmapFootprint> footprints;
  footprints.reserve(submaps.size());
  for (const LoopSubmap& s : submaps) footprints.push_back(footprintOf(s));
  return closeLoops(submaps, footprints, newest);
}

Result<LoopCloseOutcome> LoopCloser::closeLoops(const std::vector<LoopSubmap>& submaps,
                                                const std::vector<SubmapFootprint>& footprints,
                                                std::size_t newest) const {
  if (newest >= submaps.size()) {
    return Error{"loop closer: newest position " + std::to_string(newest) + " is out of range (" +
                 std::to_string(submaps.size()) + " submaps)"};
  }
  if (footprints.size() != submaps.size()) {
    return Error{"loop closer: " + std::to_string(footprints.size()) + " footprints for " +
                 std::to_string(submaps.size()) + " submaps"};
  }
  for (std::size_t k = 0; k < submaps.size(); ++k) {
    const LoopSubmap& s = submaps[k];
    if (!s.grid || !s.grid->finalized()) {
      return Error{"loop closer: submap " + std::to_string(s.index) + " has no finalized grid"};
    }
    if (footprints[k].index != s.index) {
      return Error{"loop closer: footprint " + std::to_string(footprints[k].index) + " at the position of submap " +
                   std::to_string(s.index)};
    }
  }
  auto partners = findLoopCandidatesOf(footprints, newest, config_.candidates);
  if (!partners) return Error{"loop closer: " + partners.error().message};
  return registerCandidates(submaps, newest, partners.value(),
                            [&footprints](std::size_t k) -> const SubmapFootprint& { return footprints[k]; });
}

Result<LoopCloseOutcome> LoopCloser::closeLoops(const std::vector<LoopSubmap>& submaps, const CandidateIndex& index,
                                                const SubmapFootprint& newest) const {
  if (submaps.empty() || index.size() + 1 != submaps.size()) {
    return Error{"loop closer: " + std::to_string(index.size()) + " indexed footprints for " +
                 std::to_string(submaps.size()) + " submaps (the newest last, not indexed)"};
  }
  const std::size_t last = submaps.size() - 1;
  if (newest.index != submaps[last].index) {
    return Error{"loop closer: footprint " + std::to_string(newest.index) + " given for the newest submap " +
                 std::to_string(submaps[last].index)};
  }
  auto partners = index.candidatesOf(newest);
  if (!partners) return Error{"loop closer: " + partners.error().message};
  std::vector<std::size_t> checked = partners.value();
  checked.push_back(last);
  for (const std::size_t k : checked) {
    const LoopSubmap& s = submaps[k];
    if (!s.grid || !s.grid->finalized()) {
      return Error{"loop closer: submap " + std::to_string(s.index) + " has no finalized grid"};
    }
    if (k != last && index.footprints()[k].index != s.index) {
      return Error{"loop closer: footprint " + std::to_string(index.footprints()[k].index) +
                   " at the position of submap " + std::to_string(s.index)};
    }
  }
  return registerCandidates(submaps, last, partners.value(), [&](std::size_t k) -> const SubmapFootprint& {
    return k == last ? newest : index.footprints()[k];
  });
}

LoopCloseOutcome LoopCloser::registerCandidates(
    const std::vector<LoopSubmap>& submaps, std::size_t newest, const std::vector<std::size_t>& partners,
    const std::function<const SubmapFootprint&(std::size_t)>& footprint) const {
  // The point-to-point mode's fitness and overlap are measured differently and have their own bounds.
  const bool p2p = config_.mode == LoopClosureMode::kPointToPoint2d;
  IcpAcceptanceConfig bounds = config_.acceptance;
  if (p2p) bounds.max_fitness_m2 = config_.p2p_max_fitness_m2;
  const double min_overlap = p2p ? config_.p2p_min_overlap_fraction : config_.min_overlap_fraction;

  LoopCloseOutcome out;
  const LoopSubmap& source = submaps[newest];
  std::vector<std::size_t> gated;
  for (const std::size_t k : partners) {
    const double dyaw = geometry::wrapAngle(geometry::yawOf(source.T_world_submap.linear()) -
                                            geometry::yawOf(submaps[k].T_world_submap.linear()));
    if (std::abs(dyaw) > config_.max_heading_difference_rad) {
      ++out.stats.skipped_heading;
      continue;
    }
    gated.push_back(k);
  }
  if (config_.max_revisits > 0) {
    out.stats.skipped_revisits = dropMiddleRevisits(submaps, config_.max_revisits, config_.revisit_gap, gated);
  }
  const auto budget = static_cast<std::size_t>(config_.max_registrations);
  if (budget > 0 && gated.size() > budget) {
    // The nearest by the clouds' centroids at the current estimates, ties by position (deterministic).
    const auto centroid = [&](std::size_t k) {
      const SubmapFootprint& f = footprint(k);
      return f.T_world_submap * f.centroid_submap;
    };
    const Eigen::Vector3d c = centroid(newest);
    std::vector<std::pair<double, std::size_t>> by_distance;
    for (const std::size_t k : gated) by_distance.emplace_back((centroid(k) - c).squaredNorm(), k);
    std::sort(by_distance.begin(), by_distance.end());
    by_distance.resize(budget);
    out.stats.skipped_budget = static_cast<int>(gated.size() - by_distance.size());
    gated.clear();
    for (const auto& [d2, k] : by_distance) gated.push_back(k);
    std::sort(gated.begin(), gated.end());
  }
  for (const std::size_t k : gated) {
    const LoopSubmap& target = submaps[k];
    ++out.stats.tried;
    // T_target_source predicted by the current estimates (the odometry chain plus earlier closures).
    const geometry::Pose3 T_prior = target.T_world_submap.inverse() * source.T_world_submap;
    Result<IcpResult> icp = Error{""};
    if (p2p) {
      icp = icpPointToPoint2d(source.grid->cloud(), target.grid->cloud(), T_prior, config_.p2p);
    } else {
      PointToPlaneConfig c = config_.point_to_plane;
      c.degeneracy_aware = true;
      const map::LocalGrid& target_grid = *target.grid;
      icp = icpPointToPlane(source.grid->cloud(), target_grid.cloud(), T_prior, c,
                            [&target_grid](const Eigen::Vector3d& p) { return target_grid.logOdds(p).has_value(); });
    }
    if (!icp) {
      ++out.stats.rejected;
      ++out.stats.rejected_by_reason["registration_failed"];
      continue;
    }
    out.stats.ambiguous_directions += icp->ambiguous_directions;
    const double dt_s = 1e-9 * static_cast<double>(source.first_stamp_ns - target.first_stamp_ns);
    const IcpAcceptance acc = checkIcpAcceptance(icp.value(), T_prior, dt_s, bounds);
    if (!acc.accepted) {
      ++out.stats.rejected;
      ++out.stats.rejected_by_reason[reasonKey(icp.value(), acc)];
      continue;
    }
    const double yaw_disagreement = std::abs(
        geometry::wrapAngle(geometry::yawOf(icp->T_target_source.linear()) - geometry::yawOf(T_prior.linear())));
    if (yaw_disagreement > config_.max_yaw_disagreement_rad) {
      ++out.stats.rejected;
      ++out.stats.rejected_by_reason["yaw_disagreement"];
      continue;
    }
    if (config_.odometry_yaw_sigmas > 0.0 && source.T_world_submap_odometry && target.T_world_submap_odometry) {
      const geometry::Pose3 T_odometry = target.T_world_submap_odometry->inverse() * *source.T_world_submap_odometry;
      const double off = std::abs(
          geometry::wrapAngle(geometry::yawOf(icp->T_target_source.linear()) - geometry::yawOf(T_odometry.linear())));
      const double stddev = std::sqrt(config_.odometry_cov_yaw_rad2_per_s * std::abs(dt_s) +
                                      config_.registration_yaw_stddev_rad * config_.registration_yaw_stddev_rad);
      if (off > config_.odometry_yaw_sigmas * stddev) {
        ++out.stats.rejected;
        ++out.stats.rejected_by_reason["odometry_yaw"];
        continue;
      }
    }
    const double overlap = static_cast<double>(icp->n_correspondences) /
                           static_cast<double>(std::max<std::size_t>(1, source.grid->cloud().size()));
    if (overlap < min_overlap) {
      ++out.stats.rejected;
      ++out.stats.rejected_by_reason["overlap"];
      continue;
    }
    if (icp->V_u.rows() == 0) {
      ++out.stats.rejected;
      ++out.stats.rejected_by_reason["no_well_conditioned_direction"];
      continue;
    }
    // Thesis Alg. 8: measurement V_u x_icp with covariance V_u Cov V_u^T. For the 2D point-to-point
    // baseline V_u spans x, y and yaw (every estimated direction).
    auto factor = makePartialLoopClosure(icp->V_u, toXyzRpy(icp->T_target_source), icp->covariance);
    if (!factor) {
      ++out.stats.rejected;
      ++out.stats.rejected_by_reason["bad_factor"];
      continue;
    }
    LoopClosure c;
    c.from = target.index;
    c.to = source.index;
    c.T_from_to = icp->T_target_source;
    c.T_from_to_prior = T_prior;
    c.factor = std::move(factor.value());
    c.icp = std::move(icp.value());
    out.closures.push_back(std::move(c));
    ++out.stats.accepted;
  }
  return out;
}

}  // namespace vog::slam
