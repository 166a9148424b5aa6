#pragma once
// Receding-horizon next-best-view planner (Bircher et al. 2016, as adapted in thesis 4.3 and 4.5.3-4.5.5).
//
// Each plan() call grows an RRT from the current pose inside the exploration box, through known free
// space only (TraversabilityGrid). Sampling is constrained (thesis 4.5.3): a sample is either an x-y
// point at the current depth (extended from the nearest tree node at that depth) or a depth at the
// current x-y (extended from the nearest node on that vertical), and its heading differs from its
// parent's by at most max_heading_change_rad. A node's value is
//   value(n) = value(parent) + gain(parent -> n) * exp(-lambda * cost(root -> n))
// with gain the sonar-fan gain swept along the edge (SonarGain) and cost the travel time (translation
// at v_max and turning at the yaw rate, simultaneously) expressed in metres at v_max: Bircher's cost is
// the path length, for which lambda = 0.5 per metre is tuned (thesis Table 4.2), and a turn on the spot
// costs the distance the vehicle could have covered meanwhile. The first edge of the best branch is executed; the rest
// of that branch seeds the next tree (re-checked against the newer map).
//
// Global search (PlannerConfig::global_search): when no node's value exceeds gain_threshold (after
// growing to n_tol nodes or spending max_samples), the nearest reachable candidate view whose fan sees
// more than global_min_gain becomes the goal, reached along a known-free path (kExplore with several
// waypoints); a goal is never chosen twice, so the search cannot loop.
// Termination: when neither the tree nor the global search finds gain, exploration is complete and
// the planner returns a known-free path back to the home pose; when no collision-free edge exists at
// all (or no way home), it reports kNoPath instead of looping.
// Root: when the vehicle's estimate is not a safe voxel, the tree grows from the nearest safe one
// within root_tolerance_m and the result's waypoints start with that position: every edge the
// vehicle is sent along is one the planner checked. Farther than that from every safe voxel (a loop
// closure moved the map), the result is one straight move to the nearest safe voxel within
// recovery_radius_m that the collision box reaches clear of occupied voxels (reason "recovering ...");
// the same when the estimate has left the exploration box by no more than recovery_radius_m (a
// closure moved it there; the vehicle moves back in). Farther out than that is an error.
//
// Lifecycle: create() with a config and the home (start) pose; then plan() with the newest snapshot
// and the current pose, as often as needed. The planner only reads the snapshots it is given (it
// never blocks a map writer); it keeps a traversability grid updated incrementally from successive
// snapshots of one MergedMap writer (rebuilt when a snapshot is older than the last one), the seed
// branch and its random generator. Results depend only on the config (seed), the snapshots and the
// poses passed in. Not thread-safe: one planning thread owns it.

#include "vog/map/merged_map.hpp"
#include "vog/plan/planner_config.hpp"
#include "vog/plan/sonar_gain.hpp"
#include "vog/plan/traversability.hpp"

#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace vog::plan {

enum class PlanStatus { kExplore, kComplete, kNearHome, kNoPath };
const char* toString(PlanStatus status);

struct TreeNode {
  Waypoint w;
  int parent = -1;      // index in the tree; -1 for the root
  double cost_m = 0.0;  // travel time from the root, in metres at v_max
  double gain = 0.0;    // gain of the edge parent -> this node
  double value = 0.0;   // Bircher 2016 Eq. 1 (see above)
  bool seeded = false;  // re-inserted from the previous best branch
};

struct PlanResult {
  PlanStatus status = PlanStatus::kNoPath;
  // kExplore: the next waypoint (end of the best branch's first edge). kComplete: the path home,
  // ending at the home pose. kNearHome: home is not reachable through known free space; the path to
  // the reachable safe position nearest to it. kNoPath: empty.
  std::vector<Waypoint> waypoints;
  std::vector<Waypoint> best_branch;  // kExplore: root .. best node
  double best_value = 0.0;
  double best_gain = 0.0;  // gain of the best node's own edge
  int tree_size = 0;       // nodes including the root
  int samples = 0;         // sampling attempts
  std::uint64_t map_version = 0;
  std::string reason;         // why kComplete / kNearHome / kNoPath, or "global goal ..." for a global search
  bool global_goal = false;   // kExplore toward a goal of the global search
  int global_candidates = 0;  // gain evaluations of the global search (0: not run)
};

// The vehicle turns while it moves, so its collision box may face any heading: collisions are checked
// for the vertical cylinder the box sweeps turning on the spot (diameter = the diagonal of its
// horizontal sides, height = its height), grown by clearance_m all around its vertical side.
Footprint anyHeadingFootprint(const Eigen::Vector3d& collision_box_m, double clearance_m = 0.0);

class NbvPlanner {
 public:
  // Errors name the bad config key, or say the home pose is not finite or not inside the box.
  static Result<std::unique_ptr<NbvPlanner>> create(const PlannerConfig& config, const Waypoint& home);

  NbvPlanner(const NbvPlanner&) = delete;
  NbvPlanner& operator=(const NbvPlanner&) = delete;

  // One planning iteration on `snapshot` from `current`. Errors: null snapshot, non-finite pose, pose
  // outside the exploration box, pose inside an occupied voxel, map of another resolution.
  Result<PlanResult> plan(const std::shared_ptr<const map::MergedMap>& snapshot, const Waypoint& current);

