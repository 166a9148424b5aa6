#include "vog/map/vog_map.hpp"

#include <octomap/OcTree.h>

#include <fstream>
#include <iomanip>
#include <mutex>
#include <set>
#include <sstream>

namespace vog::map {

namespace {

Status checkCompatible(const GridConfig& a, const GridConfig& b) {
  auto same = [](double x, double y) { return std::abs(x - y) <= 1e-12 * std::max(1.0, std::abs(x)); };
  if (!same(a.resolution_m, b.resolution_m)) {
    return Error{"submap resolution " + std::to_string(b.resolution_m) + " differs from map resolution " +
                 std::to_string(a.resolution_m)};
  }
  if (!same(a.clamp_min, b.clamp_min) || !same(a.clamp_max, b.clamp_max) ||
      !same(a.occupancy_threshold, b.occupancy_threshold)) {
    return Error{"submap clamping or occupancy threshold differs from the map's"};
  }
  return {};
}

std::string submapFileName(SubmapId id) {
  std::ostringstream name;
  name << "submap_" << std::setw(6) << std::setfill('0') << id << ".ot";
  return name.str();
}

}  // namespace

bool segmentIntersectsBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::AlignedBox3d& box) {
  if (box.isEmpty()) return false;
  double t0 = 0.0;
  double t1 = 1.0;
  const Eigen::Vector3d d = b - a;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-15) {
      if (a[i] < box.min()[i] || a[i] > box.max()[i]) return false;
      continue;
    }
    double ta = (box.min()[i] - a[i]) / d[i];
    double tb = (box.max()[i] - a[i]) / d[i];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

Result<std::unique_ptr<VogMap>> VogMap::create(const GridConfig& config) {
  if (auto s = config.validate(); !s) return s.error();
  return std::unique_ptr<VogMap>(new VogMap(config));
}

Status VogMap::addSubmap(SubmapId id, std::shared_ptr<const LocalGrid> grid, const geometry::Pose3& T_world_submap) {
  if (!grid) return Error{"addSubmap: no grid for submap " + std::to_string(id)};
  if (!grid->finalized()) return Error{"addSubmap: submap " + std::to_string(id) + " is not finalized"};
  if (auto s = checkCompatible(config_, grid->config()); !s) return s;
  if (!geometry::isValidPose(T_world_submap)) {
    return Error{"addSubmap: pose of submap " + std::to_string(id) + " is not a finite rigid transform"};
  }
  std::unique_lock lock(mutex_);
  for (const auto& e : entries_) {
    if (e.id == id) return Error{"addSubmap: submap id " + std::to_string(id) + " already exists"};
  }
  entries_.push_back({id, std::move(grid), T_world_submap, T_world_submap.inverse()});
  return {};
}

Status VogMap::deform(const std::vector<geometry::Pose3>& T_world_submap) {
  std::unique_lock lock(mutex_);
  if (T_world_submap.size() != entries_.size()) {
    return Error{"deform: got " + std::to_string(T_world_submap.size()) + " poses for " +
                 std::to_string(entries_.size()) + " submaps"};
  }
  for (std::size_t i = 0; i < T_world_submap.size(); ++i) {
    if (!geometry::isValidPose(T_world_submap[i])) {
      return Error{"deform: pose " + std::to_string(i) + " (submap " + std::to_string(entries_[i].id) +
                   ") is not a finite rigid transform"};
    }
  }
  for (std::size_t i = 0; i < T_world_submap.size(); ++i) {
    entries_[i].T_world_submap = T_world_submap[i];
    entries_[i].T_submap_world = T_world_submap[i].inverse();
  }
  return {};
}

std::size_t VogMap::size() const {
  std::shared_lock lock(mutex_);
  return entries_.size();
}

std::vector<SubmapEntry> VogMap::entries() const {
  std::shared_lock lock(mutex_);
  return entries_;
}

