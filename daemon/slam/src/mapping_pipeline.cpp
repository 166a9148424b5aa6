#include "vog/slam/mapping_pipeline.hpp"

#include "vog/slam/information.hpp"
#include "vog/slam/pose_vector.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <utility>

namespace vog::slam {

Status MappingPipelineConfig::validate() const {
  if (Status s = builder.validate(); !s.ok()) return Error{"mapping config: builder: " + s.error().message};
  if (Status s = loop_closer.validate(); !s.ok()) return Error{"mapping config: loop_closer: " + s.error().message};
  if (Status s = graph.validate(); !s.ok()) return Error{"mapping config: graph: " + s.error().message};
  if (!std::isfinite(depth_stddev_m) || depth_stddev_m <= 0.0) {
    std::ostringstream os;
    os << "mapping config: depth_stddev_m = " << depth_stddev_m << " must be > 0";
    return Error{os.str()};
  }
  if (!std::isfinite(roll_pitch_stddev_rad) || roll_pitch_stddev_rad <= 0.0) {
    std::ostringstream os;
    os << "mapping config: roll_pitch_stddev_rad = " << roll_pitch_stddev_rad << " must be > 0";
    return Error{os.str()};
  }
  if (!(consistency_confidence >= 0.0 && consistency_confidence < 1.0)) {
    std::ostringstream os;
    os << "mapping config: consistency_confidence = " << consistency_confidence << " must be in [0, 1)";
    return Error{os.str()};
  }
  if (!(consistency_floor_m >= 0.0) || !std::isfinite(consistency_floor_m) || !(consistency_floor_rad >= 0.0) ||
      !std::isfinite(consistency_floor_rad)) {
    std::ostringstream os;
    os << "mapping config: consistency_floor_m = " << consistency_floor_m
       << " and consistency_floor_rad = " << consistency_floor_rad << " must be finite and >= 0";
    return Error{os.str()};
  }
  if (consistency_recheck && !(consistency_confidence > 0.0)) {
    return Error{"mapping config: consistency_recheck needs consistency_confidence > 0"};
  }
  if (recheck_max_solves < 1) {
    return Error{"mapping config: recheck_max_solves = " + std::to_string(recheck_max_solves) + " must be >= 1"};
  }
  if (local_optimization_nodes < 0 || full_optimization_every < 1) {
    std::ostringstream os;
    os << "mapping config: local_optimization_nodes = " << local_optimization_nodes
       << " must be >= 0 and full_optimization_every = " << full_optimization_every << " >= 1";
    return Error{os.str()};
  }
  return Status::success();
}

double closureConsistencyChi2(const PartialLoopClosure& closure, const geometry::Pose3& T_world_from,
                              const geometry::Pose3& T_world_to, double floor_m, double floor_rad) {
  Vector6d e = toXyzRpy(T_world_from.inverse() * T_world_to) - closure.x_icp;
  for (int i = kRoll; i <= kYaw; ++i) e(i) = geometry::wrapAngle(e(i));
  const Eigen::VectorXd r = closure.V_u * e;
  Vector6d floor_var;
  floor_var << floor_m * floor_m, floor_m * floor_m, floor_m * floor_m, floor_rad * floor_rad, floor_rad * floor_rad,
      floor_rad * floor_rad;
  const Eigen::MatrixXd S = closure.covariance + closure.V_u * floor_var.asDiagonal() * closure.V_u.transpose();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
  return r.dot(ldlt.solve(r));
}

double chiSquareQuantile(int k, double p) {
  // The chi-square CDF of k degrees of freedom by its series (regularised lower incomplete gamma),
  // inverted by bisection: exact to 1e-9, enough for a threshold.
  const auto cdf = [k](double x) {
    const double a = 0.5 * k, h = 0.5 * x;
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 500 && term > 1e-15 * sum; ++n) {
      term *= h / (a + n);
      sum += term;
    }
    return std::exp(a * std::log(h) - h - std::lgamma(a)) * sum;
  };
  double lo = 0.0, hi = 1000.0;
  for (int it = 0; it < 200 && hi - lo > 1e-9; ++it) {
    const double mid = 0.5 * (lo + hi);
    (cdf(mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

namespace {

// The chi-square quantiles at confidence p by rank 1..6 (index 0 unused); zeros when p is 0 (no check).
std::array<double, 7> quantilesByRank(double p) {
  std::array<double, 7> quantile{};
  if (p > 0.0) {
    for (int k = 1; k <= 6; ++k) quantile[static_cast<std::size_t>(k)] = chiSquareQuantile(k, p);
  }
  return quantile;
}

}  // namespace

Result<ConsistentOptimum> optimizeConsistent(const PoseGraph& without_closures,
                                             const std::vector<LoopClosure>& closures, NodeId newest,
                                             const MappingPipelineConfig& config) {
  ConsistentOptimum out{without_closures, std::vector<bool>(closures.size(), false), std::nullopt};
  const auto left = [&] { return std::find(out.refused.begin(), out.refused.end(), false) != out.refused.end(); };
  const std::array<double, 7> quantile = quantilesByRank(config.consistency_confidence);
  const bool bounded = !config.optimize_closed_loop_only && config.local_optimization_nodes > 0 &&
                       without_closures.numNodes() > static_cast<std::size_t>(config.local_optimization_nodes);
  const bool full_due = bounded && newest % static_cast<NodeId>(config.full_optimization_every) == 0;
  const bool forced = config.optimize_every_submap || full_due;
  while (left() || forced) {
    out.graph = without_closures;
    NodeId first_free = newest;
    std::vector<NodeId> seeds{newest};
    for (std::size_t k = 0; k < closures.size(); ++k) {
      if (out.refused[k]) continue;
      const LoopClosure& c = closures[k];
      if (Status s = out.graph.addPartialLoopClosure(c.from, c.to, c.factor); !s.ok()) return s.error();
      first_free = std::min(first_free, c.from);
      seeds.push_back(c.from);
      seeds.push_back(c.to);
    }
    Result<OptimizeResult> result = Error{""};
    if (config.optimize_closed_loop_only) {
      result = out.graph.optimizeFrom(first_free);
    } else if (bounded && !full_due) {
      result = out.graph.optimizeNodes(
          out.graph.neighbourhood(seeds, static_cast<std::size_t>(config.local_optimization_nodes)));
    } else {
      result = out.graph.optimize();
    }
    if (!result) return result.error();
    out.optimize = result.value();
    if (config.consistency_confidence <= 0.0) break;
    // The least consistent closure, if any is beyond its quantile.
    std::optional<std::size_t> worst;
    double worst_ratio = 1.0;
    for (std::size_t k = 0; k < closures.size(); ++k) {
      if (out.refused[k]) continue;
      const LoopClosure& c = closures[k];
      auto from = out.graph.pose(c.from);
      if (!from) return from.error();
      auto to = out.graph.pose(c.to);
      if (!to) return to.error();
      const double chi2 =
          closureConsistencyChi2(c.factor, *from, *to, config.consistency_floor_m, config.consistency_floor_rad);
      const double ratio = chi2 / quantile[static_cast<std::size_t>(c.factor.rank())];
      if (ratio > worst_ratio) {
        worst_ratio = ratio;
        worst = k;
      }
    }
    if (!worst) break;
    out.refused[*worst] = true;
    if (!left() && !forced) {  // no closure left: nothing moves
      out.graph = without_closures;
      out.optimize.reset();
      break;
    }
  }
  return out;
}

Status recheckClosures(PoseGraph& graph, const std::vector<const LoopClosure*>& closures, std::vector<bool>& active,
                       const MappingPipelineConfig& config, std::vector<std::pair<NodeId, NodeId>>& switched_off,
                       std::vector<std::pair<NodeId, NodeId>>& switched_on) {
  if (active.size() != closures.size()) {
    return Error{"consistency re-check: " + std::to_string(active.size()) + " switches for " +
                 std::to_string(closures.size()) + " closures"};
  }
  if (config.consistency_confidence <= 0.0) return Status::success();
  const std::array<double, 7> quantile = quantilesByRank(config.consistency_confidence);
  std::vector<bool> off_now(closures.size(), false);  // switched off in this re-check: not back on in it
  for (int solves = 0; solves < config.recheck_max_solves; ++solves) {
    // The least consistent active closure, and the most consistent inactive one.
    std::optional<std::size_t> worst, best;
    double worst_ratio = 1.0, best_ratio = 1.0;
    for (std::size_t k = 0; k < closures.size(); ++k) {
      const LoopClosure& c = *closures[k];
      auto from = graph.pose(c.from);
      if (!from) return from.error();
      auto to = graph.pose(c.to);
      if (!to) return to.error();
      const double ratio =
          closureConsistencyChi2(c.factor, *from, *to, config.consistency_floor_m, config.consistency_floor_rad) /
          quantile[static_cast<std::size_t>(c.factor.rank())];
      if (active[k] && ratio > worst_ratio) {
        worst_ratio = ratio;
        worst = k;
      } else if (!active[k] && !off_now[k] && ratio <= best_ratio) {
        best_ratio = ratio;
        best = k;
      }
    }
    const std::optional<std::size_t> flip = worst ? worst : best;
    if (!flip) break;
    const LoopClosure& c = *closures[*flip];
    active[*flip] = !active[*flip];
    if (Status s = graph.setLoopClosureActive(c.from, c.to, active[*flip]); !s.ok()) return s;
    (active[*flip] ? switched_on : switched_off).emplace_back(c.from, c.to);
    off_now[*flip] = !active[*flip];
    if (auto r = graph.optimize(); !r) return r.error();
  }
  return Status::success();
}

Result<std::unique_ptr<MappingPipeline>> MappingPipeline::create(const MappingPipelineConfig& config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  auto builder = SubmapBuilder::create(config.builder);
  if (!builder) return builder.error();
  auto closer = LoopCloser::create(config.loop_closer);
  if (!closer) return closer.error();
  auto graph = PoseGraph::create(config.graph);
  if (!graph) return graph.error();
  auto map = map::VogMap::create(config.builder.grid);
  if (!map) return map.error();
  auto candidates = CandidateIndex::create(config.loop_closer.candidates);
  if (!candidates) return candidates.error();
  return std::unique_ptr<MappingPipeline>(new MappingPipeline(config, std::move(builder.value()),
                                                              std::move(closer.value()), std::move(graph.value()),
                                                              std::move(map.value()), std::move(candidates.value())));
}

Result<std::unique_ptr<MappingPipeline>> MappingPipeline::restore(const MappingPipelineConfig& config,
                                                                  const PipelineState& state) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  if (state.estimates.size() != state.submaps.size()) {
    return Error{"restore: " + std::to_string(state.submaps.size()) + " submaps but " +
                 std::to_string(state.estimates.size()) + " estimates"};
  }
  for (std::size_t k = 0; k < state.submaps.size(); ++k) {
    const ClosedSubmap& c = state.submaps[k];
    const std::string name = "restore: submap " + std::to_string(c.index);
    if (c.index != static_cast<std::int64_t>(k)) {
      return Error{"restore: submap at position " + std::to_string(k) + " has index " + std::to_string(c.index)};
    }
    if (!c.grid || !c.grid->finalized()) return Error{name + " has no finalized grid"};
    if (c.has_previous != (k > 0)) {
      return Error{name + (k > 0 ? " lacks its odometry factor" : " (the first) has an odometry factor")};
    }
    if (!state.estimates[k].allFinite()) return Error{name + ": estimate is not finite"};
  }
  std::size_t closure_end = 0;  // closures are grouped by `to`, in submap order (as process() adds them)
  for (const LoopClosure& lc : state.closures) {
    const auto n = static_cast<std::int64_t>(state.submaps.size());
    if (lc.to < 0 || lc.to >= n || lc.from < 0 || lc.from >= n || lc.from == lc.to) {
      return Error{"restore: loop closure " + std::to_string(lc.from) + " -> " + std::to_string(lc.to) +
                   " names an unknown submap (have " + std::to_string(n) + ")"};
    }
    if (static_cast<std::size_t>(lc.to) < closure_end) {
      return Error{"restore: loop closure " + std::to_string(lc.from) + " -> " + std::to_string(lc.to) +
                   " is out of order (closures must be sorted by their newer submap)"};
    }
    closure_end = static_cast<std::size_t>(lc.to);
  }

  auto pipeline = create(config);
  if (!pipeline) return pipeline.error();
  MappingPipeline& p = *pipeline.value();
  if (!state.submaps.empty()) {
    auto builder = SubmapBuilder::resumeAfter(config.builder, state.submaps.back());
    if (!builder) return Error{"restore: " + builder.error().message};
    p.builder_ = std::move(builder.value());
  }

  // Nodes and factors in the order process() added them: per submap the node, its odometry factor,
  // its absolute factor, then the closures accepted for it.
  const double var_z = config.depth_stddev_m * config.depth_stddev_m;
  const double var_rp = config.roll_pitch_stddev_rad * config.roll_pitch_stddev_rad;
  const Eigen::Matrix3d absolute_information = Eigen::Vector3d(1.0 / var_z, 1.0 / var_rp, 1.0 / var_rp).asDiagonal();
  std::size_t next_closure = 0;
  std::vector<geometry::Pose3> poses;
  for (std::size_t k = 0; k < state.submaps.size(); ++k) {
    const ClosedSubmap& c = state.submaps[k];
    const NodeId id = c.index;
    if (Status s = p.graph_.addNode(id, fromXyzRpy(state.estimates[k])); !s.ok())
      return Error{"restore: " + s.error().message};
    if (Status s = p.graph_.setEstimate(id, state.estimates[k]); !s.ok()) return Error{"restore: " + s.error().message};
    if (c.has_previous) {
      auto information = informationFromCovariance(c.odometry_covariance, "odometry covariance");
      if (!information) return Error{"restore: submap " + std::to_string(id) + ": " + information.error().message};
      if (Status s =
              p.graph_.addOdometryFactor(id - 1, id, c.odometry_from_previous, Eigen::Matrix3d(information.value()));
          !s.ok()) {
        return Error{"restore: " + s.error().message};
      }
    }
    if (Status s = p.graph_.addAbsoluteFactor(id, c.base_z_roll_pitch, absolute_information); !s.ok()) {
      return Error{"restore: " + s.error().message};
    }
    for (; next_closure < state.closures.size() && state.closures[next_closure].to == id; ++next_closure) {
      const LoopClosure& lc = state.closures[next_closure];
      if (Status s = p.graph_.addPartialLoopClosure(lc.from, lc.to, lc.factor); !s.ok()) {
        return Error{"restore: " + s.error().message};
      }
      if (!lc.active) {
        if (Status s = p.graph_.setLoopClosureActive(lc.from, lc.to, false); !s.ok()) {
          return Error{"restore: " + s.error().message};
        }
      }
    }
    auto pose = p.graph_.pose(id);
    if (!pose) return Error{"restore: " + pose.error().message};
    SubmapRecord record;
    record.index = id;
    record.T_world_base_odom = c.T_world_base_odom;
    record.T_world_base = pose.value();
    record.first_stamp_ns = c.first_stamp_ns;
    record.last_stamp_ns = c.last_stamp_ns;
    record.n_scans = c.n_scans;
    record.reason = c.reason;
    p.submaps_.push_back(record);
    p.loop_submaps_.push_back({id, c.grid, pose.value(), c.first_stamp_ns, c.T_world_base_odom});
    if (Status s = p.candidates_.add(footprintOf(p.loop_submaps_.back())); !s.ok()) {
      return Error{"restore: " + s.error().message};
    }
    poses.push_back(pose.value());
    if (Status s = p.map_->addSubmap(static_cast<map::SubmapId>(id), c.grid, pose.value()); !s.ok()) {
      return Error{"restore: " + s.error().message};
    }
  }
  // deform() computes the cached inverses exactly as the running pipeline's last deformation did.
  if (!poses.empty()) {
    if (Status s = p.map_->deform(poses); !s.ok()) return Error{"restore: deform: " + s.error().message};
  }
  p.closures_ = state.closures;
  return pipeline;
}

Result<MappingUpdate> MappingPipeline::feed(const ScanInput& input) {
  if (failed_) return Error{"mapping pipeline stopped: " + failed_->message};
  auto closed = builder_.addScan(input);
  if (!closed) return closed.error();
  if (!closed->has_value()) return MappingUpdate{};
  auto update = process(std::move(**closed));
  if (!update) failed_ = update.error();
  return update;
}

Result<MappingUpdate> MappingPipeline::finish() {
  if (failed_) return Error{"mapping pipeline stopped: " + failed_->message};
  auto closed = builder_.flush();
  if (!closed) return closed.error();
  if (!closed->has_value()) return MappingUpdate{};
  auto update = process(std::move(**closed));
  if (!update) failed_ = update.error();
  return update;
}

Result<MappingUpdate> MappingPipeline::process(ClosedSubmap closed) {
  MappingUpdate update;
  auto lap = [t = std::chrono::steady_clock::now()]() mutable {
    const auto now = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - t).count();
    t = now;
    return ms;
  };
  const NodeId id = closed.index;
  // All graph changes happen on a copy, committed only when every step succeeded.
  PoseGraph graph = graph_;

  // Initial estimate: the planar odometry composed onto the previous node's current estimate; z, roll
  // and pitch are observed directly (thesis 4.2), so they come from the base scan's odometry pose.
  geometry::Pose3 T_world_init = closed.T_world_base_odom;
  if (closed.has_previous) {
    const SubmapRecord& prev = submaps_.back();
    const Vector6d p = toXyzRpy(prev.T_world_base);
    Vector6d x = toXyzRpy(closed.T_world_base_odom);
    const Eigen::Vector3d& d = closed.odometry_from_previous;
    const double c = std::cos(p(kYaw));
    const double s = std::sin(p(kYaw));
    x(kX) = p(kX) + c * d.x() - s * d.y();
    x(kY) = p(kY) + s * d.x() + c * d.y();
    x(kYaw) = geometry::wrapAngle(p(kYaw) + d.z());
    T_world_init = fromXyzRpy(x);
  }
  if (Status s = graph.addNode(id, T_world_init); !s.ok()) return Error{"mapping: " + s.error().message};
  if (closed.has_previous) {
    auto information = informationFromCovariance(closed.odometry_covariance, "odometry covariance");
    if (!information) return Error{"mapping: submap " + std::to_string(id) + ": " + information.error().message};
    if (Status s = graph.addOdometryFactor(submaps_.back().index, id, closed.odometry_from_previous,
                                           Eigen::Matrix3d(information.value()));
        !s.ok()) {
      return Error{"mapping: " + s.error().message};
    }
  }
  const double var_z = config_.depth_stddev_m * config_.depth_stddev_m;
  const double var_rp = config_.roll_pitch_stddev_rad * config_.roll_pitch_stddev_rad;
  const Eigen::Matrix3d absolute_information = Eigen::Vector3d(1.0 / var_z, 1.0 / var_rp, 1.0 / var_rp).asDiagonal();
  if (Status s = graph.addAbsoluteFactor(id, closed.base_z_roll_pitch, absolute_information); !s.ok()) {
    return Error{"mapping: " + s.error().message};
  }

  update.phase_times.graph_ms = lap();

  // Loop closures against the other submaps at their current estimates.
  SubmapRecord record;
  record.index = id;
  record.T_world_base_odom = closed.T_world_base_odom;
  record.T_world_base = T_world_init;
  record.first_stamp_ns = closed.first_stamp_ns;
  record.last_stamp_ns = closed.last_stamp_ns;
  record.n_scans = closed.n_scans;
  record.reason = closed.reason;

  const LoopSubmap fresh{id, closed.grid, T_world_init, closed.first_stamp_ns, closed.T_world_base_odom};
  if (!closed.grid || !closed.grid->finalized()) {
    return Error{"mapping: submap " + std::to_string(id) + " has no finalized grid"};
  }
  SubmapFootprint footprint = footprintOf(fresh);
  if (config_.loop_closures) {
    // The new submap joins the kept list for the search only; it is committed below.
    loop_submaps_.push_back(fresh);
    Result<LoopCloseOutcome> outcome = closer_.closeLoops(loop_submaps_, candidates_, footprint);
    loop_submaps_.pop_back();
    if (!outcome) return Error{"mapping: " + outcome.error().message};
    update.closures = std::move(outcome->closures);
    update.loop_stats = outcome->stats;
  }
  update.phase_times.search_ms = lap();

  auto optimum = optimizeConsistent(graph, update.closures, id, config_);
  if (!optimum) return Error{"mapping: " + optimum.error().message};
  graph = std::move(optimum->graph);
  if (optimum->optimize) {
    update.optimized = true;
    update.optimize = *optimum->optimize;
  }
  {
    std::vector<LoopClosure> kept;
    for (std::size_t k = 0; k < update.closures.size(); ++k) {
      if (!optimum->refused[k]) {
        kept.push_back(std::move(update.closures[k]));
        continue;
      }
      ++update.loop_stats.rejected;
      --update.loop_stats.accepted;
      ++update.loop_stats.rejected_by_reason["inconsistent"];
    }
    update.closures = std::move(kept);
  }
  std::vector<bool> active;  // of closures_ then update.closures, after the re-check
  if (config_.consistency_recheck && update.optimized) {
    std::vector<const LoopClosure*> all;
    all.reserve(closures_.size() + update.closures.size());
    for (const LoopClosure& c : closures_) {
      all.push_back(&c);
      active.push_back(c.active);
    }
    for (const LoopClosure& c : update.closures) {
      all.push_back(&c);
      active.push_back(true);
    }
    if (Status s = recheckClosures(graph, all, active, config_, update.switched_off, update.switched_on); !s.ok()) {
      return Error{"mapping: " + s.error().message};
    }
    update.loop_stats.switched_off = static_cast<int>(update.switched_off.size());
    update.loop_stats.switched_on = static_cast<int>(update.switched_on.size());
  }
  update.phase_times.optimize_ms = lap();

  // Without an optimisation the other estimates did not change: their poses are the ones kept.
  std::vector<geometry::Pose3> poses;
  poses.reserve(submaps_.size() + 1);
  for (const SubmapRecord& r : submaps_) {
    if (!update.optimized) {
      poses.push_back(r.T_world_base);
      continue;
    }
    auto pose = graph.pose(r.index);
    if (!pose) return Error{"mapping: " + pose.error().message};
    poses.push_back(pose.value());
  }
  auto new_pose = graph.pose(id);
  if (!new_pose) return Error{"mapping: " + new_pose.error().message};
  poses.push_back(new_pose.value());

  // The candidate index refuses what the graph never gives (a non-finite pose): checked before the commit.
  footprint.T_world_submap = poses.back();
  if (Status s = checkFootprint(footprint); !s.ok()) return Error{"mapping: " + s.error().message};
  for (const geometry::Pose3& T : poses) {
    if (!geometry::isValidPose(T)) return Error{"mapping: the optimised graph holds a non-finite pose"};
  }

  // Commit: the map first, then the deformation (Alg. 1).
  if (Status s = map_->addSubmap(static_cast<map::SubmapId>(id), closed.grid, T_world_init); !s.ok()) {
    return Error{"mapping: " + s.error().message};
  }
  if (Status s = map_->deform(poses); !s.ok()) return Error{"mapping: deform: " + s.error().message};
  // The map's poses are the records' (both set from the same vector at every commit).
  for (std::size_t k = 0; k < submaps_.size(); ++k) {
    if (submaps_[k].T_world_base.matrix() == poses[k].matrix()) continue;
    update.moved.push_back(static_cast<map::SubmapId>(submaps_[k].index));
    submaps_[k].T_world_base = poses[k];
    loop_submaps_[k].T_world_submap = poses[k];
    if (Status s = candidates_.setPose(k, poses[k]); !s.ok()) return Error{"mapping: " + s.error().message};
  }
  record.T_world_base = poses.back();
  submaps_.push_back(record);
  loop_submaps_.push_back({id, closed.grid, poses.back(), closed.first_stamp_ns, closed.T_world_base_odom});
  if (Status s = candidates_.add(footprint); !s.ok()) return Error{"mapping: " + s.error().message};
  graph_ = std::move(graph);
  for (std::size_t k = 0; k < active.size(); ++k) {
    LoopClosure& c = k < closures_.size() ? closures_[k] : update.closures[k - closures_.size()];
    c.active = active[k];
  }
  for (const LoopClosure& c : update.closures) closures_.push_back(c);
  stats_.add(update.loop_stats);
  update.closed_submap = id;
  update.closed = std::move(closed);
  update.phase_times.commit_ms = lap();
  return update;
}

}  // namespace vog::slam
