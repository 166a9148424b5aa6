#pragma once
// Information gain of a path segment for a vertical profiling-sonar fan (thesis 4.3.1, 4.5.4).
//
// A 1 deg thick fan has almost no volume: a camera-style frustum test finds hardly any voxel centre
// inside it. Instead the segment is interpolated at the map resolution in position and at the fan's
// thickness in yaw (so consecutive fans abut while the vehicle turns), and at every pose the fan's
// beams are cast through the merged map up to the planner range (voxel walk, MergedMap::traverse).
// A beam stops at the first occupied voxel (it cannot see past it). Every voxel of the exploration
// box a beam reaches is counted once per segment, weighted by its status (PlannerConfig gain_*).
//
// Speed: given the planner's TraversabilityGrid of the same snapshot, a beam that starts inside the
// box walks the grid's dense status copy with the exact stepping of MergedMap::traverse, and stops
// when it leaves the box (a straight beam never re-enters a box, and nothing outside counts); the
// result is identical to walking the map (tested), in about a third of the time (`vog-bench plan`:
// gain_cached_us_per_edge against gain_us_per_edge).
//
// Lifecycle: holds the beam directions and a per-voxel bitset over the exploration box (the
// per-segment dedupe, cleared at the start of each segment). Reads only the snapshot passed to each
// call. Not thread-safe: one per planner.

#include "vog/map/merged_map.hpp"
#include "vog/plan/planner_config.hpp"
#include "vog/plan/traversability.hpp"

#include <cstdint>
#include <vector>

namespace vog::plan {

struct GainStats {
  long poses = 0;
  long rays = 0;
  long voxels_visited = 0;
};

class SonarGain {
 public:
  // resolution_m is the merged map's. Errors on an invalid config or a box too large for its bitset.
  static Result<SonarGain> create(const PlannerConfig& config, double resolution_m);

  // Weighted count of distinct box voxels the fan sees along from -> to (both ends included).
  // `cache`, when given, must have been built or updated from this very snapshot (same version).
  double segmentGain(const map::MergedMap& map, const Waypoint& from, const Waypoint& to,
                     const TraversabilityGrid* cache = nullptr);
  // The poses segmentGain casts from: n + 1 evenly spaced poses, n = max(1, ceil(distance / res),
  // ceil(|yaw change| / fan thickness)); yaw turns the short way round.
  std::vector<Waypoint> interpolate(const Waypoint& from, const Waypoint& to) const;
  // Sensor pose of the fan at a waypoint (vehicle level, then the fan's mounting).
  geometry::Pose3 sensorPose(const Waypoint& w) const;
  // Beam directions in the sensor frame and the range they are cast to.
  const std::vector<Eigen::Vector3d>& beamDirections() const { return beams_sensor_; }
  double rangeM() const { return range_m_; }
  // Is this voxel counted (inside the exploration box's voxels)?
  bool counts(const map::VoxelKey& key) const { return box_keys_.contains(key); }
  double weight(map::Occupancy status) const;

  const GainStats& stats() const { return stats_; }

 private:
  SonarGain() = default;
  // Counts one beam's voxels; returns false when the beam must be walked on the map instead.
  bool castCached(const TraversabilityGrid& cache, const Eigen::Vector3d& origin, const Eigen::Vector3d& end,
                  double& gain);
  std::size_t boxIndex(const map::VoxelKey& key) const {
    const map::VoxelKey d = key - box_keys_.min;
    return static_cast<std::size_t>(d.x()) +
           static_cast<std::size_t>(box_size_.x()) *
               (static_cast<std::size_t>(d.y()) +
                static_cast<std::size_t>(box_size_.y()) * static_cast<std::size_t>(d.z()));
  }
  // First visit of box voxel i in this segment?
  bool firstVisit(std::size_t i) {
    std::uint64_t& word = seen_[i >> 6];
    const std::uint64_t bit = std::uint64_t{1} << (i & 63);
    const bool first = (word & bit) == 0;
    word |= bit;
    return first;
  }

  double resolution_m_ = 0.0;
  double yaw_step_rad_ = 0.0;
  double range_m_ = 0.0;
  double w_unknown_ = 0.0;
  double w_free_ = 0.0;
  double w_occupied_ = 0.0;
  geometry::Pose3 T_vehicle_sensor_;
  std::vector<Eigen::Vector3d> beams_sensor_;
  map::KeyBox box_keys_;
  Eigen::Vector3i box_size_ = Eigen::Vector3i::Zero();
  // One bit per box voxel: counted in the current segment. A bitset (not a stamp per voxel) stays in
  // the L2 cache; clearing it per segment costs far less than one beam walk.
  std::vector<std::uint64_t> seen_;
  GainStats stats_;
};

}  // namespace vog::plan
