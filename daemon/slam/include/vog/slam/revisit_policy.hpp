#pragma once
// RevisitPolicy: when to send the vehicle back to a view it mapped from long ago (active loop
// closure). Not in the thesis: its planner only explores, and a run whose loop closures stop
// reaching the older submaps (the viewing-direction gate skips pairs seen from other headings, the
// fitness check refuses the rest) drifts on until later submaps' free space clears the older map's
// thin pilings. Closing a loop needs the sonar to see the same faces again from a similar heading,
// which exploration alone does not seek.
//
// A closure anchors the chain when its two submaps started at least anchor_span_s apart (it ties
// the recent submaps to the older map). A revisit is due when neither an anchoring closure nor a
// revisit happened for longer than after_s; the views are then the base poses of the submaps started
// at least anchor_span_s ago, nearest first. The caller hands them to the planner
// (NbvPlanner::requestRevisit), which goes to the first one it can reach.
//
// Lifecycle: create() with the config and the mission's start stamp; due() at each planning
// iteration with the mapping pipeline's current submaps and closures (append-only lists).
// Deterministic: a pure function of its inputs and the calls made before.
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/slam/loop_closer.hpp"
#include "vog/slam/mapping_pipeline.hpp"

#include <cstdint>
#include <vector>

namespace vog::slam {

// The submaps an accepted loop closure joined (LoopClosure::from, LoopClosure::to).
struct ClosurePair {
  std::int64_t from = 0;
  std::int64_t to = 0;
};
std::vector<ClosurePair> closurePairs(const std::vector<LoopClosure>& closures);

struct RevisitConfig {
  // Longest time without an anchoring closure before a revisit, s; 0 = never revisit (our choice:
  // 150 s, the time the thesis's odometry noise (Eq. 4.1) takes to reach a 0.64 m planar standard
  // deviation, more than half the collision box; vog-bench mission).
  double after_s = 150.0;
  // Start-time difference that makes a closure anchoring and a submap old enough to revisit, s
  // (our choice: 120 s, about seven submaps of the propeller run).
  double anchor_span_s = 120.0;
  Status validate() const;
};

class RevisitPolicy {
 public:
  // Errors name the bad key.
  static Result<RevisitPolicy> create(const RevisitConfig& config, std::int64_t start_stamp_ns);

  // The views to revisit, nearest to p_world_now first, when a revisit is due at now_ns (and it is
  // then counted as made); otherwise empty. `closures` are the accepted closures' (from, to) submap
  // indices in acceptance order (MappingPipeline::closures()); an index out of range is ignored.
  std::vector<geometry::Pose3> due(const std::vector<SubmapRecord>& submaps, const std::vector<ClosurePair>& closures,
                                   const Eigen::Vector3d& p_world_now, std::int64_t now_ns);
  int revisits() const { return revisits_; }

 private:
  RevisitPolicy(const RevisitConfig& config, std::int64_t start_stamp_ns)
      : config_(config), start_ns_(start_stamp_ns) {}
  // Seconds since the start stamp.
  double secondsOf(std::int64_t stamp_ns) const { return 1e-9 * static_cast<double>(stamp_ns - start_ns_); }

  RevisitConfig config_;
  std::int64_t start_ns_ = 0;
  std::size_t closures_seen_ = 0;
  double last_anchor_s_ = 0.0;
  double last_revisit_s_ = 0.0;
  int revisits_ = 0;
};

}  // namespace vog::slam
