#include "vog/plan/traversability.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <queue>
#include <sstream>
#include <utility>
#include <vector>

namespace vog::plan {

using map::KeyBox;
using map::MergedMap;
using map::VoxelKey;

namespace {

// Calls f for every key within `reach` voxels of centre on each axis, in (z, y, x) order.
template <typename F>
void forEachKeyWithin(const map::VoxelKey& centre, int reach, F&& f) {
  map::VoxelKey d;
  for (d.z() = -reach; d.z() <= reach; ++d.z())
    for (d.y() = -reach; d.y() <= reach; ++d.y())
      for (d.x() = -reach; d.x() <= reach; ++d.x()) f(centre + d);
}

// Does a box of half-extents h (its own frame), translated from the origin by `move`, reach the point
// q (same frame)? Some t in [0, 1] must give |q_i - t move_i| <= h_i on every axis.
bool sweptBoxReaches(const Eigen::Vector3d& q, const Eigen::Vector3d& move, const Eigen::Vector3d& h) {
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 3; ++i) {
    if (move[i] == 0.0) {
      if (std::abs(q[i]) > h[i]) return false;
      continue;
    }
    double t0 = (q[i] - h[i]) / move[i], t1 = (q[i] + h[i]) / move[i];
    if (t0 > t1) std::swap(t0, t1);
    lo = std::max(lo, t0);
    hi = std::min(hi, t1);
    if (lo > hi) return false;
  }
  return true;
}

constexpr std::size_t kMaxGridVoxels = 256u * 1024u * 1024u;
constexpr auto kFree = static_cast<std::uint8_t>(map::Occupancy::kFree);

KeyBox intersect(const KeyBox& a, const KeyBox& b) {
  KeyBox out;
  out.min = a.min.cwiseMax(b.min);
  out.max = a.max.cwiseMin(b.max);
  return out;
}

KeyBox dilate(const KeyBox& a, const Eigen::Vector3i& r) {
  KeyBox out;
  out.min = a.min - r;
  out.max = a.max + r;
  return out;
}

// Dense scratch volume over an inclusive key box.
struct Volume {
  KeyBox keys;
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  std::vector<std::uint8_t> v;

  explicit Volume(const KeyBox& k) : keys(k), size(k.max - k.min + VoxelKey::Ones()) {
    v.assign(
        static_cast<std::size_t>(size.x()) * static_cast<std::size_t>(size.y()) * static_cast<std::size_t>(size.z()),
        0);
  }
  std::size_t index(int x, int y, int z) const {
    return static_cast<std::size_t>(x - keys.min.x()) +
           static_cast<std::size_t>(size.x()) *
               (static_cast<std::size_t>(y - keys.min.y()) +
                static_cast<std::size_t>(size.y()) * static_cast<std::size_t>(z - keys.min.z()));
  }
};

// Sliding-window OR along one line: out(i) = any get(j) for j in [i - r, i + r], for i in [lo, hi].
template <class Get, class Put>
void windowOr(int lo, int hi, int r, Get&& get, Put&& put) {
  int count = 0;
  for (int j = lo - r; j <= lo + r; ++j) count += get(j);
  put(lo, count > 0);
  for (int i = lo + 1; i <= hi; ++i) {
    count += get(i + r) - get(i - 1 - r);
    put(i, count > 0);
  }
}

}  // namespace

