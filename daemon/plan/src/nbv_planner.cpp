#include "vog/plan/nbv_planner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <iomanip>
#include <sstream>
#include <utility>

namespace vog::plan {

namespace {

std::string describe(const Eigen::Vector3d& p) {
  std::ostringstream s;
  s << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return s.str();
}

std::string metres(double m) {
  std::ostringstream s;
  s << std::setprecision(3) << m << " m";
  return s.str();
}

bool inBox(const PlannerConfig& c, const Eigen::Vector3d& p) {
  return (p.array() >= c.box_min_world_m.array()).all() && (p.array() <= c.box_max_world_m.array()).all();
}

std::string outsideBox(const char* what, const PlannerConfig& c, const Eigen::Vector3d& p) {
  return std::string(what) + " " + describe(p) + " is outside the exploration box plan.box_min_world_m " +
         describe(c.box_min_world_m) + " .. plan.box_max_world_m " + describe(c.box_max_world_m);
}

// Greedy thinning in the given order: a voxel is kept when no kept voxel and no voxel of `taken` lies
// closer than spacing_vox (in voxels) to it. Each kept or taken voxel marks the ball around it in a
// dense mask over `box`, so each test is one lookup.
std::vector<map::VoxelKey> spreadOut(const std::vector<map::VoxelKey>& keys, const std::vector<map::VoxelKey>& taken,
                                     double spacing_vox, const map::KeyBox& box) {
  const int r = static_cast<int>(std::ceil(spacing_vox));
  std::vector<map::VoxelKey> ball;
  for (int z = -r; z <= r; ++z)
    for (int y = -r; y <= r; ++y)
      for (int x = -r; x <= r; ++x)
        if (static_cast<double>(x * x + y * y + z * z) < spacing_vox * spacing_vox) ball.emplace_back(x, y, z);
  const Eigen::Vector3i size = box.max - box.min + map::VoxelKey::Ones();
  std::vector<std::uint8_t> near(static_cast<std::size_t>(size.prod()), 0);
  auto indexOf = [&](const map::VoxelKey& k) {
    const map::VoxelKey d = k - box.min;
    return static_cast<std::size_t>(d.x() + size.x() * (d.y() + size.y() * d.z()));
  };
  auto mark = [&](const map::VoxelKey& k) {
    for (const map::VoxelKey& o : ball)
      if (box.contains(k + o)) near[indexOf(k + o)] = 1;
  };
  for (const map::VoxelKey& t : taken) mark(t);
  std::vector<map::VoxelKey> kept;
  for (const map::VoxelKey& k : keys) {
    if (!box.contains(k) || near[indexOf(k)]) continue;
    mark(k);
    kept.push_back(k);
  }
  return kept;
}

}  // namespace

const char* toString(PlanStatus status) {
  switch (status) {
    case PlanStatus::kExplore: return "explore";
    case PlanStatus::kComplete: return "complete";
    case PlanStatus::kNearHome: return "near_home";
    case PlanStatus::kNoPath: break;
  }
  return "no_path";
}

Result<std::unique_ptr<NbvPlanner>> NbvPlanner::create(const PlannerConfig& config, const Waypoint& home) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  if (!home.p_world.allFinite() || !std::isfinite(home.yaw_rad))
    return Error{"plan: home pose " + describe(home.p_world) + " yaw " + std::to_string(home.yaw_rad) +
                 " is not finite"};
  if (!inBox(config, home.p_world)) return Error{outsideBox("plan: home position", config, home.p_world)};
  return std::unique_ptr<NbvPlanner>(new NbvPlanner(config, home));
}

NbvPlanner::NbvPlanner(const PlannerConfig& config, const Waypoint& home)
    : config_(config), home_(home), rng_(config.seed) {}

