#pragma once
// Parameters of the next-best-view planner (thesis 4.3, 4.5.3-4.5.4 after Bircher et al. 2016).
// Defaults are the propeller simulation's (thesis Table 4.2) unless marked as our choice.

#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <numbers>

namespace vog::plan {

// A vehicle waypoint: position in the world frame (z up) and heading. Roll and pitch are zero (the
// HAUV hovers level).
struct Waypoint {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
};

struct PlannerConfig {
  // Exploration bounding box (world frame). Thesis 4.4: 12 m x 7 m x 3.5 m around the propeller.
  Eigen::Vector3d box_min_world_m{-6.0, -3.5, -3.5};
  Eigen::Vector3d box_max_world_m{6.0, 3.5, 0.0};
  // Full side lengths of the vehicle's collision box, centred on the vehicle (Table 4.2).
  Eigen::Vector3d collision_box_m{1.0, 1.0, 0.5};
  // Horizontal clearance kept between the collision box and anything not known free: the map around
  // the vehicle is drawn at an estimate that drifts in x, y and heading between loop closures, so a
  // box that only just fits in the map's free space can touch the real surface. None in z: depth is
  // measured, it does not drift (our choice: three voxels; vog-bench mission vog-lc, seeds 1-10 with
  // revisits and contacts: no refused step in 20 runs; two voxels: 4 refused steps in 3 runs, the
  // estimate 0.46-0.48 m off the truth where the map still showed 0.84-1.2 m of room).
  double clearance_m = 0.3;
  double planner_range_m = 5.0;  // d_max^planner (Table 4.2)
  double lambda = 0.5;           // gain discount per metre of path cost (Table 4.2)
  double max_edge_m = 2.0;       // RRT max edge length (Table 4.2)
  int n_max = 15;                // tree size (Table 4.2, N_max)
  // Bircher 2016's N_TOL: while no node has gain above the threshold the tree keeps growing up to
  // this size before exploration is declared complete (our choice).
  int n_tol = 60;
  // Sampling attempts per plan call, so a boxed-in vehicle is reported, never looped on (our choice).
  int max_samples = 600;
  double max_heading_change_rad = std::numbers::pi / 2;  // thesis 4.5.3: 90 deg
  double v_max_mps = 0.25;                               // Table 4.2
  double yaw_rate_radps = 0.15;                          // Table 4.2, psi
  // Thesis 4.5.3 two-step sampling: share of samples drawn in x-y at the current depth; the rest
  // are drawn along z at the current x-y (our choice).
  double xy_sample_share = 0.7;
  // Unknown space within this distance of the home (start) position counts as free for collision
  // checks (never occupied space). The vertical fan leaves the vehicle's near field unobserved above
  // and below its plane (at range r it covers +-0.26 r), so without this no first edge is ever
  // free; it states the operator's guarantee that the vehicle was put in at open water there
  // (Bircher 2016 initialises the same way). 0 = off (our choice: 1.5 m, past that blind zone).
  double assume_free_radius_m = 1.5;
  // The tree grows from the nearest safe position within this distance of the vehicle's estimate
  // when the estimate itself is not safe: the vehicle stops within its navigation and control error
  // of a safe waypoint, and a loop closure can move the estimate (not the vehicle) by tens of
  // centimetres (our choice: half the collision box's side plus the clearance; vog-bench mission).
  double root_tolerance_m = 0.6;
  // Farther than root_tolerance_m from every safe voxel (a loop closure moved the map by more), the
  // vehicle first moves straight to the nearest safe voxel within this distance that its collision box
  // reaches without touching an occupied voxel (NbvPlanner::plan); 0 = off, "no path" instead (our
  // choice: 1.5 m; vog-bench mission, propeller seed 2 otherwise ends after 10 submaps).
  double recovery_radius_m = 1.5;
  // After an obstruction (NbvPlanner::reportObstruction) the vehicle first backs off this far the way
  // it came: three voxels, more than the any-heading box's one-voxel margin.
  double obstruction_retreat_m = 0.3;
  // false: Bircher 2016's sampling (the thesis's baseline): uniform in the box, any heading.
  bool constrained_sampling = true;
  // false: gain of the edge's end pose only (Bircher 2016, the thesis's baseline); true: the fan
  // swept along the edge (thesis 4.5.4).
  bool gain_along_edge = true;
  // Gain per voxel by status (thesis 4.3.1: most gain on unknown space).
  double gain_unknown = 1.0;
  double gain_free = 0.0;
  double gain_occupied = 0.0;
  // Exploration is complete when no branch value exceeds this (in weighted voxels; our choice:
  // a few voxels of unknown space are noise, not a region worth a detour).
  double gain_threshold = 10.0;
  // Global search when the local tree finds no branch above gain_threshold (our choice; Bircher
  // 2016 stops there, and its receding horizon of a few 2 m edges declares "complete" while
  // unexplored regions remain farther away or behind obstacles, the local-minimum problem that
  // history-aware NBVP variants address, e.g. Selin et al. 2019): candidate views, the safe voxels
  // reachable from the vehicle thinned to global_spacing_m apart, are tried nearest first (in
  // path steps; every k-th when there are more than global_max_candidates, so the whole reachable
  // space is sampled); the first whose fan, at the best of 8 headings, sees more than
  // global_min_gain is the next goal, reached by a known-free path. Exploration is complete only
  // when none is found.
  bool global_search = true;
  double global_spacing_m = 0.5;
  double global_min_gain = 50.0;
  int global_max_candidates = 400;  // gain evaluations per search (bounds the time of one call)
  std::uint64_t seed = 1;
  // The sonar whose beams the gain casts; its max_range_m is replaced by planner_range_m.
  geometry::SonarFan fan;

  // Names the first bad key and its value, or is ok.
  Status validate() const;
};

}  // namespace vog::plan