Result<TraversabilityGrid> TraversabilityGrid::build(const MergedMap& map, const Eigen::AlignedBox3d& box_world,
                                                     const Footprint& footprint, const AssumedFree& assumed_free) {
  if (!box_world.min().allFinite() || !box_world.max().allFinite() ||
      (box_world.max().array() <= box_world.min().array()).any())
    return Error{"traversability: the exploration box is empty or not finite"};
  if (!footprint.size_m.allFinite() || (footprint.size_m.array() <= 0.0).any())
    return Error{"traversability: the footprint must be finite and > 0 on every axis"};
  if (footprint.vertical_cylinder && footprint.size_m.x() != footprint.size_m.y())
    return Error{"traversability: a cylinder's footprint has one diameter (x and y differ)"};
  TraversabilityGrid g;
  g.resolution_ = map.resolution();
  g.inv_resolution_ = 1.0 / g.resolution_;
  g.bounds_ = map.config().bounds();
  g.box_world_ = box_world;
  for (int i = 0; i < 3; ++i) {
    // A box centred anywhere in voxel v reaches at most floor(h / res) + 1 voxels past v.
    g.r_[i] = static_cast<int>(std::floor(0.5 * footprint.size_m[i] * g.inv_resolution_)) + 1;
  }
  if (footprint.vertical_cylinder) {
    const double rho = 0.5 * footprint.size_m.x() * g.inv_resolution_;
    for (int k = 0; k <= g.r_.y(); ++k) {
      const double m = std::max(k - 1, 0);
      g.disc_half_width_.push_back(static_cast<int>(std::floor(std::sqrt(std::max(rho * rho - m * m, 0.0)))) + 1);
    }
  }
  KeyBox box_keys;
  box_keys.min = map::pointToKey(box_world.min(), g.inv_resolution_);
  box_keys.max = map::pointToKey(box_world.max(), g.inv_resolution_);
  g.grid_ = dilate(box_keys, g.r_);
  g.size_ = g.grid_.max - g.grid_.min + VoxelKey::Ones();
  const double n = static_cast<double>(g.size_.x()) * g.size_.y() * g.size_.z();
  if (n > static_cast<double>(kMaxGridVoxels)) {
    std::ostringstream s;
    s << "traversability: the exploration box needs " << n << " voxels at " << g.resolution_ << " m (limit "
      << kMaxGridVoxels << ")";
    return Error{s.str()};
  }
  if (!(assumed_free.radius_m >= 0.0) || !std::isfinite(assumed_free.radius_m) ||
      !assumed_free.centre_world.allFinite())
    return Error{"traversability: the assumed-free sphere must have a finite centre and radius >= 0"};
  g.assumed_free_ = assumed_free;
  g.status_.assign(static_cast<std::size_t>(n), static_cast<std::uint8_t>(map::Occupancy::kUnknown));
  g.safe_.assign(static_cast<std::size_t>(n), 0);
  g.block_min_ = g.grid_.min.unaryExpr([](int v) { return v >> MergedMap::kBlockBits; });
  g.blocks_ = g.grid_.max.unaryExpr([](int v) { return v >> MergedMap::kBlockBits; }) - g.block_min_ + VoxelKey::Ones();
  g.stale_.assign(static_cast<std::size_t>(g.blocks_.x()) * static_cast<std::size_t>(g.blocks_.y()) *
                      static_cast<std::size_t>(g.blocks_.z()),
                  0);
  if (assumed_free.radius_m > 0.0) {
    // Voxels of blocks the map does not hold stay at this; readBlock applies the same rule.
    const Eigen::Vector3d r = Eigen::Vector3d::Constant(assumed_free.radius_m);
    KeyBox sphere;
    sphere.min = map::pointToKey(assumed_free.centre_world - r, g.inv_resolution_);
    sphere.max = map::pointToKey(assumed_free.centre_world + r, g.inv_resolution_);
    sphere = intersect(sphere, g.grid_);
    g.assumed_free_keys_ = sphere;
    VoxelKey k;
    if (!sphere.empty())
      for (k.z() = sphere.min.z(); k.z() <= sphere.max.z(); ++k.z())
        for (k.y() = sphere.min.y(); k.y() <= sphere.max.y(); ++k.y())
          for (k.x() = sphere.min.x(); k.x() <= sphere.max.x(); ++k.x())
            if (g.assumedFree(k)) g.status_[g.indexOf(k)] = kFree;
  }
  for (const auto& [origin, block] : map.blocksChangedSince(0)) g.readBlock(origin, block.get());
  g.recompute(g.grid_);
  g.map_version_ = map.version();
  g.map_writer_ = map.writerId();
  return g;
}

