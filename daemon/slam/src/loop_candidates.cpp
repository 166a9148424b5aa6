#include "vog/slam/loop_candidates.hpp"

#include "vog/slam/information.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <string>

namespace vog::slam {

Status CandidateConfig::validate() const {
  if (min_index_gap < 1) {
    return Error{"candidate config: min_index_gap must be >= 1, got " + std::to_string(min_index_gap)};
  }
  return Status::success();
}

Status checkFootprint(const SubmapFootprint& s) {
  const std::string name = "loop candidates: submap " + std::to_string(s.index);
  if (!geometry::isValidPose(s.T_world_submap)) return Error{name + " has a non-finite or non-rigid pose"};
  if (!s.aabb_min_submap.allFinite() || !s.aabb_max_submap.allFinite() || !s.centroid_submap.allFinite()) {
    return Error{name + " has a non-finite bounding box or centroid"};
  }
  if ((s.aabb_min_submap.array() > s.aabb_max_submap.array()).any()) {
    return Error{name + " has a bounding box with min > max"};
  }
  return Status::success();
}

bool centroidInside(const SubmapFootprint& a, const SubmapFootprint& b) {
  const Eigen::Vector3d c_a = a.T_world_submap.inverse() * (b.T_world_submap * b.centroid_submap);
  return (c_a.array() >= a.aabb_min_submap.array()).all() && (c_a.array() <= a.aabb_max_submap.array()).all();
}

namespace {

Status checkFootprints(const std::vector<SubmapFootprint>& submaps, const CandidateConfig& config) {
  if (Status s = config.validate(); !s) return s.error();
  for (const SubmapFootprint& s : submaps) {
    if (Status st = checkFootprint(s); !st) return st;
  }
  return Status::success();
}

// The footprint's known box and centroid in world x-y (the box's bounding box over its 8 corners).
Eigen::AlignedBox2d worldBox(const SubmapFootprint& f) {
  Eigen::AlignedBox2d box;
  const Eigen::AlignedBox3d local(f.aabb_min_submap, f.aabb_max_submap);
  for (int c = 0; c < 8; ++c) {
    const auto corner = static_cast<Eigen::AlignedBox3d::CornerType>(c);
    box.extend((f.T_world_submap * local.corner(corner)).head<2>());
  }
  return box;
}

Eigen::Vector2d worldCentroid(const SubmapFootprint& f) { return (f.T_world_submap * f.centroid_submap).head<2>(); }

// Cell coordinate of v, clamped so that a key packs into 32 bits per axis.
std::int64_t cellOf(double v, double cell_m) {
  constexpr double kLimit = 1 << 30;
  return static_cast<std::int64_t>(std::clamp(std::floor(v / cell_m), -kLimit, kLimit));
}

std::uint64_t cellKey(std::int64_t ix, std::int64_t iy) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(ix)) << 32) | static_cast<std::uint32_t>(iy);
}

// Calls fn(key) for every cell the box overlaps; false (no call) when it spans more than max_cells per axis.
template <typename Fn>
bool forEachCell(const Eigen::AlignedBox2d& box, double cell_m, std::int64_t max_cells, Fn&& fn) {
  const std::int64_t x0 = cellOf(box.min().x(), cell_m), x1 = cellOf(box.max().x(), cell_m);
  const std::int64_t y0 = cellOf(box.min().y(), cell_m), y1 = cellOf(box.max().y(), cell_m);
  if (x1 - x0 >= max_cells || y1 - y0 >= max_cells) return false;
  for (std::int64_t ix = x0; ix <= x1; ++ix) {
    for (std::int64_t iy = y0; iy <= y1; ++iy) fn(cellKey(ix, iy));
  }
  return true;
}

bool spansAtMost(const Eigen::AlignedBox2d& box, double cell_m, std::int64_t max_cells) {
  return cellOf(box.max().x(), cell_m) - cellOf(box.min().x(), cell_m) < max_cells &&
         cellOf(box.max().y(), cell_m) - cellOf(box.min().y(), cell_m) < max_cells;
}