double NbvPlanner::edgeCost(const Waypoint& a, const Waypoint& b) const {
  const double translate_s = (b.p_world - a.p_world).norm() / config_.v_max_mps;
  const double turn_s = std::abs(geometry::wrapAngle(b.yaw_rad - a.yaw_rad)) / config_.yaw_rate_radps;
  return config_.v_max_mps * std::max(translate_s, turn_s);
}

bool NbvPlanner::headingOk(const Waypoint& from, const Waypoint& to) const {
  if (!config_.constrained_sampling) return true;
  return std::abs(geometry::wrapAngle(to.yaw_rad - from.yaw_rad)) <= config_.max_heading_change_rad + 1e-12;
}

Status NbvPlanner::syncTraversability(const map::MergedMap& map) {
  if (!gain_ || resolution_m_ != map.resolution()) {
    auto gain = SonarGain::create(config_, map.resolution());
    if (!gain.ok()) return gain.error();
    gain_.emplace(std::move(gain.value()));
    grid_.reset();
    resolution_m_ = map.resolution();
  }
  if (grid_) {
    // A snapshot of another writer (a restart, or a map rebuilt from scratch) or an older one cannot
    // be caught up with: rebuild.
    if (grid_->update(map).ok()) return {};
  }
  const Eigen::AlignedBox3d box(config_.box_min_world_m, config_.box_max_world_m);
  auto built = TraversabilityGrid::build(map, box, anyHeadingFootprint(config_.collision_box_m, config_.clearance_m),
                                         {home_.p_world, config_.assume_free_radius_m});
  if (!built.ok()) return built.error();
  grid_.emplace(std::move(built.value()));
  for (const Eigen::Vector3d& c : contacts_) grid_->addContact(c);
  return {};
}

std::optional<Eigen::Vector3d> NbvPlanner::reportObstruction(const Eigen::Vector3d& p_world,
                                                             const Eigen::Vector3d& target_world) {
  if (!p_world.allFinite() || !target_world.allFinite()) return std::nullopt;
  Eigen::Vector3d d = target_world - p_world;
  d.z() = 0.0;  // depth is held by the vehicle; what stopped it was ahead
  if (d.norm() < 1e-6) return std::nullopt;
  pending_retreat_ = p_world - config_.obstruction_retreat_m * d.normalized();
  seed_branch_.clear();
  const Eigen::Vector3d contact = p_world + 0.5 * config_.collision_box_m.head<2>().norm() * d.normalized();
  if (contacts_.size() == kMaxContacts) contacts_.erase(contacts_.begin());
  contacts_.push_back(contact);
  if (grid_) grid_->addContact(contact);
  return pending_retreat_;
}

void NbvPlanner::addNode(const map::MergedMap& map, int parent, const Waypoint& w, bool seeded) {
  const TreeNode& p = tree_[static_cast<std::size_t>(parent)];
  TreeNode n;
  n.w = w;
  n.parent = parent;
  n.seeded = seeded;
  n.cost_m = p.cost_m + edgeCost(p.w, w);
  n.gain = config_.gain_along_edge ? gain_->segmentGain(map, p.w, w, &*grid_) : gain_->segmentGain(map, w, w, &*grid_);
  // Bircher 2016 Eq. 1: gain discounted by the cost of the path from the root.
  n.value = p.value + n.gain * std::exp(-config_.lambda * n.cost_m);
  tree_.push_back(n);
}

Footprint anyHeadingFootprint(const Eigen::Vector3d& collision_box_m, double clearance_m) {
  return Footprint::cylinder(collision_box_m.head<2>().norm() + 2.0 * clearance_m, collision_box_m.z());
}