bool TraversabilityGrid::readBlock(const VoxelKey& origin, const MergedMap::Block* block) {
  KeyBox b;
  b.min = origin;
  b.max = origin + VoxelKey::Constant(MergedMap::kBlockSide - 1);
  const KeyBox clipped = intersect(b, grid_);
  if (clipped.empty()) return false;
  bool changed = false;
  if (clipped.min == b.min && clipped.max == b.max && intersect(b, assumed_free_keys_).empty()) {
    // The usual block (whole inside the grid, away from the assumed-free sphere): a row of 8 statuses
    // compared and written at once. A loop closure re-merges most blocks and changes few statuses.
    constexpr int kSide = MergedMap::kBlockSide;
    std::array<std::uint8_t, kSide> statuses{};  // kUnknown
    for (int zy = 0; zy < kSide * kSide; ++zy) {
      if (block != nullptr) {
        for (int x = 0; x < kSide; ++x) {
          const auto i = static_cast<std::size_t>((zy << MergedMap::kBlockBits) | x);
          statuses[static_cast<std::size_t>(x)] = static_cast<std::uint8_t>(statusOf(*block, i));
        }
      }
      std::uint8_t* row = status_.data() + indexOf(VoxelKey(origin.x(), origin.y() + (zy & (kSide - 1)),
                                                            origin.z() + (zy >> MergedMap::kBlockBits)));
      if (std::memcmp(row, statuses.data(), kSide) != 0) {
        std::memcpy(row, statuses.data(), kSide);
        changed = true;
      }
    }
  } else {
    changed = readClippedBlock(origin, block, clipped);
  }
  // A contact inside reads as changed when the map says free; it stays occupied (a needless recompute).
  for (const VoxelKey& c : contacts_)
    if (clipped.contains(c)) status_[indexOf(c)] = static_cast<std::uint8_t>(map::Occupancy::kOccupied);
  return changed;
}

map::Occupancy TraversabilityGrid::statusOf(const MergedMap::Block& block, std::size_t i) const {
  // The classification MergedMap::at makes: clamp, then threshold (thesis Eq. 3.4-3.5).
  return block.count(i) == 0 ? map::Occupancy::kUnknown : bounds_.classify(bounds_.clamp(block.sum(i)));
}

bool TraversabilityGrid::readClippedBlock(const VoxelKey& origin, const MergedMap::Block* block,
                                          const KeyBox& clipped) {
  bool changed = false;
  VoxelKey k;
  for (k.z() = clipped.min.z(); k.z() <= clipped.max.z(); ++k.z())
    for (k.y() = clipped.min.y(); k.y() <= clipped.max.y(); ++k.y()) {
      std::uint8_t* row = status_.data() + indexOf(VoxelKey(clipped.min.x(), k.y(), k.z()));
      const int block_row =
          ((k.z() - origin.z()) << (2 * MergedMap::kBlockBits)) | ((k.y() - origin.y()) << MergedMap::kBlockBits);
      for (k.x() = clipped.min.x(); k.x() <= clipped.max.x(); ++k.x()) {
        map::Occupancy status = map::Occupancy::kUnknown;
        if (block != nullptr) status = statusOf(*block, static_cast<std::size_t>(block_row + (k.x() - origin.x())));
        if (status == map::Occupancy::kUnknown && assumedFree(k)) status = map::Occupancy::kFree;
        std::uint8_t& out = row[k.x() - clipped.min.x()];
        changed = changed || out != static_cast<std::uint8_t>(status);
        out = static_cast<std::uint8_t>(status);
      }
    }
  return changed;
}

void TraversabilityGrid::addContact(const Eigen::Vector3d& p_world) {
  if (!p_world.allFinite()) return;
  const VoxelKey k = map::pointToKey(p_world, inv_resolution_);
  if (!grid_.contains(k)) return;
  if (std::find(contacts_.begin(), contacts_.end(), k) == contacts_.end()) contacts_.push_back(k);
  status_[indexOf(k)] = static_cast<std::uint8_t>(map::Occupancy::kOccupied);
  KeyBox around;
  around.min = k;
  around.max = k;
  recompute(dilate(around, r_));
}