std::vector<geometry::Pose3> VogMap::poses() const {
  std::shared_lock lock(mutex_);
  std::vector<geometry::Pose3> out;
  out.reserve(entries_.size());
  for (const auto& e : entries_) out.push_back(e.T_world_submap);
  return out;
}

VoxelValue VogMap::sumAt(const Eigen::Vector3d& p_world, const std::vector<const SubmapEntry*>& subset) const {
  double sum = 0.0;
  int known = 0;
  const double inv_res = 1.0 / config_.resolution_m;
  for (const SubmapEntry* e : subset) {
    const VoxelKey key = pointToKey(e->toSubmap(p_world), inv_res);
    if (!e->grid->knownKeys().contains(key)) continue;
    if (const auto l = e->grid->logOddsAt(key)) {
      sum += static_cast<double>(*l);
      ++known;
    }
  }
  if (known == 0) return {};
  const double clamped = bounds_.clamp(sum);
  return {clamped, bounds_.classify(clamped)};
}

VoxelValue VogMap::query(const Eigen::Vector3d& p_world) const {
  if (!p_world.allFinite()) return {};
  std::shared_lock lock(mutex_);
  std::vector<const SubmapEntry*> all;
  all.reserve(entries_.size());
  for (const auto& e : entries_) all.push_back(&e);
  return sumAt(p_world, all);
}

std::vector<const SubmapEntry*> VogMap::crossedBy(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) const {
  std::vector<const SubmapEntry*> subset;
  for (const auto& e : entries_) {
    Eigen::AlignedBox3d box = e.grid->knownBox();
    if (box.isEmpty()) continue;
    // Pad by a hair so a sample on the box face is never dropped by rounding.
    box.min().array() -= 1e-6;
    box.max().array() += 1e-6;
    if (segmentIntersectsBox(e.toSubmap(p1), e.toSubmap(p2), box)) subset.push_back(&e);
  }
  return subset;
}

std::vector<LineSample> VogMap::lineQuery(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) const {
  std::vector<LineSample> out;
  if (!p1.allFinite() || !p2.allFinite()) return out;
  const double length = (p2 - p1).norm();
  const Eigen::Vector3d v = length > 0.0 ? Eigen::Vector3d((p2 - p1) / length) : Eigen::Vector3d::Zero();
  const double step = config_.resolution_m;
  const auto n = static_cast<int>(std::floor(length / step));
  std::shared_lock lock(mutex_);
  const auto subset = crossedBy(p1, p2);
  out.reserve(static_cast<std::size_t>(n) + 1);
  for (int k = 0; k <= n; ++k) {
    const Eigen::Vector3d x = p1 + (k * step) * v;
    out.push_back({x, sumAt(x, subset)});
  }
  return out;
}

CastResult VogMap::castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& end) const {
  CastResult result;
  if (!origin.allFinite() || !end.allFinite()) return result;
  const double length = (end - origin).norm();
  const Eigen::Vector3d v = length > 0.0 ? Eigen::Vector3d((end - origin) / length) : Eigen::Vector3d::Zero();
  const double step = config_.resolution_m;
  const auto n = static_cast<int>(std::floor(length / step));
  std::shared_lock lock(mutex_);
  const auto subset = crossedBy(origin, end);
  for (int k = 0; k <= n; ++k) {
    const Eigen::Vector3d x = origin + (k * step) * v;
    const VoxelValue value = sumAt(x, subset);
    if (value.status == Occupancy::kOccupied) {
      result.hit = true;
      result.hit_world = x;
      return result;
    }
    (value.status == Occupancy::kFree ? result.n_free : result.n_unknown)++;
  }
  return result;
}