Status NbvPlanner::prepare(const std::shared_ptr<const map::MergedMap>& snapshot, const Waypoint& current,
                           const char* what) {
  if (!snapshot) return Error{std::string(what) + ": no map snapshot was given"};
  const map::MergedMap& map = *snapshot;
  if (!current.p_world.allFinite() || !std::isfinite(current.yaw_rad))
    return Error{std::string(what) + ": current pose " + describe(current.p_world) + " yaw " +
                 std::to_string(current.yaw_rad) + " is not finite"};
  // A loop closure can move the estimate outside the box: within root_tolerance_m the tree grows from
  // the nearest safe position inside it, within recovery_radius_m the vehicle moves back in (below).
  const Eigen::AlignedBox3d box(config_.box_min_world_m, config_.box_max_world_m);
  if (box.exteriorDistance(current.p_world) > std::max(config_.root_tolerance_m, config_.recovery_radius_m))
    return Error{outsideBox((std::string(what) + ": current position").c_str(), config_, current.p_world)};
  if (map.query(current.p_world).status == map::Occupancy::kOccupied)
    return Error{std::string(what) + ": current position " + describe(current.p_world) +
                 " is inside an obstacle (occupied voxel)"};
  return syncTraversability(map);
}

PlanResult NbvPlanner::fromRoot(const Waypoint& root, const Waypoint& current, PlanResult result) {
  if (result.status == PlanStatus::kNoPath || root.p_world == current.p_world) return result;
  std::vector<Waypoint> w{Waypoint{root.p_world, current.yaw_rad}};
  for (const Waypoint& x : result.waypoints) w.push_back(x);
  result.waypoints = std::move(w);
  return result;
}

Result<PlanResult> NbvPlanner::planHome(const std::shared_ptr<const map::MergedMap>& snapshot,
                                        const Waypoint& current) {
  if (Status s = prepare(snapshot, current, "plan home"); !s.ok()) return s.error();
  PlanResult result;
  result.map_version = snapshot->version();
  result.reason = "return home";
  // Stopped by an obstruction: back off the way the vehicle came first, then home from there.
  Waypoint from = current;
  const std::optional<Eigen::Vector3d> back = std::exchange(pending_retreat_, std::nullopt);
  if (back) from.p_world = *back;
  Waypoint start = from;
  if (!grid_->isSafe(from.p_world)) {
    const auto snapped = grid_->nearestSafe(from.p_world, config_.root_tolerance_m);
    if (!snapped) {
      result.reason +=
          "; the position " + describe(from.p_world) + " is not within plan.root_tolerance_m of a safe voxel";
      return result;
    }
    start.p_world = *snapped;
  }
  result = fromRoot(start, from, goHome(start, std::move(result)));
  if (back && result.status != PlanStatus::kNoPath) {
    std::vector<Waypoint> waypoints{from};
    waypoints.insert(waypoints.end(), result.waypoints.begin(), result.waypoints.end());
    result.waypoints = std::move(waypoints);
  }
  return result;
}

