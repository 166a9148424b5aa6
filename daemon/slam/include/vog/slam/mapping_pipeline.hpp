#pragma once
// MappingPipeline: the mapping thread's algorithm in one class, without threads or I/O (thesis 3.2,
// 4.2, Alg. 1 and 6-8). Scans with their odometry pose and depth/attitude measurements are fed in time
// order. When the SubmapBuilder closes a submap the pipeline
//   1. adds its base pose as a node (initialised by composing the odometry onto the optimised estimate
//      of the previous node), the odometry factor from the previous node (covariance dt * Sigma) and
//      the absolute z/roll/pitch factor of its base scan;
//   2. appends the grid to the VogMap at that estimate;
//   3. searches loop closures for it (LoopCloser) and adds the accepted ones;
//   4. optimises the pose graph (when a closure was added, or always if configured);
//   5. deforms the VogMap with every optimised base pose (Alg. 1) and reports which submaps moved, so
//      that the caller can run MergedMap::sync on `map().entries()`.
//
// Lifecycle: create() (or restore() from persisted state); feed() any number of times in time order;
// finish() closes the last submap.
// Invariants: the graph has exactly one node per VogMap submap, with the same id (the submap index)
// and, after every feed()/finish() that returned ok, the same pose; a rejected input changes nothing.
// An internal failure while processing a closed submap (pose graph or optimiser error, never caused by
// input that passed validation) leaves graph and map as they were but loses that submap, so the
// pipeline then refuses further input with the original error (the odometry chain would have a gap).
// Deterministic: no clocks, no randomness.
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/map/vog_map.hpp"
#include "vog/slam/loop_closer.hpp"
#include "vog/slam/pose_graph.hpp"
#include "vog/slam/submap_builder.hpp"

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace vog::slam {

struct MappingPipelineConfig {
  SubmapBuilderConfig builder;
  LoopCloserConfig loop_closer;
  PoseGraphConfig graph;
  bool loop_closures = true;  // false: submaps stay at raw odometry (the baseline)
  // Absolute factor noise: depth sensor and IMU attitude (standard deviations). Assumed values for a
  // strain-gauge depth sensor and an AHRS; the thesis treats z, roll and pitch as observed (4.2).
  double depth_stddev_m = 0.05;
  double roll_pitch_stddev_rad = geometry::deg2rad(0.5);
  // Optimise after every new submap even without a new closure (else only when one was accepted).
  bool optimize_every_submap = false;
  // After a closure, optimise only the loop it makes: the nodes from the oldest submap it joins to the
  // newest (PoseGraph::optimizeFrom), the older ones held. The cost and the submaps that move (and are
  // re-merged) then follow the loop's length, not the mission's; but the held part no longer learns
  // from later closures (harbour survey, 250 submaps: submap pose RMSE 0.48 m against 0.34 m with the
  // whole graph; daemon/slam/README.md). Without a closure only the new node is optimised.
  bool optimize_closed_loop_only = false;
  // Bounded solves for long missions: once the graph has more than local_optimization_nodes nodes
  // (0: never), a solve frees only that many, the nodes nearest in hops to the new submap and to the
  // submaps its closures join (PoseGraph::neighbourhood), the rest held; so its cost and the submaps
  // that move no longer grow with the mission. Every full_optimization_every-th submap (by index) the
  // whole graph is solved, closure or not, so that the held part learns from the closures since
  // (docs/long-mission). Ignored with optimize_closed_loop_only.
  int local_optimization_nodes = 0;
  int full_optimization_every = 25;
  // Consistency before insertion: the new submap's accepted closures enter the graph only when they
  // agree with odometry and the other closures. The graph is optimised with them; a closure whose
  // residual at that optimum is unlikely (closureConsistencyChi2 above the chi-square quantile of
  // its rank at consistency_confidence) is refused, the worst first, and the rest optimised again.
  // The residual's covariance is the closure's own plus a floor for what the registration's
  // covariance leaves out (voxel-sized bias of partial views): consistency_floor_m along its
  // translations, consistency_floor_rad along its rotations. 0 confidence: every closure enters, the
  // default until the check makes the trajectory better (daemon/slam/README.md; 0.999 measured there).
  double consistency_confidence = 0.0;
  double consistency_floor_m = 0.05;
  double consistency_floor_rad = geometry::deg2rad(0.5);
  // Closures that were accepted and are later found inconsistent (needs consistency_confidence > 0):
  // after every solve that moved the graph, every accepted closure is checked again at the new optimum
  // with the same statistic; the least consistent one beyond its quantile is switched off
  // (PoseGraph::setLoopClosureActive) and the whole graph solved again, and when none is beyond, the
  // most consistent switched-off closure within its quantile is switched back on (not one switched off
  // in the same re-check), up to recheck_max_solves solves per new submap. The map deforms with the
  // poses, so it bends back when a closure is switched off. Off by default (daemon/slam/README.md: it
  // does not make the trajectory better yet), and not offered by vogd: the mission store keeps the
  // closures as accepted, not the later switches (restore() honours LoopClosure::active).
  bool consistency_recheck = false;
  int recheck_max_solves = 8;
  Status validate() const;
};

// The consistency statistic of a closure at the estimates T_world_from, T_world_to: r^T S^-1 r with r
// the closure's residual in its directions (as the pose graph's factor has it) and S its covariance
// plus V_u diag(floor_m^2 I3, floor_rad^2 I3) V_u^T.
double closureConsistencyChi2(const PartialLoopClosure& closure, const geometry::Pose3& T_world_from,
                              const geometry::Pose3& T_world_to, double floor_m, double floor_rad);

// The chi-square quantile of k degrees of freedom (1..6) at confidence p in (0, 1).
double chiSquareQuantile(int k, double p);

// The consistency check before insertion (MappingPipelineConfig::consistency_confidence): optimises
// `without_closures` (the graph with the new node `newest`, its odometry and absolute factors) with
// `closures`, refusing the least consistent one and optimising again while one is beyond its quantile.
// The solve is the whole graph's, the closed loop's or a bounded one as `config` says. `optimize` is
// empty when nothing was optimised (no closure left, and neither optimize_every_submap nor a whole-graph
// solve due): the graph is then `without_closures`.
struct ConsistentOptimum {
  PoseGraph graph;
  std::vector<bool> refused;  // per closure
  std::optional<OptimizeResult> optimize;
};
Result<ConsistentOptimum> optimizeConsistent(const PoseGraph& without_closures,
                                             const std::vector<LoopClosure>& closures, NodeId newest,
                                             const MappingPipelineConfig& config);

// The consistency re-check (MappingPipelineConfig::consistency_recheck) on `graph`, which holds every
// closure of `closures` as a factor, switched on where `active` holds, at an optimum: switches closures
// off and on as described there, solving the whole graph after each switch, and keeps `active` equal to
// the graph's switches. Appends each switch (from, to) to `switched_off` / `switched_on` in order.
// Errors on sizes that differ or a failed solve (the graph and `active` are then as far as they got).
Status recheckClosures(PoseGraph& graph, const std::vector<const LoopClosure*>& closures, std::vector<bool>& active,
                       const MappingPipelineConfig& config, std::vector<std::pair<NodeId, NodeId>>& switched_off,
                       std::vector<std::pair<NodeId, NodeId>>& switched_on);

// Where process() spent its time for one closed submap (wall ms, steady clock; figures only, no
// algorithm reads them).
struct MappingPhaseTimes {
  double graph_ms = 0.0;     // copying the graph and adding the new node's factors
  double search_ms = 0.0;    // loop-closure candidate search and registrations (LoopCloser::closeLoops)
  double optimize_ms = 0.0;  // optimizeConsistent: every solve and consistency pass, with its graph copies
  double commit_ms = 0.0;    // poses read back, VogMap add + deform, records updated
};

// What one feed()/finish() changed.
struct MappingUpdate {
  std::optional<std::int64_t> closed_submap;  // index (= VogMap id = graph node id) of a new submap
  std::vector<LoopClosure> closures;          // accepted for it
  LoopCloseStats loop_stats;                  // of this call
  bool optimized = false;
  OptimizeResult optimize;           // valid when optimized
  std::vector<map::SubmapId> moved;  // submaps whose base pose changed in the VogMap
  // Earlier closures (from, to) the consistency re-check switched off or back on in this call, in order.
  std::vector<std::pair<NodeId, NodeId>> switched_off;
  std::vector<std::pair<NodeId, NodeId>> switched_on;
  // The new submap as the builder closed it (grid, odometry factor, absolute measurement): what a
  // mission store persists so that restore() can rebuild the graph. Set iff closed_submap is.
  std::optional<ClosedSubmap> closed;
  MappingPhaseTimes phase_times;  // set iff closed_submap is
};

// The record of one submap: odometry and current (optimised) base pose.
struct SubmapRecord {
  std::int64_t index = 0;
  geometry::Pose3 T_world_base_odom = geometry::Pose3::Identity();
  geometry::Pose3 T_world_base = geometry::Pose3::Identity();
  std::int64_t first_stamp_ns = 0;
  std::int64_t last_stamp_ns = 0;
  std::size_t n_scans = 0;
  CloseReason reason = CloseReason::kFlush;
};

// Everything restore() needs: the closed submaps in index order 0..N-1 (grids finalized, as the builder
// produced them or reloaded from disk), the accepted closures in acceptance order, and the current graph
// estimate of every submap (x, y, z, roll, pitch, yaw as PoseGraph::estimate() returns it), in index order.
struct PipelineState {
  std::vector<ClosedSubmap> submaps;
  std::vector<LoopClosure> closures;
  std::vector<Vector6d> estimates;
};

class MappingPipeline {
 public:
  static Result<std::unique_ptr<MappingPipeline>> create(const MappingPipelineConfig& config);
  // Rebuilds a pipeline from persisted state (a resumed mission). The graph gets the same nodes and
  // factors, added in the same order as the original pipeline added them, and the same estimates; the
  // VogMap the same entries at the same poses; so feeding the scans that follow gives bit-identical
  // results to a pipeline that never stopped. The submap that was active when the state was saved is
  // not part of it: the next fed scan starts submap N (its odometry factor runs from submap N-1, see
  // SubmapBuilder::resumeAfter). Loop statistics restart at zero. An inconsistent state (gaps in the
  // indices, a closure naming an unknown or newer submap, a missing or non-finite estimate, an
  // unfinalized grid) is an error naming what was wrong.
  static Result<std::unique_ptr<MappingPipeline>> restore(const MappingPipelineConfig& config,
                                                          const PipelineState& state);
  MappingPipeline(const MappingPipeline&) = delete;
  MappingPipeline& operator=(const MappingPipeline&) = delete;

  Result<MappingUpdate> feed(const ScanInput& input);
  // Closes the active submap (end of a run) and processes it like any other.
  Result<MappingUpdate> finish();

  const map::VogMap& map() const { return *map_; }
  const PoseGraph& graph() const { return graph_; }
  const std::vector<SubmapRecord>& submaps() const { return submaps_; }
  const std::vector<LoopClosure>& closures() const { return closures_; }
  const LoopCloseStats& loopStats() const { return stats_; }
  const MappingPipelineConfig& config() const { return config_; }

 private:
  MappingPipeline(const MappingPipelineConfig& config, SubmapBuilder builder, LoopCloser closer, PoseGraph graph,
                  std::unique_ptr<map::VogMap> map, CandidateIndex candidates)
      : config_(config),
        builder_(std::move(builder)),
        closer_(std::move(closer)),
        graph_(std::move(graph)),
        map_(std::move(map)),
        candidates_(std::move(candidates)) {}
  Result<MappingUpdate> process(ClosedSubmap closed);

  MappingPipelineConfig config_;
  SubmapBuilder builder_;
  LoopCloser closer_;
  PoseGraph graph_;
  std::unique_ptr<map::VogMap> map_;
  std::vector<SubmapRecord> submaps_;
  // The loop closer's view of every submap and their footprints, in the order of submaps_ and at the same
  // poses: kept so that a new submap's candidate search tests the submaps near it (CandidateIndex), not
  // N centroid computations and a copy of every list.
  std::vector<LoopSubmap> loop_submaps_;
  CandidateIndex candidates_;
  std::vector<LoopClosure> closures_;
  LoopCloseStats stats_;
  std::optional<Error> failed_;  // set by an internal failure in process()
};

}  // namespace vog::slam