void TraversabilityGrid::recompute(KeyBox region) const {
  region = intersect(region, grid_);
  if (region.empty()) return;
  // oy: a blocked voxel within the footprint's horizontal extent, over the region widened in z; then
  // the vertical pass on the region. Outside the grid counts as blocked.
  KeyBox b = region;
  b.min.z() -= r_.z();
  b.max.z() += r_.z();
  b = intersect(b, grid_);
  Volume oy(b);
  if (disc_half_width_.empty()) {
    // A box: separable, pass x over the region widened in y (and z), then pass y.
    KeyBox a = b;
    a.min.y() -= r_.y();
    a.max.y() += r_.y();
    a = intersect(a, grid_);
    Volume ox(a);
    for (int z = a.min.z(); z <= a.max.z(); ++z)
      for (int y = a.min.y(); y <= a.max.y(); ++y) {
        const std::size_t row = indexOf(VoxelKey(grid_.min.x(), y, z));
        windowOr(
            region.min.x(), region.max.x(), r_.x(),
            [&](int x) -> int {
              return x < grid_.min.x() || x > grid_.max.x()
                         ? 1
                         : (status_[row + static_cast<std::size_t>(x - grid_.min.x())] != kFree ? 1 : 0);
            },
            [&](int x, bool v) { ox.v[ox.index(x, y, z)] = v ? 1 : 0; });
      }
    for (int z = b.min.z(); z <= b.max.z(); ++z)
      for (int x = region.min.x(); x <= region.max.x(); ++x) {
        windowOr(
            region.min.y(), region.max.y(), r_.y(),
            [&](int y) -> int { return y < a.min.y() || y > a.max.y() ? 1 : ox.v[ox.index(x, y, z)]; },
            [&](int y, bool v) { oy.v[oy.index(x, y, z)] = v ? 1 : 0; });
      }
  } else {
    // A cylinder, per layer in O(voxels): a blocked voxel at (x', y + dy) reaches x when
    // |x - x'| <= disc_half_width_[|dy|], and the half-width shrinks as |dy| grows, so of each column
    // only the blocked voxel nearest in y matters. First, for every column, the distance in y from each
    // row of the region to the nearest blocked voxel (two sweeps); then, per row, the union of the
    // windows those voxels open in x (a difference array). The same flags as testing every row of the
    // disc for every voxel, without the factor 2 r + 1.
    const int r = r_.y();
    const int x0 = region.min.x() - r, nx = region.max.x() + r - x0 + 1;
    const int y0 = region.min.y() - r, ny = region.max.y() + r - y0 + 1;
    const auto at = [nx](int x, int y) { return static_cast<std::size_t>(y) * static_cast<std::size_t>(nx) + x; };
    const int none = r + 1;                               // no blocked voxel within r rows
    std::vector<std::uint8_t> blocked(at(0, ny));         // [y - y0][x - x0]
    std::vector<int> nearest(at(0, ny));                  // [y - y0][x - x0]: rows to the nearest blocked voxel
    std::vector<int> last(static_cast<std::size_t>(nx));  // per column: the last blocked row seen in a sweep
    std::vector<int> cover(static_cast<std::size_t>(region.max.x() - region.min.x() + 2));
    for (int z = b.min.z(); z <= b.max.z(); ++z) {
      for (int j = 0; j < ny; ++j) {
        const int y = y0 + j;
        std::uint8_t* row = blocked.data() + at(0, j);
        if (y < grid_.min.y() || y > grid_.max.y()) {
          std::fill(row, row + nx, std::uint8_t{1});
          continue;
        }
        const std::uint8_t* status = status_.data() + indexOf(VoxelKey(grid_.min.x(), y, z));
        for (int i = 0; i < nx; ++i) {
          const int x = x0 + i;
          row[i] = x < grid_.min.x() || x > grid_.max.x() || status[x - grid_.min.x()] != kFree;
        }
      }
      std::fill(last.begin(), last.end(), std::numeric_limits<int>::min() / 2);
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          if (blocked[at(i, j)] != 0) last[static_cast<std::size_t>(i)] = j;
          nearest[at(i, j)] = std::min(j - last[static_cast<std::size_t>(i)], none);
        }
      std::fill(last.begin(), last.end(), std::numeric_limits<int>::max() / 2);
      for (int j = ny - 1; j >= 0; --j)
        for (int i = 0; i < nx; ++i) {
          if (blocked[at(i, j)] != 0) last[static_cast<std::size_t>(i)] = j;
          nearest[at(i, j)] = std::min(nearest[at(i, j)], last[static_cast<std::size_t>(i)] - j);
        }
      for (int y = region.min.y(); y <= region.max.y(); ++y) {
        std::fill(cover.begin(), cover.end(), 0);
        const int* dist = nearest.data() + at(0, y - y0);
        for (int i = 0; i < nx; ++i) {
          if (dist[i] > r) continue;
          const int w = disc_half_width_[static_cast<std::size_t>(dist[i])];
          const int lo = std::max(x0 + i - w, region.min.x()), hi = std::min(x0 + i + w, region.max.x());
          if (lo > hi) continue;
          ++cover[static_cast<std::size_t>(lo - region.min.x())];
          --cover[static_cast<std::size_t>(hi + 1 - region.min.x())];
        }
        int covered = 0;
        for (int x = region.min.x(); x <= region.max.x(); ++x) {
          covered += cover[static_cast<std::size_t>(x - region.min.x())];
          oy.v[oy.index(x, y, z)] = covered > 0 ? 1 : 0;
        }
      }
    }
  }
  // The vertical pass, a layer at a time (rows stay contiguous in memory; a column-wise window would
  // stride through the whole volume): per (x, y), the number of blocked layers in [z - r_z, z + r_z].
  const int wx = region.max.x() - region.min.x() + 1;
  std::vector<int> blocked_layers(static_cast<std::size_t>(wx) *
                                  static_cast<std::size_t>(region.max.y() - region.min.y() + 1));
  auto addLayer = [&](int z, int sign) {
    int* count = blocked_layers.data();
    for (int y = region.min.y(); y <= region.max.y(); ++y, count += wx) {
      if (z < b.min.z() || z > b.max.z()) {  // outside the grid: blocked
        for (int i = 0; i < wx; ++i) count[i] += sign;
        continue;
      }
      const std::uint8_t* row = oy.v.data() + oy.index(region.min.x(), y, z);
      for (int i = 0; i < wx; ++i) count[i] += sign * row[i];
    }
  };
  for (int z = region.min.z() - r_.z(); z <= region.min.z() + r_.z(); ++z) addLayer(z, 1);
  for (int z = region.min.z(); z <= region.max.z(); ++z) {
    const int* count = blocked_layers.data();
    for (int y = region.min.y(); y <= region.max.y(); ++y, count += wx) {
      std::uint8_t* safe = safe_.data() + indexOf(VoxelKey(region.min.x(), y, z));
      for (int i = 0; i < wx; ++i) safe[i] = count[i] == 0 ? 1 : 0;
    }
    if (z == region.max.z()) break;
    addLayer(z + r_.z() + 1, 1);
    addLayer(z - r_.z(), -1);
  }
}