Result<PlanResult> NbvPlanner::plan(const std::shared_ptr<const map::MergedMap>& snapshot, const Waypoint& current) {
  if (Status s = prepare(snapshot, current, "plan"); !s.ok()) return s.error();
  const map::MergedMap& map = *snapshot;

  PlanResult result;
  result.map_version = map.version();
  tree_.clear();
  // A plan that is one straight move keeping the heading (no tree beyond the current pose).
  auto moveTo = [&](const Eigen::Vector3d& target, std::string reason) {
    result.status = PlanStatus::kExplore;
    result.waypoints = {Waypoint{target, current.yaw_rad}};
    result.best_branch = {current, result.waypoints.front()};
    result.tree_size = 1;
    result.reason = std::move(reason);
    tree_.push_back(TreeNode{current, -1, 0.0, 0.0, 0.0, false});
    return result;
  };
  if (const std::optional<Eigen::Vector3d> back = std::exchange(pending_retreat_, std::nullopt)) {
    // Stopped by an obstruction: first back off the way the vehicle came (the one direction known
    // to be clear), then plan from there.
    return moveTo(*back, "backing off an obstruction to " + describe(*back));
  }
  std::vector<Waypoint> seed;
  seed.swap(seed_branch_);
  // The vehicle stops within its navigation and control error of the safe waypoint it was sent to,
  // possibly just outside the safe voxels: the tree grows from the nearest safe position within
  // root_tolerance_m.
  Waypoint start = current;
  if (!grid_->isSafe(current.p_world)) {
    const auto snapped = grid_->nearestSafe(current.p_world, config_.root_tolerance_m);
    if (!snapped) {
      // Farther from the safe voxels than the vehicle can have strayed: a loop closure moved the map
      // around it, typically nearer a surface than the estimate had it. It is physically where it was a
      // moment ago, so it moves straight (keeping its heading) to the nearest safe voxel that its box
      // reaches without touching an occupied voxel.
      if (const auto escape = grid_->nearestSafeClearOfOccupied(map, current.p_world, current.yaw_rad,
                                                                config_.collision_box_m, config_.recovery_radius_m)) {
        return moveTo(*escape, "recovering: the current position " + describe(current.p_world) +
                                   " is not in the safe region; moving to " + describe(*escape));
      }
      result.status = PlanStatus::kNoPath;
      result.tree_size = 1;
      result.reason = "the collision box at the current position " + describe(current.p_world) +
                      " is not entirely in known free space (nor within plan.root_tolerance_m, and no safe voxel"
                      " within plan.recovery_radius_m is reachable clear of occupied space)";
      return result;
    }
    start.p_world = *snapped;
  }
  // The vehicle is sent to the tree's root first when it was snapped to a safe voxel.
  auto fromRoot = [&](PlanResult r) { return NbvPlanner::fromRoot(start, current, std::move(r)); };
  tree_.push_back(TreeNode{start, -1, 0.0, 0.0, 0.0, false});
  if (std::vector<Waypoint> views = std::exchange(revisit_views_, {}); !views.empty()) {
    if (revisit(start, std::move(views), result)) {
      seed_branch_.clear();
      return fromRoot(std::move(result));
    }
  }

  // Seed: the rest of the last best branch, as long as its edges are still free (Bircher 2016).
  int parent = 0;
  for (const Waypoint& w : seed) {
    const Waypoint& from = tree_[static_cast<std::size_t>(parent)].w;
    if (!headingOk(from, w) || !grid_->edgeIsFree(from.p_world, w.p_world)) break;
    addNode(map, parent, w, true);
    parent = static_cast<int>(tree_.size()) - 1;
  }

  const Eigen::Vector3d root = start.p_world;
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::uniform_real_distribution<double> ux(config_.box_min_world_m.x(), config_.box_max_world_m.x());
  std::uniform_real_distribution<double> uy(config_.box_min_world_m.y(), config_.box_max_world_m.y());
  std::uniform_real_distribution<double> uz(config_.box_min_world_m.z(), config_.box_max_world_m.z());
  std::uniform_real_distribution<double> uyaw(-config_.max_heading_change_rad, config_.max_heading_change_rad);
  std::uniform_real_distribution<double> uyaw_any(-std::numbers::pi, std::numbers::pi);
  auto bestValue = [&] {
    double v = 0.0;
    for (std::size_t i = 1; i < tree_.size(); ++i) v = std::max(v, tree_[i].value);
    return v;
  };
  double best_value = bestValue();
  int samples = 0;
  while (samples < config_.max_samples) {
    const int nodes = static_cast<int>(tree_.size()) - 1;
    if (nodes >= config_.n_tol) break;
    if (nodes >= config_.n_max && best_value > config_.gain_threshold) break;
    ++samples;
    // Thesis 4.5.3: x-y at the current depth, or z at the current x-y. Every draw happens whether or
    // not the sample is kept, so the sequence depends only on the seed and the number of samples.
    // Unconstrained (Bircher 2016): anywhere in the box, any heading.
    const bool constrained = config_.constrained_sampling;
    const bool horizontal = u01(rng_) < config_.xy_sample_share;
    const double sx = ux(rng_);
    const double sy = uy(rng_);
    const double sz = uz(rng_);
    const double dyaw = constrained ? uyaw(rng_) : uyaw_any(rng_);
    const Eigen::Vector3d target = !constrained ? Eigen::Vector3d(sx, sy, sz)
                                   : horizontal ? Eigen::Vector3d(sx, sy, root.z())
                                                : Eigen::Vector3d(root.x(), root.y(), sz);
    int nearest = -1;
    double nearest_d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < tree_.size(); ++i) {
      const Eigen::Vector3d& p = tree_[i].w.p_world;
      const bool eligible = !constrained || (horizontal ? p.z() == root.z() : (p.x() == root.x() && p.y() == root.y()));
      if (!eligible) continue;
      const double d = (target - p).norm();
      if (d < nearest_d) {
        nearest_d = d;
        nearest = static_cast<int>(i);
      }
    }
    // Too short an edge sees nothing new and wastes a node.
    if (nearest < 0 || nearest_d < resolution_m_) continue;
    const TreeNode& near = tree_[static_cast<std::size_t>(nearest)];
    Eigen::Vector3d end = target;
    if (nearest_d > config_.max_edge_m) {
      end = near.w.p_world + (target - near.w.p_world) * (config_.max_edge_m / nearest_d);
      // Keep the constrained coordinates exact (no rounding drift off the plane or the vertical).
      if (constrained && horizontal)
        end.z() = root.z();
      else if (constrained)
        end.head<2>() = root.head<2>();
    }
    if (!grid_->edgeIsFree(near.w.p_world, end)) continue;
    const Waypoint w{end, geometry::wrapAngle(near.w.yaw_rad + dyaw)};
    addNode(map, nearest, w, false);
    best_value = std::max(best_value, tree_.back().value);
  }
  result.samples = samples;
  result.tree_size = static_cast<int>(tree_.size());
  if (tree_.size() == 1) {
    result.reason = "no collision-free edge from the current position " + describe(root) + " in " +
                    std::to_string(samples) + " samples";
    return fromRoot(globalGoalOrHome(map, start, std::move(result), false));
  }
  std::size_t best = 1;
  for (std::size_t i = 2; i < tree_.size(); ++i)
    if (tree_[i].value > tree_[best].value) best = i;
  result.best_value = tree_[best].value;
  result.best_gain = tree_[best].gain;
  if (result.best_value <= config_.gain_threshold) {
    std::ostringstream s;
    s << "best branch value " << result.best_value << " <= plan.gain_threshold " << config_.gain_threshold << " after "
      << result.tree_size << " nodes";
    result.reason = s.str();
    return fromRoot(globalGoalOrHome(map, start, std::move(result), true));
  }
  // Indices from the best node back to the root (at least two: best >= 1).
  std::vector<std::size_t> chain;
  for (int i = static_cast<int>(best); i != -1; i = tree_[static_cast<std::size_t>(i)].parent)
    chain.push_back(static_cast<std::size_t>(i));
  result.status = PlanStatus::kExplore;
  for (auto it = chain.rbegin(); it != chain.rend(); ++it) result.best_branch.push_back(tree_[*it].w);
  result.waypoints.push_back(tree_[chain[chain.size() - 2]].w);
  seed_branch_.clear();
  for (std::size_t k = 2; k < result.best_branch.size(); ++k) seed_branch_.push_back(result.best_branch[k]);
  return fromRoot(std::move(result));
}

