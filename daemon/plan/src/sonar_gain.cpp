#include "vog/plan/sonar_gain.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace vog::plan {

namespace {
constexpr double kMaxBoxVoxels = 256.0 * 1024.0 * 1024.0;
}

Result<SonarGain> SonarGain::create(const PlannerConfig& config, double resolution_m) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  if (!(resolution_m > 0.0) || !std::isfinite(resolution_m)) return Error{"gain: map resolution must be > 0"};
  SonarGain g;
  g.resolution_m_ = resolution_m;
  // Consecutive fans 1 deg thick abut when the yaw step equals the thickness (thesis 4.1 fan). A fan
  // of zero thickness falls back to one resolution of arc at the planner range.
  g.yaw_step_rad_ = config.fan.spread_rad > 0.0 ? config.fan.spread_rad : resolution_m / config.planner_range_m;
  g.range_m_ = config.planner_range_m;
  g.w_unknown_ = config.gain_unknown;
  g.w_free_ = config.gain_free;
  g.w_occupied_ = config.gain_occupied;
  g.T_vehicle_sensor_ = config.fan.T_vehicle_sensor;
  for (int i = 0; i < config.fan.n_beams; ++i) g.beams_sensor_.push_back(config.fan.beamDirection(i));
  const double inv = 1.0 / resolution_m;
  g.box_keys_.min = map::pointToKey(config.box_min_world_m, inv);
  g.box_keys_.max = map::pointToKey(config.box_max_world_m, inv);
  g.box_size_ = g.box_keys_.max - g.box_keys_.min + map::VoxelKey::Ones();
  const double n = static_cast<double>(g.box_size_.x()) * g.box_size_.y() * g.box_size_.z();
  if (n > kMaxBoxVoxels) {
    std::ostringstream s;
    s << "gain: the exploration box holds " << n << " voxels at " << resolution_m << " m (limit " << kMaxBoxVoxels
      << ")";
    return Error{s.str()};
  }
  g.seen_.assign((static_cast<std::size_t>(n) + 63) / 64, 0);
  return g;
}

double SonarGain::weight(map::Occupancy status) const {
  switch (status) {
    case map::Occupancy::kFree: return w_free_;
    case map::Occupancy::kOccupied: return w_occupied_;
    case map::Occupancy::kUnknown: break;
  }
  return w_unknown_;
}

geometry::Pose3 SonarGain::sensorPose(const Waypoint& w) const {
  return geometry::poseFromXyzRpy(w.p_world.x(), w.p_world.y(), w.p_world.z(), 0.0, 0.0, w.yaw_rad) * T_vehicle_sensor_;
}

std::vector<Waypoint> SonarGain::interpolate(const Waypoint& from, const Waypoint& to) const {
  const double distance = (to.p_world - from.p_world).norm();
  const double dyaw = geometry::wrapAngle(to.yaw_rad - from.yaw_rad);
  // Thesis 4.5.4 (Fig. 4.16): intermediate poses at the map resolution; yaw at the fan thickness.
  const double steps = std::max({1.0, std::ceil(distance / resolution_m_), std::ceil(std::abs(dyaw) / yaw_step_rad_)});
  const int n = static_cast<int>(std::min(steps, 100000.0));
  std::vector<Waypoint> out;
  out.reserve(static_cast<std::size_t>(n) + 1);
  for (int i = 0; i <= n; ++i) {
    const double t = static_cast<double>(i) / n;
    out.push_back({from.p_world + t * (to.p_world - from.p_world), geometry::wrapAngle(from.yaw_rad + t * dyaw)});
  }
  return out;
}