Result<TraversabilityUpdate> TraversabilityGrid::update(const MergedMap& newer) {
  if (newer.resolution() != resolution_) return Error{"traversability: snapshot resolution differs from the grid's"};
  if (newer.writerId() != map_writer_) return Error{"traversability: the snapshot is of another map than the grid's"};
  if (newer.version() < map_version_) {
    std::ostringstream s;
    s << "traversability: snapshot version " << newer.version() << " is older than the grid's " << map_version_;
    return Error{s.str()};
  }
  TraversabilityUpdate stats;
  if (newer.version() == map_version_) return stats;
  // The blocks of the grid whose safe flags a changed status may reach go stale (settle()).
  auto markAround = [&](const VoxelKey& origin) {
    KeyBox b;
    b.min = origin;
    b.max = origin + VoxelKey::Constant(MergedMap::kBlockSide - 1);
    const KeyBox touched = intersect(dilate(b, r_), grid_);
    if (touched.empty()) return;
    const VoxelKey lo = blockOf(touched.min);
    const VoxelKey hi = blockOf(touched.max);
    for (int z = lo.z(); z <= hi.z(); ++z)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int x = lo.x(); x <= hi.x(); ++x) {
          std::uint8_t& flag = stale_[blockIndex(VoxelKey(x, y, z))];
          if (flag != 0) continue;
          flag = 1;
          ++stale_count_;
          ++stats.blocks_stale;
        }
  };
  auto touchesGrid = [&](const VoxelKey& origin) {
    KeyBox b;
    b.min = origin;
    b.max = origin + VoxelKey::Constant(MergedMap::kBlockSide - 1);
    return !intersect(b, grid_).empty();
  };
  // Safe flags depend only on the statuses: a block whose statuses all stay (a loop closure re-merges
  // most blocks with new sums and the same statuses) needs no recompute. A block created again after
  // its removal is only in the changed list (the map drops its removal record).
  for (const VoxelKey& origin : newer.blocksRemovedSince(map_version_)) {
    if (!touchesGrid(origin)) continue;
    if (readBlock(origin, nullptr)) markAround(origin);
    ++stats.blocks_read;
  }
  for (const auto& [origin, block] : newer.blocksChangedSince(map_version_)) {
    if (!touchesGrid(origin)) continue;
    if (readBlock(origin, block.get())) markAround(origin);
    ++stats.blocks_read;
  }
  map_version_ = newer.version();
  return stats;
}

bool TraversabilityGrid::insideBox(const Eigen::Vector3d& p) const { return p.allFinite() && box_world_.contains(p); }

