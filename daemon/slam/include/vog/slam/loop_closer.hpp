#pragma once
// LoopCloser (thesis Alg. 6-8): for a newly closed submap, finds loop-closure candidates among
// non-consecutive submaps under the current base-pose estimates (centroid-in-AABB gate, Alg. 6),
// registers each pair with ICP and returns the accepted registrations as pose-graph factors.
//
// Modes:
//  - kPointToPoint2d (`p2p`, thesis Alg. 6): 2D point-to-point ICP on (x, y, yaw), accepted by the
//    three checks of checkIcpAcceptance (converged, fitness, disagreement with odometry within the
//    drift bound sqrt(cov_x dt + cov_y dt)); the factor constrains x, y and yaw.
//  - kDegenerate (`degenerate`, thesis Alg. 7-8): degeneracy-aware point-to-plane ICP, the same
//    acceptance checks, and a partial factor over the well-conditioned directions V_u only.
//
// Stateless apart from its configuration: each call is a pure function of its inputs.
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/map/local_grid.hpp"
#include "vog/slam/icp.hpp"
#include "vog/slam/loop_candidates.hpp"
#include "vog/slam/pose_graph.hpp"

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace vog::slam {

enum class LoopClosureMode { kPointToPoint2d, kDegenerate };
const char* toString(LoopClosureMode mode);
// "p2p" or "degenerate".
Result<LoopClosureMode> parseLoopClosureMode(std::string_view name);

struct LoopCloserConfig {
  LoopClosureMode mode = LoopClosureMode::kDegenerate;
  CandidateConfig candidates;
  PointToPoint2dConfig p2p;
  PointToPlaneConfig point_to_plane;  // degeneracy_aware is forced on in kDegenerate mode
  // Drift rates for criterion 3 default to the odometry noise of thesis Eq. 4.1. Fitness 0.015 m^2
  // over the correspondences within the ICP's final 0.3 m bound (PointToPlaneConfig): on the pilings
  // (vog-bench mission, seeds 1, 2, 5, every registration tried compared with the truth) registrations
  // within 0.2 m / 2 deg of the truth end at 0.011-0.026 m^2 (10-90 %), the others at 0.014-0.036;
  // with this bound, 30 % overlap and the 2 deg yaw check, 188 registrations passed, 2 of them more than
  // 0.3 m off, where the earlier 1 m fitness (0.05 m^2) passed 66 with 5.
  IcpAcceptanceConfig acceptance{0.015, 0.00138, 0.00138};
  // The fitness bound of kPointToPoint2d, which replaces acceptance.max_fitness_m2 in that mode: its
  // fitness is the mean squared point-to-point distance in 2-D, larger than the point-to-plane
  // residual of the same alignment; 0.015 m^2 is where its wrong propeller registrations began.
  double p2p_max_fitness_m2 = 0.015;
  // Viewing-direction gate, added to Alg. 6: a profiling sonar only sees the faces of objects turned
  // towards it, so two submaps whose base headings differ much see different faces of the same pilings
  // (the near halves of a cylinder seen from opposite sides are 2 r apart) and ICP aligns them with a
  // bias of up to the object size. Pairs whose current base yaws differ by more than this are skipped.
  // 45 deg: submaps of consecutive laps of an orbit are about 32 deg out of phase.
  double max_heading_difference_rad = 0.7854;  // 45 deg
  // Criterion 3 extended to heading: the registered yaw may differ from the current estimate's by at
  // most this (the thesis bounds only x-y; a wrong match between similar pilings often turns: 2 deg
  // passes 90 % of the registrations within 0.2 m / 2 deg of the truth and half of the others fail it).
  double max_yaw_disagreement_rad = 0.03491;  // 2 deg
  // At most this many registrations per new submap (0: every candidate the gates pass), the candidates
  // whose clouds' centroids are nearest the new one's: on a survey repeated over the same lanes every
  // pass adds candidates, and the registrations would make the mapping time per submap grow with the
  // mission (docs/long-mission).
  int max_registrations = 0;
  // At most this many revisits per new submap (0: every one). A revisit is a run of candidates whose
  // submap indices follow one another with gaps of at most revisit_gap (one pass over the place); the
  // oldest run and the max_revisits - 1 newest are registered. A repeated survey otherwise ties each
  // new submap to every earlier pass over the place, and the pose graph's normal equations fill in
  // with the passes (docs/long-mission); with the oldest and the newest, each pass is tied to the one
  // before it and to the first. Applied before max_registrations.
  int max_revisits = 0;
  int revisit_gap = 3;
  // Fraction of the source cloud that must find a correspondence within the ICP's final bound at the
  // result (overlap): 0.3 within the point-to-plane ICP's 0.3 m. The point-to-point mode counts
  // within its fixed 1 m and keeps its own bound (at 0.3 a wrong closure passed in
  // mapping_pipeline_test).
  double min_overlap_fraction = 0.3;
  double p2p_min_overlap_fraction = 0.5;
  // Heading against the odometry (0: off): the registered yaw may differ from the odometry's relative
  // yaw between the two bases (not the current estimates, which earlier closures may have turned) by at
  // most odometry_yaw_sigmas standard deviations of that difference, sqrt(odometry_cov_yaw dt +
  // registration_yaw_stddev^2): the heading's random walk between the two bases (thesis 4.4.1) and the
  // registration's own heading error (voxel-sized on a few metres).
  double odometry_yaw_sigmas = 0.0;
  double odometry_cov_yaw_rad2_per_s = 1e-7;
  double registration_yaw_stddev_rad = 0.008727;  // 0.5 deg
  Status validate() const;
};

// A submap as the loop closer sees it: its grid (finalized, cloud in the submap frame), its current
// base-pose estimate and its first stamp (for the drift bound).
struct LoopSubmap {
  std::int64_t index = 0;
  std::shared_ptr<const map::LocalGrid> grid;
  geometry::Pose3 T_world_submap = geometry::Pose3::Identity();
  std::int64_t first_stamp_ns = 0;
  // The odometry's own base pose (before any closure), for the heading check against odometry; a
  // submap without it is not checked.
  std::optional<geometry::Pose3> T_world_submap_odometry = std::nullopt;
};

// The candidate gate's view of a submap: its grid's known box, cloud centroid and cloud size (fixed once
// the grid is finalized) at its current base-pose estimate. The centroid costs a pass over the cloud: a
// caller that closes loops for every new submap computes it once per submap and keeps it.
SubmapFootprint footprintOf(const LoopSubmap& submap);

// An accepted closure: `to` registered against `from` (T_from_to), and the factor it becomes.
struct LoopClosure {
  std::int64_t from = 0;  // the older submap (ICP target)
  std::int64_t to = 0;    // the new submap (ICP source)
  geometry::Pose3 T_from_to = geometry::Pose3::Identity();
  geometry::Pose3 T_from_to_prior = geometry::Pose3::Identity();  // from the estimates before ICP
  PartialLoopClosure factor;
  IcpResult icp;
  // False once the consistency re-check switched it off (MappingPipelineConfig::consistency_recheck):
  // its factor stays in the graph, unused, until a later re-check finds it consistent again.
  bool active = true;
};

struct LoopCloseStats {
  int tried = 0;
  int accepted = 0;
  int rejected = 0;
  std::map<std::string, int> rejected_by_reason;  // cause -> count
  int skipped_heading = 0;                        // candidates skipped by the viewing-direction gate (not tried)
  int skipped_budget = 0;                         // candidates beyond max_registrations (not tried)
  int skipped_revisits = 0;                       // candidates of revisits beyond max_revisits (not tried)
  int ambiguous_directions = 0;                   // directions of tried registrations the probe dropped
  int switched_off = 0;                           // accepted closures the consistency re-check switched off
  int switched_on = 0;                            // ... and on again
  void add(const LoopCloseStats& other);
};

struct LoopCloseOutcome {
  std::vector<LoopClosure> closures;
  LoopCloseStats stats;
};

class LoopCloser {
 public:
  static Result<LoopCloser> create(const LoopCloserConfig& config);
  // Closures between `submaps[newest]` and every other candidate submap. Errors on an index out of
  // range or a submap without a finalized grid; a failed or rejected registration is a statistic.
  // The candidates are found by findLoopCandidatesOf (O(N) gate tests) and tried in ascending position.
  Result<LoopCloseOutcome> closeLoops(const std::vector<LoopSubmap>& submaps, std::size_t newest) const;
  // The same with the footprints given (footprints[k] equal to footprintOf(submaps[k])), so that a caller
  // does not recompute every submap's centroid for every new submap; an error when the sizes or the
  // indices differ.
  Result<LoopCloseOutcome> closeLoops(const std::vector<LoopSubmap>& submaps,
                                      const std::vector<SubmapFootprint>& footprints, std::size_t newest) const;
  // The same for the last of `submaps`, with the footprints of the others in a CandidateIndex (its
  // position k is submaps[k]) and its own as `newest`: the gate tests only the footprints near the new
  // one (CandidateIndex), so the search does not grow with the mission; the same candidates, so the same
  // outcome. Errors on sizes or indices that differ, and on a candidate without a finalized grid.
  Result<LoopCloseOutcome> closeLoops(const std::vector<LoopSubmap>& submaps, const CandidateIndex& index,
                                      const SubmapFootprint& newest) const;
  const LoopCloserConfig& config() const { return config_; }

 private:
  explicit LoopCloser(const LoopCloserConfig& config) : config_(config) {}
  // Registers submaps[newest] against the candidates `partners` (ascending positions); footprint(k)
  // gives the footprint of position k (the budget's distances).
  LoopCloseOutcome registerCandidates(const std::vector<LoopSubmap>& submaps, std::size_t newest,
                                      const std::vector<std::size_t>& partners,
                                      const std::function<const SubmapFootprint&(std::size_t)>& footprint) const;
  LoopCloserConfig config_;
};

}  // namespace vog::slam