bool SonarGain::castCached(const TraversabilityGrid& cache, const Eigen::Vector3d& origin, const Eigen::Vector3d& end,
                           double& gain) {
  // The stepping of MergedMap::traverse, operation for operation, so the voxels are the same.
  const map::VoxelWalk walk = map::startVoxelWalk(origin, end, resolution_m_, 1.0 / resolution_m_);
  const map::VoxelKey& key = walk.key;
  if (!box_keys_.contains(key)) return false;
  const map::VoxelKey& last = walk.last;
  const Eigen::Vector3i& step = walk.step;
  const Eigen::Vector3d& t_max = walk.t_max;
  const Eigen::Vector3d& t_delta = walk.t_delta;
  // The walk below is the loop of MergedMap::traverse with its bookkeeping made incremental: linear
  // indices into the status array and the bitset, the steps left inside the box per axis, and the
  // L1 distance to the end key (zero exactly when traverse's `key == last` holds).
  const map::VoxelKey& gmin = cache.gridKeys().min;
  const Eigen::Vector3i& gsize = cache.gridSize();
  const std::int64_t status_stride[3] = {1, gsize.x(), static_cast<std::int64_t>(gsize.x()) * gsize.y()};
  const std::int64_t seen_stride[3] = {1, box_size_.x(), static_cast<std::int64_t>(box_size_.x()) * box_size_.y()};
  std::int64_t status_i =
      (key.x() - gmin.x()) + status_stride[1] * (key.y() - gmin.y()) + status_stride[2] * (key.z() - gmin.z());
  auto seen_i = static_cast<std::int64_t>(boxIndex(key));
  const std::uint8_t* status_of = cache.statusArray().data();
  std::uint64_t* seen = seen_.data();
  const double w[3] = {w_unknown_, w_free_, w_occupied_};  // indexed by map::Occupancy
  static_assert(static_cast<int>(map::Occupancy::kUnknown) == 0 && static_cast<int>(map::Occupancy::kFree) == 1 &&
                static_cast<int>(map::Occupancy::kOccupied) == 2);
  // Per axis, in scalars so that the whole walk state stays in registers: the steps left inside the
  // box, last - key, the boundary parameter and its increment, and the index increments.
  auto insideAlong = [&](int i) {
    return step[i] > 0 ? box_keys_.max[i] - key[i] : (step[i] < 0 ? key[i] - box_keys_.min[i] : 0);
  };
  int in0 = insideAlong(0), in1 = insideAlong(1), in2 = insideAlong(2);
  int d0 = last[0] - key[0], d1 = last[1] - key[1], d2 = last[2] - key[2];
  const int s0 = step[0], s1 = step[1], s2 = step[2];
  int l1 = std::abs(d0) + std::abs(d1) + std::abs(d2);
  double t0 = t_max[0], t1 = t_max[1], t2 = t_max[2];
  const double dt0 = t_delta[0], dt1 = t_delta[1], dt2 = t_delta[2];
  const std::int64_t ds0 = s0 * status_stride[0], ds1 = s1 * status_stride[1], ds2 = s2 * status_stride[2];
  const std::int64_t de0 = s0 * seen_stride[0], de1 = s1 * seen_stride[1], de2 = s2 * seen_stride[2];
  double added = 0.0;
  long visited = 0;
  const long max_steps = 3 + l1;
  for (long n = 0; n <= max_steps; ++n) {
    ++visited;
    const std::uint8_t status = status_of[status_i];
    std::uint64_t& word = seen[static_cast<std::size_t>(seen_i) >> 6];
    const std::uint64_t bit = std::uint64_t{1} << (static_cast<std::size_t>(seen_i) & 63);
    if ((word & bit) == 0) {
      word |= bit;
      added += w[status];
    }
    if (status == static_cast<std::uint8_t>(map::Occupancy::kOccupied)) break;
    if (l1 == 0) break;
    // Same choice as traverse's two ifs (ties: the lowest axis), as selects rather than branches
    // (the branches mispredict about every other voxel).
    const bool y_first = t1 < t0;
    const double t01 = y_first ? t1 : t0;
    const bool z = t2 < t01;
    const bool y = !z && y_first;
    const bool x = !z && !y_first;
    if ((z ? t2 : t01) > 1.0) break;
    // Out of the box for good: nothing further counts, and occlusion no longer matters.
    in0 -= x;
    in1 -= y;
    in2 -= z;
    if ((in0 | in1 | in2) < 0) break;
    l1 += x ? std::abs(d0 - s0) - std::abs(d0)
            : (y ? std::abs(d1 - s1) - std::abs(d1) : std::abs(d2 - s2) - std::abs(d2));
    d0 -= x ? s0 : 0;
    d1 -= y ? s1 : 0;
    d2 -= z ? s2 : 0;
    t0 += x ? dt0 : 0.0;
    t1 += y ? dt1 : 0.0;
    t2 += z ? dt2 : 0.0;
    status_i += x ? ds0 : (y ? ds1 : ds2);
    seen_i += x ? de0 : (y ? de1 : de2);
  }
  gain += added;
  stats_.voxels_visited += visited;
  return true;
}

double SonarGain::segmentGain(const map::MergedMap& map, const Waypoint& from, const Waypoint& to,
                              const TraversabilityGrid* cache) {
  if (!from.p_world.allFinite() || !to.p_world.allFinite() || !std::isfinite(from.yaw_rad) ||
      !std::isfinite(to.yaw_rad))
    return 0.0;
  if (cache != nullptr && (cache->mapVersion() != map.version() || cache->resolution() != resolution_m_ ||
                           !cache->gridKeys().contains(box_keys_.min) || !cache->gridKeys().contains(box_keys_.max)))
    cache = nullptr;
  std::fill(seen_.begin(), seen_.end(), 0u);
  double gain = 0.0;
  for (const Waypoint& w : interpolate(from, to)) {
    const geometry::Pose3 T_world_sensor = sensorPose(w);
    const Eigen::Vector3d origin = T_world_sensor.translation();
    ++stats_.poses;
    for (const Eigen::Vector3d& d_sensor : beams_sensor_) {
      const Eigen::Vector3d end = origin + range_m_ * (T_world_sensor.linear() * d_sensor);
      ++stats_.rays;
      if (cache != nullptr && castCached(*cache, origin, end, gain)) continue;
      map.traverse(origin, end, [&](const map::VoxelKey& key, const map::VoxelValue& value) {
        ++stats_.voxels_visited;
        if (box_keys_.contains(key)) {
          if (firstVisit(boxIndex(key))) gain += weight(value.status);
        }
        // The beam cannot see past the first occupied voxel (thesis Fig. 4.8).
        return value.status != map::Occupancy::kOccupied;
      });
    }
  }
  return gain;
}

}  // namespace vog::plan