Status VogMap::save(const std::filesystem::path& dir) const {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error{"cannot create " + dir.string() + ": " + ec.message()};
  const auto entries = this->entries();
  {
    std::ofstream grid(dir / "grid.txt");
    grid << std::setprecision(17) << "resolution_m " << config_.resolution_m << "\nprob_hit " << config_.prob_hit
         << "\nprob_miss " << config_.prob_miss << "\nclamp_min " << config_.clamp_min << "\nclamp_max "
         << config_.clamp_max << "\noccupancy_threshold " << config_.occupancy_threshold << "\nmax_range_m "
         << config_.max_range_m << "\ncloud_voxel_m " << config_.cloud_voxel_m << "\nnormal_neighbours "
         << config_.normal_neighbours << "\n";
    if (!grid) return Error{"cannot write " + (dir / "grid.txt").string()};
  }
  std::ofstream poses(dir / "poses.txt");
  poses << "# id x y z qx qy qz qw (T_world_submap)\n" << std::setprecision(17);
  for (const auto& e : entries) {
    if (auto s = e.grid->save(dir / submapFileName(e.id)); !s) return s;
    const Eigen::Quaterniond q(e.T_world_submap.linear());
    const Eigen::Vector3d t = e.T_world_submap.translation();
    poses << e.id << ' ' << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' '
          << q.w() << '\n';
  }
  if (!poses) return Error{"cannot write " + (dir / "poses.txt").string()};
  return {};
}

Result<std::unique_ptr<VogMap>> VogMap::load(const std::filesystem::path& dir) {
  GridConfig config;
  {
    std::ifstream grid(dir / "grid.txt");
    if (!grid) return Error{"cannot read " + (dir / "grid.txt").string()};
    std::string key;
    int line = 0;
    while (grid >> key) {
      ++line;
      double value = 0.0;
      if (!(grid >> value))
        return Error{(dir / "grid.txt").string() + ":" + std::to_string(line) + ": bad value for " + key};
      if (key == "resolution_m")
        config.resolution_m = value;
      else if (key == "prob_hit")
        config.prob_hit = value;
      else if (key == "prob_miss")
        config.prob_miss = value;
      else if (key == "clamp_min")
        config.clamp_min = value;
      else if (key == "clamp_max")
        config.clamp_max = value;
      else if (key == "occupancy_threshold")
        config.occupancy_threshold = value;
      else if (key == "max_range_m")
        config.max_range_m = value;
      else if (key == "cloud_voxel_m")
        config.cloud_voxel_m = value;
      else if (key == "normal_neighbours")
        config.normal_neighbours = static_cast<int>(value);
      else
        return Error{(dir / "grid.txt").string() + ":" + std::to_string(line) + ": unknown key " + key};
    }
  }
  auto map = create(config);
  if (!map) return map.error();
  std::ifstream poses(dir / "poses.txt");
  if (!poses) return Error{"cannot read " + (dir / "poses.txt").string()};
  std::string text;
  int line = 0;
  while (std::getline(poses, text)) {
    ++line;
    if (text.empty() || text[0] == '#') continue;
    std::istringstream is(text);
    SubmapId id = 0;
    double x, y, z, qx, qy, qz, qw;
    if (!(is >> id >> x >> y >> z >> qx >> qy >> qz >> qw)) {
      return Error{(dir / "poses.txt").string() + ":" + std::to_string(line) + ": expected id x y z qx qy qz qw"};
    }
    const Eigen::Quaterniond q(qw, qx, qy, qz);
    if (!std::isfinite(q.norm()) || std::abs(q.norm() - 1.0) > 1e-6) {
      return Error{(dir / "poses.txt").string() + ":" + std::to_string(line) + ": quaternion is not unit"};
    }
    geometry::Pose3 T = geometry::Pose3::Identity();
    T.linear() = q.normalized().toRotationMatrix();
    T.translation() = Eigen::Vector3d(x, y, z);
    auto grid = LocalGrid::load(config, dir / submapFileName(id));
    if (!grid) return grid.error();
    if (auto s = (*map)->addSubmap(id, std::move(*grid), T); !s) return s.error();
  }
  return map;
}

}  // namespace vog::map