std::vector<Waypoint> NbvPlanner::alongPath(const std::vector<Eigen::Vector3d>& points, double start_yaw,
                                            double goal_yaw) const {
  std::vector<Waypoint> out;
  double yaw = start_yaw;
  auto turnToward = [&](double target) {
    const double d = geometry::wrapAngle(target - yaw);
    yaw = geometry::wrapAngle(yaw + std::clamp(d, -config_.max_heading_change_rad, config_.max_heading_change_rad));
    return yaw;
  };
  for (std::size_t i = 1; i < points.size(); ++i) out.push_back({points[i], turnToward(goal_yaw)});
  while (std::abs(geometry::wrapAngle(goal_yaw - yaw)) > 1e-12) out.push_back({points.back(), turnToward(goal_yaw)});
  if (!out.empty()) out.back().yaw_rad = geometry::wrapAngle(goal_yaw);
  return out;
}

void NbvPlanner::requestRevisit(std::vector<Waypoint> views) {
  std::erase_if(views, [](const Waypoint& w) { return !w.p_world.allFinite() || !std::isfinite(w.yaw_rad); });
  revisit_views_ = std::move(views);
}

bool NbvPlanner::revisit(const Waypoint& start, std::vector<Waypoint> views, PlanResult& result) const {
  if (views.size() > kMaxRevisitTries) views.resize(kMaxRevisitTries);
  for (const Waypoint& view : views) {
    const std::optional<Eigen::Vector3d> goal = grid_->nearestSafe(view.p_world, config_.root_tolerance_m);
    if (!goal) continue;
    auto path = grid_->findPath(start.p_world, *goal);
    if (!path.ok()) continue;
    std::vector<Waypoint> waypoints = alongPath(path.value(), start.yaw_rad, view.yaw_rad);
    if (waypoints.empty()) continue;  // already there, facing that way
    result.status = PlanStatus::kExplore;
    result.waypoints = std::move(waypoints);
    result.best_branch.assign(1, start);
    for (const Waypoint& x : result.waypoints) result.best_branch.push_back(x);
    result.tree_size = 1;
    std::ostringstream s;
    s << "revisit " << describe(view.p_world) << " yaw " << view.yaw_rad << " at " << describe(*goal);
    result.reason = s.str();
    return true;
  }
  return false;
}