  // The way home on `snapshot` from `current` (the vehicle's one way home: an exploration that
  // completes ends on the same path): kComplete with a known-free path from the nearest safe voxel
  // within root_tolerance_m to the home pose, headings turned as in plan(); when home is not
  // reachable through known free space, kNearHome with the path to the reachable safe voxel nearest
  // to home (ties: the fewest steps); kNoPath with the reason when the vehicle cannot move at all. After
  // reportObstruction() the path starts with the retreat move (as plan()'s would). Same errors as plan(); it leaves the
  // kept branch and a revisit request for the next plan().
  Result<PlanResult> planHome(const std::shared_ptr<const map::MergedMap>& snapshot, const Waypoint& current);

  // The vehicle was stopped at p_world on its way to target_world by something the map does not
  // show (its estimate and the map disagree, or an unmapped obstacle): the next plan() first backs
  // it off by obstruction_retreat_m the way it came (kExplore with that one waypoint), and the kept
  // branch, which led there, is dropped. The point ahead of p_world at half the collision box's
  // footprint diagonal becomes a contact (TraversabilityGrid::addContact; the planner keeps the
  // last kMaxContacts of them across grid rebuilds), so later plans do not send the vehicle into the
  // same place again. Returns the retreat position; non-finite input, or no direction (it was
  // turning on the spot), changes nothing and gives nullopt.
  std::optional<Eigen::Vector3d> reportObstruction(const Eigen::Vector3d& p_world, const Eigen::Vector3d& target_world);

  // Asks the next plan() to send the vehicle back to one of `views` (poses it has mapped from
  // before, in the caller's order of preference) instead of exploring: the first view with a safe
  // voxel within root_tolerance_m that a known-free path reaches becomes the goal, arrived at with
  // the view's heading (kExplore, reason "revisit ..."). A mapping layer uses this to close loops
  // when its estimate has drifted from the older map (active loop closure). At most
  // kMaxRevisitTries views are tried; none reachable, or non-finite views, and plan() explores as
  // usual. One request serves one plan() call.
  void requestRevisit(std::vector<Waypoint> views);
  static constexpr std::size_t kMaxRevisitTries = 8;
  static constexpr std::size_t kMaxContacts = 64;

  // The tree of the last plan() call (tests and plots).
  const std::vector<TreeNode>& lastTree() const { return tree_; }
  const PlannerConfig& config() const { return config_; }
  const Waypoint& home() const { return home_; }
  // The traversability grid of the last snapshot, if any.
  const TraversabilityGrid* traversability() const { return grid_ ? &*grid_ : nullptr; }
  // Travel time between two waypoints (translation at v_max and yaw at the yaw rate, simultaneously)
  // times v_max: metres of path-length-equivalent cost.
  double edgeCost(const Waypoint& a, const Waypoint& b) const;

 private:
  NbvPlanner(const PlannerConfig& config, const Waypoint& home);
  // Checks the inputs of plan() and planHome() (`what` names the call in errors) and brings the
  // traversability grid up to the snapshot.
  Status prepare(const std::shared_ptr<const map::MergedMap>& snapshot, const Waypoint& current, const char* what);
  Status syncTraversability(const map::MergedMap& map);
  // The vehicle is sent to the tree's root first when it was snapped to a safe voxel away from `current`.
  static PlanResult fromRoot(const Waypoint& root, const Waypoint& current, PlanResult result);
  bool headingOk(const Waypoint& from, const Waypoint& to) const;
  void addNode(const map::MergedMap& map, int parent, const Waypoint& w, bool seeded);
  PlanResult goHome(const Waypoint& current, PlanResult result) const;
  // A pending revisit request (requestRevisit); true when it set `result` to kExplore toward a view.
  bool revisit(const Waypoint& start, std::vector<Waypoint> views, PlanResult& result) const;
  // The global search (see above); true when it set `result` to kExplore toward a goal.
  bool globalGoal(const map::MergedMap& map, const Waypoint& start, PlanResult& result);
  // The local tree found no move worth making (tree_has_edge: it grew at least one edge, so the
  // vehicle can move here): a global goal, else the path home. Without an edge the end needs the
  // global search's word that no view is left and somewhere to go; boxed in at home, or with the
  // global search off, it is kNoPath.
  PlanResult globalGoalOrHome(const map::MergedMap& map, const Waypoint& start, PlanResult result, bool tree_has_edge);
  // Waypoints along `points` (points[0] excluded), heading turned toward goal_yaw by at most
  // max_heading_change_rad per waypoint, then on the spot at the last point until it is reached.
  std::vector<Waypoint> alongPath(const std::vector<Eigen::Vector3d>& points, double start_yaw, double goal_yaw) const;

  PlannerConfig config_;
  Waypoint home_;
  std::mt19937_64 rng_;
  std::optional<TraversabilityGrid> grid_;
  std::optional<SonarGain> gain_;
  double resolution_m_ = 0.0;
  std::vector<Waypoint> seed_branch_;               // best branch of the last call after its first edge
  std::vector<Eigen::Vector3d> global_goals_;       // goals chosen by the global search so far
  std::optional<Eigen::Vector3d> pending_retreat_;  // where the next plan() backs off to
  std::vector<Waypoint> revisit_views_;             // requestRevisit() for the next plan()
  std::vector<Eigen::Vector3d> contacts_;           // reportObstruction(), oldest first
  std::vector<TreeNode> tree_;
};

}  // namespace vog::plan
