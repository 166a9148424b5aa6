#include "vog/map/local_grid.hpp"

#include "vog/core/atomic_file.hpp"
#include "vog/map/octree_file.hpp"

#include <nanoflann.hpp>
#include <octomap/OcTree.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cassert>
#include <bit>
#include <fstream>
#include <sstream>
#include <unordered_map>

namespace vog::map {

namespace {

constexpr int kOctoOffset = 32768;  // octomap key = voxel index + 32768 (tree_max_val at depth 16)

octomap::point3d toOcto(const Eigen::Vector3d& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

bool toOctoKey(const VoxelKey& k, octomap::OcTreeKey& out) {
  for (int i = 0; i < 3; ++i) {
    const int v = k[i] + kOctoOffset;
    if (v < 0 || v >= 2 * kOctoOffset) return false;
    out[static_cast<unsigned>(i)] = static_cast<octomap::key_type>(v);
  }
  return true;
}

struct CloudAdaptor {
  const std::vector<Eigen::Vector3d>& pts;
  std::size_t kdtree_get_point_count() const { return pts.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return pts[i][static_cast<Eigen::Index>(dim)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, CloudAdaptor>, CloudAdaptor, 3>;

}  // namespace

LocalGrid::LocalGrid(const GridConfig& config, std::unique_ptr<octomap::OcTree> tree)
    : config_(config), inv_resolution_(1.0 / config.resolution_m), tree_(std::move(tree)) {
  tree_->setProbHit(config_.prob_hit);
  tree_->setProbMiss(config_.prob_miss);
  tree_->setClampingThresMin(config_.clamp_min);
  tree_->setClampingThresMax(config_.clamp_max);
  tree_->setOccupancyThres(config_.occupancy_threshold);
}

LocalGrid::~LocalGrid() = default;

Result<std::unique_ptr<LocalGrid>> LocalGrid::create(const GridConfig& config) {
  if (auto s = config.validate(); !s) return s.error();
  return std::unique_ptr<LocalGrid>(new LocalGrid(config, std::make_unique<octomap::OcTree>(config.resolution_m)));
}

Result<std::unique_ptr<LocalGrid>> LocalGrid::fromTree(const GridConfig& config, std::unique_ptr<octomap::OcTree> tree,
                                                       std::vector<Eigen::Vector3d> sensor_origins) {
  if (auto s = config.validate(); !s) return s.error();
  if (!tree) return Error{"LocalGrid::fromTree: no tree"};
  if (std::abs(tree->getResolution() - config.resolution_m) > 1e-9) {
    return Error{"LocalGrid::fromTree: tree resolution " + std::to_string(tree->getResolution()) +
                 " differs from map resolution " + std::to_string(config.resolution_m)};
  }
  for (std::size_t i = 0; i < sensor_origins.size(); ++i) {
    if (!sensor_origins[i].allFinite()) {
      return Error{"LocalGrid::fromTree: sensor origin " + std::to_string(i) + " is not finite"};
    }
  }
  auto grid = std::unique_ptr<LocalGrid>(new LocalGrid(config, std::move(tree)));
  grid->sensor_origins_ = std::move(sensor_origins);
  grid->finalize();
  return grid;
}

Result<std::unique_ptr<LocalGrid>> LocalGrid::load(const GridConfig& config, const std::filesystem::path& ot_file,
                                                   std::vector<Eigen::Vector3d> sensor_origins) {
  std::ifstream in(ot_file, std::ios::binary);
  if (!in) return Error{"cannot open " + ot_file.string()};
  auto tree = readOcTree(in);
  if (!tree) return Error{ot_file.string() + ": " + tree.error().message};
  return fromTree(config, std::move(tree).value(), std::move(sensor_origins));
}

Result<std::unique_ptr<LocalGrid>> LocalGrid::deserialize(const GridConfig& config, std::string_view ot_bytes) {
  std::istringstream in{std::string(ot_bytes)};
  auto tree = readOcTree(in);
  if (!tree) return tree.error();
  return fromTree(config, std::move(tree).value());
}

Result<std::string> LocalGrid::serialize() const {
  if (!finalized_) return Error{"cannot serialise a local grid that is still open for scans"};
  return leaves_.writeOcTree(config_.resolution_m);
}

const octomap::OcTree& LocalGrid::tree() const {
  assert(tree_ && "a finalized LocalGrid has no OcTree");
  return *tree_;
}

std::size_t LocalGrid::residentBytes() const {
  const std::size_t per_point = sizeof(Eigen::Vector3d);
  return leaves_.memoryBytes() + per_point * (cloud_.points.capacity() + cloud_.normals.capacity()) +
         per_point * sensor_origins_.capacity();
}

Status LocalGrid::save(const std::filesystem::path& ot_file) const {
  auto bytes = serialize();
  if (!bytes) return bytes.error();
  return writeFileAtomically(ot_file, *bytes);
}

Status LocalGrid::insertScan(const geometry::Pose3& T_grid_sensor, const geometry::SonarFan& fan,
                             const geometry::RangeScan& scan) {
  if (static_cast<int>(scan.range_m.size()) != fan.n_beams) {
    return Error{"scan has " + std::to_string(scan.range_m.size()) + " beams, the sonar fan " +
                 std::to_string(fan.n_beams)};
  }
  if (!geometry::isValidPose(T_grid_sensor)) return Error{"scan pose is not a finite rigid transform"};
  std::vector<BeamEnd> beams;
  beams.reserve(scan.range_m.size());
  for (int i = 0; i < fan.n_beams; ++i) {
    const float r = scan.range_m[static_cast<std::size_t>(i)];
    if (std::isnan(r) || r < 0.0f) return Error{"beam " + std::to_string(i) + " has an invalid range"};
    if (static_cast<double>(r) < fan.min_range_m) continue;  // inside the blanking distance: no information
    const Eigen::Vector3d dir = T_grid_sensor.linear() * fan.beamDirection(i);
    const bool hit = std::isfinite(r);
    const double range = hit ? static_cast<double>(r) : config_.max_range_m;
    beams.push_back({T_grid_sensor.translation() + range * dir, hit});
  }
  return insertRays(T_grid_sensor.translation(), beams);
}

Status LocalGrid::insertRays(const Eigen::Vector3d& origin_grid, std::span<const BeamEnd> beams) {
  if (finalized_) return Error{"cannot insert into a finalized LocalGrid"};
  if (!origin_grid.allFinite()) return Error{"ray origin is not finite"};
  for (const auto& b : beams) {
    if (!b.end_grid.allFinite()) return Error{"ray end point is not finite"};
  }
  // One scan updates each voxel at most once, occupied winning over free (OctoMap's computeUpdate).
  octomap::KeySet free_keys;
  octomap::KeySet occupied_keys;
  if (!ray_) ray_ = std::make_unique<octomap::KeyRay>();
  octomap::KeyRay& ray = *ray_;
  const octomap::point3d origin = toOcto(origin_grid);
  for (const auto& b : beams) {
    Eigen::Vector3d end = b.end_grid;
    bool hit = b.hit;
    const Eigen::Vector3d delta = end - origin_grid;
    const double length = delta.norm();
    if (length > config_.max_range_m) {
      end = origin_grid + delta * (config_.max_range_m / length);
      hit = false;
    }
    if (!tree_->computeRayKeys(origin, toOcto(end), ray)) return Error{"ray leaves the addressable map volume"};
    free_keys.insert(ray.begin(), ray.end());
    if (hit) {
      octomap::OcTreeKey k;
      if (!tree_->coordToKeyChecked(toOcto(end), k)) return Error{"ray end leaves the addressable map volume"};
      occupied_keys.insert(k);
    } else {
      octomap::OcTreeKey k;
      if (tree_->coordToKeyChecked(toOcto(end), k)) free_keys.insert(k);
    }
  }
  for (const auto& k : free_keys) {
    if (occupied_keys.count(k) == 0) tree_->updateNode(k, false);
  }
  for (const auto& k : occupied_keys) tree_->updateNode(k, true);
  sensor_origins_.push_back(origin_grid);
  ++scan_count_;
  return {};
}

void LocalGrid::finalize() {
  if (finalized_) return;
  packLeaves();
  computeKnownBox();
  computeCloud();
  ray_.reset();
  tree_.reset();
  sensor_origins_.shrink_to_fit();
  finalized_ = true;
}

std::optional<float> LocalGrid::logOddsAt(const VoxelKey& key) const {
  if (finalized_) return leaves_.find(key);
  octomap::OcTreeKey k;
  if (!toOctoKey(key, k)) return std::nullopt;
  const octomap::OcTreeNode* node = tree_->search(k);
  if (node == nullptr) return std::nullopt;
  return node->getLogOdds();
}

std::optional<float> LocalGrid::logOdds(const Eigen::Vector3d& p_grid) const {
  if (!p_grid.allFinite()) return std::nullopt;
  return logOddsAt(pointToKey(p_grid, inv_resolution_));
}

namespace {

// Calls f(leaf) for every leaf of an OctoMap tree, in its depth-first order.
template <class F>
void forEachTreeLeaf(const octomap::OcTree& tree, F&& f) {
  const unsigned max_depth = tree.getTreeDepth();
  LocalGrid::Leaf leaf;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    // A leaf at depth d covers 2^(16-d) voxels per axis; its key is the voxel just above its centre.
    const int span = 1 << (max_depth - it.getDepth());
    const octomap::OcTreeKey& k = it.getKey();
    for (int i = 0; i < 3; ++i) {
      leaf.min[i] = static_cast<int>(k[static_cast<unsigned>(i)]) - kOctoOffset - span / 2;
      leaf.max[i] = leaf.min[i] + span - 1;
    }
    leaf.log_odds = it->getLogOdds();
    f(leaf);
  }
}

}  // namespace

std::vector<LocalGrid::Leaf> LocalGrid::leaves() const {
  std::vector<Leaf> out;
  const auto keep = [&](const Leaf& leaf) { out.push_back(leaf); };
  if (finalized_) {
    out.reserve(leaves_.size());
    forEachLeaf(keep);
  } else {
    forEachTreeLeaf(*tree_, keep);
  }
  return out;
}

void LocalGrid::packLeaves() {
  std::vector<PackedLeaves::Leaf> packed;
  packed.reserve(tree_->getNumLeafNodes());
  forEachTreeLeaf(*tree_, [&](const Leaf& leaf) {
    const int span_log2 = std::countr_zero(static_cast<unsigned>(leaf.max.x() - leaf.min.x() + 1));
    packed.push_back({leaf.min, span_log2, leaf.log_odds});
  });
  leaves_ = PackedLeaves::pack(std::move(packed));
}

void LocalGrid::computeKnownBox() {
  known_keys_ = KeyBox{};
  forEachLeaf([&](const Leaf& leaf) { known_keys_.extend(leaf.min, leaf.max); });
}

Eigen::AlignedBox3d LocalGrid::knownBox() const {
  if (known_keys_.empty()) return Eigen::AlignedBox3d();  // empty box
  const double r = config_.resolution_m;
  return Eigen::AlignedBox3d(known_keys_.min.cast<double>() * r,
                             (known_keys_.max.cast<double>().array() + 1.0).matrix() * r);
}

Eigen::Vector3d LocalGrid::cloudCentroid() const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : cloud_.points) sum += p;
  return cloud_.empty() ? sum : Eigen::Vector3d(sum / static_cast<double>(cloud_.size()));
}

void LocalGrid::computeCloud() {
  // Occupied voxel centres, averaged per cloud_voxel_m cell (thesis 4.2: a downsampled cloud per submap).
  struct Cell {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int n = 0;
  };
  auto hash = [](const VoxelKey& k) {
    return static_cast<std::size_t>(k.x()) * 73856093u ^ static_cast<std::size_t>(k.y()) * 19349663u ^
           static_cast<std::size_t>(k.z()) * 83492791u;
  };
  std::unordered_map<VoxelKey, Cell, decltype(hash)> cells(1024, hash);
  const double inv_cell = 1.0 / config_.cloudVoxelM();
  const double occupied = config_.bounds().occupied;
  forEachLeaf([&](const Leaf& leaf) {
    if (static_cast<double>(leaf.log_odds) <= occupied) return;
    for (int x = leaf.min.x(); x <= leaf.max.x(); ++x)
      for (int y = leaf.min.y(); y <= leaf.max.y(); ++y)
        for (int z = leaf.min.z(); z <= leaf.max.z(); ++z) {
          const Eigen::Vector3d c = keyToCentre(VoxelKey(x, y, z), config_.resolution_m);
          Cell& cell = cells[pointToKey(c, inv_cell)];
          cell.sum += c;
          ++cell.n;
        }
  });
  // Deterministic order: sort cells by key.
  std::vector<std::pair<VoxelKey, Eigen::Vector3d>> ordered;
  ordered.reserve(cells.size());
  for (const auto& [k, cell] : cells) ordered.emplace_back(k, cell.sum / cell.n);
  std::sort(ordered.begin(), ordered.end(), [](const auto& a, const auto& b) {
    return std::lexicographical_compare(a.first.data(), a.first.data() + 3, b.first.data(), b.first.data() + 3);
  });
  cloud_ = {};
  for (const auto& [k, p] : ordered) cloud_.points.push_back(p);
  if (cloud_.size() < 3) {
    cloud_.normals.assign(cloud_.size(), Eigen::Vector3d::UnitZ());
    return;
  }

  CloudAdaptor adaptor{cloud_.points};
  KdTree index(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  index.buildIndex();
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(config_.normal_neighbours), cloud_.size());
  std::vector<std::uint32_t> idx(k);
  std::vector<double> dist(k);
  // Normals are oriented towards the nearest sensor origin (the surface was seen from that side); a
  // grid read back without its origins orients them towards its base.
  CloudAdaptor origins_adaptor{sensor_origins_};
  std::optional<KdTree> origins;
  if (!sensor_origins_.empty()) {
    origins.emplace(3, origins_adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    origins->buildIndex();
  }
  cloud_.normals.resize(cloud_.size());
  for (std::size_t i = 0; i < cloud_.size(); ++i) {
    const Eigen::Vector3d& p = cloud_.points[i];
    const std::size_t n = index.knnSearch(p.data(), k, idx.data(), dist.data());
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t j = 0; j < n; ++j) mean += cloud_.points[idx[j]];
    mean /= static_cast<double>(n);
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (std::size_t j = 0; j < n; ++j) {
      const Eigen::Vector3d d = cloud_.points[idx[j]] - mean;
      cov += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    Eigen::Vector3d normal = eig.eigenvectors().col(0);
    Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
    if (origins) {
      std::uint32_t nearest = 0;
      double d2 = 0.0;
      origins->knnSearch(p.data(), 1, &nearest, &d2);
      viewpoint = sensor_origins_[nearest];
    }
    if (normal.dot(viewpoint - p) < 0.0) normal = -normal;
    cloud_.normals[i] = normal.normalized();
  }
}

}  // namespace vog::map