bool NbvPlanner::globalGoal(const map::MergedMap& map, const Waypoint& start, PlanResult& result) {
  const std::vector<map::VoxelKey> reach = grid_->reachable(start.p_world, grid_->statusArray().size());
  // Candidate views: the reachable safe voxels thinned to global_spacing_m apart, nearest first
  // (breadth-first order), so a reachable region of any shape has some (an absolute lattice can miss
  // a thin one entirely). A goal reached before whose gain did not go away (unknown voxels the fan
  // cannot resolve) is not chosen again, nor anything within the spacing of it: the search cannot loop.
  std::vector<map::VoxelKey> taken;
  for (const Eigen::Vector3d& g : global_goals_) taken.push_back(map::pointToKey(g, 1.0 / resolution_m_));
  std::vector<Eigen::Vector3d> candidates;
  for (const map::VoxelKey& k : spreadOut(reach, taken, config_.global_spacing_m / resolution_m_, grid_->gridKeys()))
    candidates.push_back(map::keyToCentre(k, resolution_m_));
  // More candidates than evaluations allowed: every stride-th, so the whole reachable space is
  // sampled (nearest first) rather than only its nearest part.
  const std::size_t max_candidates = static_cast<std::size_t>(config_.global_max_candidates);
  const std::size_t stride = std::max<std::size_t>(1, (candidates.size() + max_candidates - 1) / max_candidates);
  int evaluated = 0;
  for (std::size_t i = 0; i < candidates.size(); i += stride) {
    const Eigen::Vector3d& c = candidates[i];
    ++evaluated;
    // The fan at 8 headings (the vehicle can face any of them on arrival); at the vehicle's own voxel
    // only the 7 it does not face (the view it faces is the one its sonar already has).
    const bool here = (c - start.p_world).norm() < resolution_m_;
    double best_gain = 0.0;
    double best_yaw = start.yaw_rad;
    for (int h = here ? 1 : 0; h < 8; ++h) {
      const Waypoint w{c, geometry::wrapAngle(start.yaw_rad + h * std::numbers::pi / 4)};
      const double g = gain_->segmentGain(map, w, w, &*grid_);
      if (g > best_gain) {
        best_gain = g;
        best_yaw = w.yaw_rad;
      }
    }
    if (best_gain <= config_.global_min_gain) continue;
    auto path = grid_->findPath(start.p_world, c);
    if (!path.ok()) continue;  // reachable by construction; kept as a guard
    global_goals_.push_back(c);
    seed_branch_.clear();
    result.status = PlanStatus::kExplore;
    result.global_goal = true;
    result.global_candidates = evaluated;
    result.best_gain = best_gain;
    double length_m = 0.0;
    for (std::size_t j = 1; j < path.value().size(); ++j) length_m += (path.value()[j] - path.value()[j - 1]).norm();
    result.best_value = best_gain * std::exp(-config_.lambda * length_m);
    result.waypoints = alongPath(path.value(), start.yaw_rad, best_yaw);
    result.best_branch.assign(1, start);
    for (const Waypoint& x : result.waypoints) result.best_branch.push_back(x);
    std::ostringstream s;
    s << "global goal " << describe(c) << " (fan gain " << best_gain << ", " << evaluated
      << " candidates) after: " << result.reason;
    result.reason = s.str();
    return true;
  }
  result.global_candidates = evaluated;
  return false;
}