// The gate of one pair (a before b in the list): Alg. 6 lines 4-8.
bool isCandidatePair(const SubmapFootprint& a, const SubmapFootprint& b, const CandidateConfig& config) {
  if (std::llabs(a.index - b.index) < config.min_index_gap) return false;
  if (a.n_points < config.min_points || b.n_points < config.min_points) return false;
  return centroidInside(a, b) || centroidInside(b, a);
}

}  // namespace

Result<std::vector<std::pair<std::size_t, std::size_t>>> findLoopCandidates(const std::vector<SubmapFootprint>& submaps,
                                                                            const CandidateConfig& config) {
  if (Status s = checkFootprints(submaps, config); !s) return s.error();
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t i = 0; i < submaps.size(); ++i) {
    for (std::size_t j = i + 1; j < submaps.size(); ++j) {
      if (isCandidatePair(submaps[i], submaps[j], config)) pairs.emplace_back(i, j);
    }
  }
  return pairs;
}

Result<std::vector<std::size_t>> findLoopCandidatesOf(const std::vector<SubmapFootprint>& submaps, std::size_t newest,
                                                      const CandidateConfig& config) {
  if (Status s = checkFootprints(submaps, config); !s) return s.error();
  if (newest >= submaps.size()) {
    return Error{"loop candidates: newest position " + std::to_string(newest) + " is out of range (" +
                 std::to_string(submaps.size()) + " submaps)"};
  }
  std::vector<std::size_t> partners;
  const SubmapFootprint& n = submaps[newest];
  if (n.n_points < config.min_points) return partners;  // no pair with it passes line 4
  for (std::size_t k = 0; k < submaps.size(); ++k) {
    if (k == newest) continue;
    // The pair as findLoopCandidates orders it: the earlier position first.
    const bool candidate = k < newest ? isCandidatePair(submaps[k], n, config) : isCandidatePair(n, submaps[k], config);
    if (candidate) partners.push_back(k);
  }
  return partners;
}

Result<CandidateIndex> CandidateIndex::create(const CandidateConfig& gate, double cell_m, double margin_m) {
  if (Status s = gate.validate(); !s) return s.error();
  if (!(cell_m > 0.0) || !std::isfinite(cell_m) || !(margin_m > 0.0) || !std::isfinite(margin_m)) {
    return Error{"candidate index: cell_m = " + std::to_string(cell_m) + " and margin_m = " + std::to_string(margin_m) +
                 " must be finite and positive"};
  }
  return CandidateIndex(gate, cell_m, margin_m);
}

CandidateIndex::Registered CandidateIndex::grownBoxes(const SubmapFootprint& f) const {
  Registered r;
  const Eigen::Vector2d grow(margin_m_, margin_m_);
  const Eigen::AlignedBox2d box = worldBox(f);
  const Eigen::Vector2d c = worldCentroid(f);
  r.box = Eigen::AlignedBox2d(box.min() - grow, box.max() + grow);
  r.centroid = Eigen::AlignedBox2d(c - grow, c + grow);
  r.wide = !spansAtMost(r.box, cell_m_, kMaxCellsPerAxis) || !spansAtMost(r.centroid, cell_m_, kMaxCellsPerAxis);
  return r;
}

void CandidateIndex::insert(std::uint32_t position, const Registered& r) {
  if (r.wide) {
    wide_.push_back(position);
    return;
  }
  forEachCell(r.box, cell_m_, kMaxCellsPerAxis, [&](std::uint64_t key) { box_cells_[key].push_back(position); });
  forEachCell(r.centroid, cell_m_, kMaxCellsPerAxis,
              [&](std::uint64_t key) { centroid_cells_[key].push_back(position); });
}

void CandidateIndex::erase(std::uint32_t position, const Registered& r) {
  const auto remove = [position](std::vector<std::uint32_t>& v) { v.erase(std::find(v.begin(), v.end(), position)); };
  if (r.wide) {
    remove(wide_);
    return;
  }
  const auto from = [&](Cells& cells) {
    return [&cells, &remove](std::uint64_t key) {
      const auto it = cells.find(key);
      remove(it->second);
      if (it->second.empty()) cells.erase(it);
    };
  };
  forEachCell(r.box, cell_m_, kMaxCellsPerAxis, from(box_cells_));
  forEachCell(r.centroid, cell_m_, kMaxCellsPerAxis, from(centroid_cells_));
}