std::vector<std::pair<double, VoxelKey>> TraversabilityGrid::safeKeysWithin(const Eigen::Vector3d& p_world,
                                                                            double radius_m) const {
  std::vector<std::pair<double, VoxelKey>> out;
  const int reach = static_cast<int>(std::ceil(radius_m * inv_resolution_));
  forEachKeyWithin(map::pointToKey(p_world, inv_resolution_), reach, [&](const VoxelKey& k) {
    const Eigen::Vector3d c = map::keyToCentre(k, resolution_);
    const double dist = (c - p_world).norm();
    if (dist <= radius_m && insideBox(c) && isSafeKey(k)) out.emplace_back(dist, k);
  });
  // Visited in (z, y, x) order; stable_sort keeps that order for ties.
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

std::optional<Eigen::Vector3d> TraversabilityGrid::nearestSafe(const Eigen::Vector3d& p_world, double radius_m) const {
  if (!p_world.allFinite() || !(radius_m >= 0.0)) return std::nullopt;
  const auto keys = safeKeysWithin(p_world, radius_m);
  if (keys.empty()) return std::nullopt;
  return map::keyToCentre(keys.front().second, resolution_);
}

std::optional<Eigen::Vector3d> TraversabilityGrid::nearestSafeClearOfOccupied(const MergedMap& snapshot,
                                                                              const Eigen::Vector3d& p_world,
                                                                              double yaw_rad,
                                                                              const Eigen::Vector3d& box_m,
                                                                              double radius_m) const {
  if (!p_world.allFinite() || !std::isfinite(yaw_rad) || !box_m.allFinite() || !(radius_m >= 0.0)) return std::nullopt;
  // Box frame: axes u_i = R e_i. A voxel (a cube of side res) can touch the box only if its centre q
  // satisfies |u_i . (q - s)| <= h_i + res/2 (|u_i,x| + |u_i,y| + |u_i,z|) on every axis for some
  // centre s on the segment (separating axes of the box only: conservative).
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Vector3d h;
  for (int i = 0; i < 3; ++i) h[i] = 0.5 * box_m[i] + 0.5 * resolution_ * R.col(i).cwiseAbs().sum();
  // Occupied voxels that any candidate sweep could touch: within radius + the box's half-diagonal.
  std::vector<Eigen::Vector3d> occupied_box;  // q - p in the box frame
  const int reach = static_cast<int>(std::ceil((radius_m + h.norm()) * inv_resolution_));
  forEachKeyWithin(map::pointToKey(p_world, inv_resolution_), reach, [&](const VoxelKey& k) {
    const map::Occupancy s = grid_.contains(k) ? status(k) : snapshot.at(k).status;
    if (s != map::Occupancy::kOccupied) return;
    // Occupied voxels the box already overlaps at p are where the map disagrees with the vehicle (it
    // is physically there): they cannot be avoided and do not count.
    const Eigen::Vector3d q = R.transpose() * (map::keyToCentre(k, resolution_) - p_world);
    if (!sweptBoxReaches(q, Eigen::Vector3d::Zero(), h)) occupied_box.push_back(q);
  });
  for (const auto& candidate : safeKeysWithin(p_world, radius_m)) {
    const Eigen::Vector3d c = map::keyToCentre(candidate.second, resolution_);
    const Eigen::Vector3d move = R.transpose() * (c - p_world);
    const bool touches = std::any_of(occupied_box.begin(), occupied_box.end(),
                                     [&](const Eigen::Vector3d& q) { return sweptBoxReaches(q, move, h); });
    if (!touches) return c;
  }
  return std::nullopt;
}

VoxelKey TraversabilityGrid::blockOf(const VoxelKey& key) const {
  return key.unaryExpr([](int v) { return v >> MergedMap::kBlockBits; }) - block_min_;
}

std::size_t TraversabilityGrid::blockIndex(const VoxelKey& block) const {
  return static_cast<std::size_t>(block.x()) +
         static_cast<std::size_t>(blocks_.x()) *
             (static_cast<std::size_t>(block.y()) +
              static_cast<std::size_t>(blocks_.y()) * static_cast<std::size_t>(block.z()));
}

KeyBox TraversabilityGrid::blockKeys(const VoxelKey& block) const {
  KeyBox b;
  b.min = (block_min_ + block) * MergedMap::kBlockSide;
  b.max = b.min + VoxelKey::Constant(MergedMap::kBlockSide - 1);
  return b;
}

void TraversabilityGrid::settle(const VoxelKey& key) const {
  if (stale_count_ == 0) return;
  const VoxelKey block = blockOf(key);
  if (stale_[blockIndex(block)] == 0) return;
  // The stale blocks of the aligned group of kSettleBlocks^3 blocks around it, in one recompute: the
  // filter's margins are paid once for the group.
  const VoxelKey g0 = block.unaryExpr([](int v) { return v / kSettleBlocks * kSettleBlocks; });
  const VoxelKey g1 = (g0 + VoxelKey::Constant(kSettleBlocks - 1)).cwiseMin(blocks_ - VoxelKey::Ones());
  KeyBox region;
  VoxelKey b;
  for (b.z() = g0.z(); b.z() <= g1.z(); ++b.z())
    for (b.y() = g0.y(); b.y() <= g1.y(); ++b.y())
      for (b.x() = g0.x(); b.x() <= g1.x(); ++b.x()) {
        std::uint8_t& flag = stale_[blockIndex(b)];
        if (flag == 0) continue;
        flag = 0;
        --stale_count_;
        const KeyBox keys = blockKeys(b);
        region.extend(keys.min, keys.max);
      }
  recompute(region);
}

void TraversabilityGrid::settleAll() const {
  if (stale_count_ == 0) return;
  // In runs along the grid's longest axis: each run's bounding box in one pass (the separable filter's
  // margins paid once per run instead of per block), runs split where a slice across that axis holds
  // no stale block, so changes at the two ends of a long box do not make one box spanning it. The runs
  // are disjoint: the cost never exceeds a rebuild.
  int axis = 0;
  for (int i = 1; i < 3; ++i)
    if (blocks_[i] > blocks_[axis]) axis = i;
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  KeyBox run;
  auto flush = [&] {
    if (run.empty()) return;
    recompute(run);
    run = KeyBox{};
  };
  VoxelKey k;
  for (int slice = 0; slice < blocks_[axis]; ++slice) {
    bool any = false;
    k[axis] = slice;
    for (k[a2] = 0; k[a2] < blocks_[a2]; ++k[a2])
      for (k[a1] = 0; k[a1] < blocks_[a1]; ++k[a1]) {
        std::uint8_t& flag = stale_[blockIndex(k)];
        if (flag == 0) continue;
        flag = 0;
        const KeyBox keys = blockKeys(k);
        run.extend(keys.min, keys.max);
        any = true;
      }
    if (!any) flush();
  }
  flush();
  stale_count_ = 0;
}

bool TraversabilityGrid::isSafeKey(const VoxelKey& key) const {
  if (!grid_.contains(key)) return false;
  settle(key);
  return safe_[indexOf(key)] != 0;
}

bool TraversabilityGrid::isSafe(const Eigen::Vector3d& p) const {
  return insideBox(p) && isSafeKey(map::pointToKey(p, inv_resolution_));
}

bool TraversabilityGrid::edgeIsFree(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  // The exploration box is convex: both ends inside keep the whole edge inside.
  if (!insideBox(a) || !insideBox(b)) return false;
  map::VoxelWalk w = map::startVoxelWalk(a, b, resolution_, inv_resolution_);
  VoxelKey& key = w.key;
  const VoxelKey last = w.last;
  // Every voxel between the two end keys is visited at most once; the bound guards against rounding.
  const long max_steps = 3 + (last - key).cwiseAbs().sum();
  for (long n = 0; n <= max_steps; ++n) {
    if (!isSafeKey(key)) return false;
    if (key == last) return true;
    const int axis = w.nextAxis();
    if (w.t_max[axis] > 1.0) break;
    key[axis] += w.step[axis];
    w.t_max[axis] += w.t_delta[axis];
  }
  // Rounding ended the walk one step short of the end voxel: check it too.
  return isSafeKey(last);
}

Result<std::vector<Eigen::Vector3d>> TraversabilityGrid::findPath(const Eigen::Vector3d& from,
                                                                  const Eigen::Vector3d& to) const {
  if (!isSafe(from)) return Error{"path: the start is not in known free space inside the exploration box"};
  if (!isSafe(to)) return Error{"path: the goal is not in known free space inside the exploration box"};
  const VoxelKey ks = map::pointToKey(from, inv_resolution_);
  const VoxelKey kg = map::pointToKey(to, inv_resolution_);
  const std::size_t n = safe_.size();
  std::vector<float> cost(n, std::numeric_limits<float>::infinity());
  std::vector<std::int32_t> parent(n, -1);
  using Item = std::pair<float, std::int32_t>;  // (f = g + h in voxels, index)
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  auto keyOf = [&](std::size_t i) -> VoxelKey {
    const auto sx = static_cast<std::size_t>(size_.x());
    const auto sy = static_cast<std::size_t>(size_.y());
    return VoxelKey(static_cast<int>(i % sx), static_cast<int>((i / sx) % sy), static_cast<int>(i / (sx * sy))) +
           grid_.min;
  };
  auto h = [&](const VoxelKey& k) { return static_cast<float>((k - kg).cast<double>().norm()); };
  const std::size_t is = indexOf(ks);
  const std::size_t ig = indexOf(kg);
  cost[is] = 0.0F;
  open.emplace(h(ks), static_cast<std::int32_t>(is));
  // 6-connected: the segment between two face neighbours' centres stays inside the two voxels, so
  // every step is itself a free edge under edgeIsFree.
  static const VoxelKey kSteps[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  bool found = is == ig;
  while (!open.empty() && !found) {
    const auto [f, ii] = open.top();
    open.pop();
    const auto i = static_cast<std::size_t>(ii);
    const VoxelKey k = keyOf(i);
    if (f > cost[i] + h(k) + 1e-3F) continue;  // stale entry
    for (const VoxelKey& s : kSteps) {
      const VoxelKey nk = k + s;
      if (!isSafeKey(nk) || (nk != kg && !insideBox(map::keyToCentre(nk, resolution_)))) continue;
      const std::size_t j = indexOf(nk);
      const float c = cost[i] + 1.0F;
      if (c < cost[j]) {
        cost[j] = c;
        parent[j] = ii;
        if (j == ig) {
          found = true;
          break;
        }
        open.emplace(c + h(nk), static_cast<std::int32_t>(j));
      }
    }
  }
  if (!found) return Error{"path: no known-free path between start and goal"};
  std::vector<std::size_t> chain;
  for (std::int32_t i = static_cast<std::int32_t>(ig); i != -1; i = parent[static_cast<std::size_t>(i)]) {
    chain.push_back(static_cast<std::size_t>(i));
    if (static_cast<std::size_t>(i) == is) break;
  }
  std::reverse(chain.begin(), chain.end());
  // from lies in the start voxel and to in the goal voxel: they replace those voxels' centres.
  std::vector<Eigen::Vector3d> cells;
  cells.reserve(chain.size() + 1);
  cells.push_back(from);
  for (std::size_t c = 1; c + 1 < chain.size(); ++c) cells.push_back(map::keyToCentre(keyOf(chain[c]), resolution_));
  cells.push_back(to);
  // Shortcut: from each kept point, jump to the farthest point still reachable by one free edge.
  std::vector<Eigen::Vector3d> out{from};
  std::size_t i = 0;
  while (i + 1 < cells.size()) {
    std::size_t j = i + 1;
    while (j + 1 < cells.size() && edgeIsFree(cells[i], cells[j + 1])) ++j;
    out.push_back(cells[j]);
    i = j;
  }
  return out;
}

std::vector<VoxelKey> TraversabilityGrid::reachable(const Eigen::Vector3d& from_world, std::size_t max_voxels) const {
  std::vector<VoxelKey> order;
  if (!isSafe(from_world) || max_voxels == 0) return order;
  // A search that may walk the whole grid reads nearly every block: one settleAll() pays the filter's
  // margins once per run instead of once per group of blocks the walk enters.
  if (max_voxels >= safe_.size()) settleAll();
  std::vector<std::uint8_t> seen(safe_.size(), 0);
  const VoxelKey start = map::pointToKey(from_world, inv_resolution_);
  seen[indexOf(start)] = 1;
  order.push_back(start);
  static const VoxelKey kSteps[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  // The output doubles as the FIFO queue of the breadth-first search.
  for (std::size_t head = 0; head < order.size() && order.size() < max_voxels; ++head) {
    const VoxelKey k = order[head];
    for (const VoxelKey& s : kSteps) {
      const VoxelKey nk = k + s;
      if (!isSafeKey(nk) || !insideBox(map::keyToCentre(nk, resolution_))) continue;
      std::uint8_t& flag = seen[indexOf(nk)];
      if (flag != 0) continue;
      flag = 1;
      order.push_back(nk);
      if (order.size() >= max_voxels) break;
    }
  }
  return order;
}

std::size_t TraversabilityGrid::safeCount() const {
  settleAll();
  return static_cast<std::size_t>(std::count(safe_.begin(), safe_.end(), std::uint8_t{1}));
}

bool TraversabilityGrid::sameFlags(const TraversabilityGrid& other) const {
  settleAll();
  other.settleAll();
  return grid_.min == other.grid_.min && grid_.max == other.grid_.max && safe_ == other.safe_ &&
         status_ == other.status_;
}

}  // namespace vog::plan