PlanResult NbvPlanner::globalGoalOrHome(const map::MergedMap& map, const Waypoint& start, PlanResult result,
                                        bool tree_has_edge) {
  if (config_.global_search) {
    if (globalGoal(map, start, result)) return result;
    if (!tree_has_edge)
      result.reason += "; no reachable view left (" + std::to_string(result.global_candidates) + " candidates)";
  }
  // Without an edge, only the global search, which saw every safe voxel reachable from here, says the
  // exploration is over (in a region too narrow for the tree's edges); the vehicle came in, so
  // usually there is a way back. Boxed in at home it cannot move at all.
  const bool at_home = (home_.p_world - start.p_world).norm() < resolution_m_;
  if (!tree_has_edge && (!config_.global_search || at_home)) {
    result.status = PlanStatus::kNoPath;
    return result;
  }
  return goHome(start, std::move(result));
}

PlanResult NbvPlanner::goHome(const Waypoint& current, PlanResult result) const {
  auto path = grid_->findPath(current.p_world, home_.p_world);
  if (path.ok()) {
    result.status = PlanStatus::kComplete;
    // Headings turn toward the home heading by at most the allowed change per waypoint (thesis 4.5.3).
    result.waypoints = alongPath(path.value(), current.yaw_rad, home_.yaw_rad);
    if (result.waypoints.empty()) result.waypoints.push_back(home_);
    return result;
  }
  // Home is not reachable through known free space (not safe itself, or cut off): the reachable safe
  // voxel nearest to it (the breadth-first order makes the fewest steps win a tie).
  const double res = grid_->resolution();
  std::optional<Eigen::Vector3d> nearest;
  double nearest_m = 0.0;
  for (const map::VoxelKey& k : grid_->reachable(current.p_world, grid_->statusArray().size())) {
    const Eigen::Vector3d c = map::keyToCentre(k, res);
    const double d = (c - home_.p_world).norm();
    if (!nearest || d < nearest_m) {
      nearest = c;
      nearest_m = d;
    }
  }
  auto near = nearest ? grid_->findPath(current.p_world, *nearest) : path;
  if (!near.ok()) {
    result.status = PlanStatus::kNoPath;
    result.reason += "; exploration is complete but there is no way home: " + path.error().message;
    return result;
  }
  result.status = PlanStatus::kNearHome;
  result.reason += "; home " + describe(home_.p_world) + " is not reachable through known free space (" +
                   path.error().message + "): going to " + describe(*nearest) +
                   ", the reachable safe position nearest to it (" + metres(nearest_m) + " away)";
  result.waypoints = alongPath(near.value(), current.yaw_rad, home_.yaw_rad);
  if (result.waypoints.empty()) result.waypoints.push_back({*nearest, home_.yaw_rad});
  return result;
}

}  // namespace vog::plan