Status CandidateIndex::add(const SubmapFootprint& footprint) {
  if (Status s = checkFootprint(footprint); !s) return s;
  if (footprints_.size() >= std::numeric_limits<std::uint32_t>::max()) {
    return Error{"candidate index: too many submaps (" + std::to_string(footprints_.size()) + ")"};
  }
  const auto position = static_cast<std::uint32_t>(footprints_.size());
  const Registered r = grownBoxes(footprint);
  footprints_.push_back(footprint);
  registered_.push_back(r);
  insert(position, r);
  return Status::success();
}

Status CandidateIndex::setPose(std::size_t position, const geometry::Pose3& T_world_submap) {
  if (position >= footprints_.size()) {
    return Error{"candidate index: position " + std::to_string(position) + " is out of range (" +
                 std::to_string(footprints_.size()) + " submaps)"};
  }
  SubmapFootprint moved = footprints_[position];
  moved.T_world_submap = T_world_submap;
  if (Status s = checkFootprint(moved); !s) return s;
  footprints_[position] = moved;
  Registered& r = registered_[position];
  if (!r.wide && r.box.contains(worldBox(moved)) && r.centroid.contains(worldCentroid(moved))) {
    return Status::success();  // still inside the cells it is registered in
  }
  const auto p = static_cast<std::uint32_t>(position);
  erase(p, r);
  r = grownBoxes(moved);
  insert(p, r);
  return Status::success();
}

Result<std::vector<std::size_t>> CandidateIndex::candidatesOf(const SubmapFootprint& newest) const {
  if (Status s = checkFootprint(newest); !s) return s.error();
  std::vector<std::size_t> partners;
  if (newest.n_points < gate_.min_points) return partners;  // no pair with it passes line 4
  std::vector<std::uint32_t> near(wide_);
  // The new centroid inside an earlier box: that box is registered in the centroid's cell.
  const Eigen::Vector2d c = worldCentroid(newest);
  if (const auto it = box_cells_.find(cellKey(cellOf(c.x(), cell_m_), cellOf(c.y(), cell_m_)));
      it != box_cells_.end()) {
    near.insert(near.end(), it->second.begin(), it->second.end());
  }
  // An earlier centroid inside the new box: that centroid is registered in one of the box's cells.
  const bool bounded = forEachCell(worldBox(newest), cell_m_, kMaxCellsPerAxis, [&](std::uint64_t key) {
    if (const auto it = centroid_cells_.find(key); it != centroid_cells_.end()) {
      near.insert(near.end(), it->second.begin(), it->second.end());
    }
  });
  if (!bounded) {  // a box wider than the cells are worth: every earlier footprint
    near.resize(footprints_.size());
    for (std::uint32_t k = 0; k < near.size(); ++k) near[k] = k;
  }
  std::sort(near.begin(), near.end());
  near.erase(std::unique(near.begin(), near.end()), near.end());
  for (const std::uint32_t k : near) {
    if (isCandidatePair(footprints_[k], newest, gate_)) partners.push_back(k);
  }
  return partners;
}

Result<double> planarMahalanobisSquared(const geometry::Pose3& T_registered, const geometry::Pose3& T_predicted,
                                        const Eigen::Matrix3d& covariance) {
  if (!geometry::isValidPose(T_registered) || !geometry::isValidPose(T_predicted)) {
    return Error{"mahalanobis gate: pose is not a finite rigid transform"};
  }
  const auto info = informationFromCovariance(covariance, "mahalanobis gate covariance");
  if (!info) return info.error();
  Eigen::Vector3d d;
  d.head<2>() = T_registered.translation().head<2>() - T_predicted.translation().head<2>();
  d(2) = geometry::wrapAngle(geometry::yawOf(T_registered.linear()) - geometry::yawOf(T_predicted.linear()));
  return d.dot(*info * d);
}

}  // namespace vog::slam
