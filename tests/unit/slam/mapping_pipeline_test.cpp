// MappingPipeline and LoopCloser on a drifting orbit over the synthetic pier: loop closures
// are found and accepted, none is wrong (0.2 m / 2 deg of the truth), optimisation lowers the base-pose
// error below raw odometry, the VogMap holds exactly the optimised poses, and bad input changes nothing.
#include "pipeline_fixture.hpp"
#include "vog/eval/closures.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/slam/loop_closer.hpp"
#include "vog/slam/mapping_pipeline.hpp"
#include "vog/slam/pose_vector.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <numbers>

namespace vog::slam {
namespace {

using geometry::deg2rad;
using testing::Run;

// About three laps (radius 5.5, 6.2, 6.9 m). The odometry's position random walk is below thesis
// Eq. 4.1 (at 0.00138 m^2/s a 40-scan submap is itself bent by ~0.1 m, which alone breaks the 0.2 m /
// 2 deg bound) and a heading-rate bias supplies the drift (heading error dominates, thesis 4.5.3):
// about 0.4 m base-pose RMSE by the end of the run.
constexpr int kScans = 1100;
constexpr int kStride = 2;
constexpr double kCovXy = 0.0003;
constexpr double kYawBias = deg2rad(0.02);

MappingPipelineConfig pipelineConfig(LoopClosureMode mode) {
  MappingPipelineConfig c;
  c.builder.grid.resolution_m = 0.1;
  c.builder.max_scans = 40;
  c.builder.odometry_cov_x_m2_per_s = kCovXy;
  c.builder.odometry_cov_y_m2_per_s = kCovXy;
  c.builder.odometry_cov_yaw_rad2_per_s = 1e-5;
  c.loop_closer.mode = mode;
  c.loop_closer.p2p.max_correspondence_distance_m = 0.5;
  c.loop_closer.point_to_plane.max_correspondence_distance_m = 0.5;
  return c;
}

const Run& sharedRun() {
  static const Run run = testing::makeRun(kScans, kStride, kCovXy, kYawBias, 42);
  return run;
}

struct Outcome {
  std::unique_ptr<MappingPipeline> pipeline;
  double rmse_odom_m = 0.0;
  double rmse_opt_m = 0.0;
  int wrong = 0;
};

Outcome runPipeline(LoopClosureMode mode, bool closures,
                    const std::function<void(MappingPipelineConfig&)>& adjust = nullptr) {
  MappingPipelineConfig c = pipelineConfig(mode);
  c.loop_closures = closures;
  if (adjust) adjust(c);
  auto p = MappingPipeline::create(c);
  EXPECT_TRUE(p.ok());
  Outcome out;
  out.pipeline = std::move(p.value());
  const slam::testing::Run& run = sharedRun();
  std::vector<geometry::Pose3> before;
  auto check = [&](const Result<MappingUpdate>& u, double feed_ms) {
    ASSERT_TRUE(u.ok()) << u.error().message;
    // The phase times split the closing call's time: each >= 0, together no more than the call took.
    const MappingPhaseTimes& t = u->phase_times;
    for (const double ms : {t.graph_ms, t.search_ms, t.optimize_ms, t.commit_ms}) EXPECT_GE(ms, 0.0);
    EXPECT_LE(t.graph_ms + t.search_ms + t.optimize_ms + t.commit_ms, feed_ms);
    const std::vector<geometry::Pose3> after = out.pipeline->map().poses();
    if (u->closed_submap) {
      ASSERT_EQ(after.size(), before.size() + 1);
      EXPECT_EQ(static_cast<std::int64_t>(out.pipeline->map().entries().back().id), *u->closed_submap);
    }
    // `moved` names exactly the old submaps whose pose changed.
    std::vector<map::SubmapId> changed;
    for (std::size_t k = 0; k < before.size(); ++k) {
      if (before[k].matrix() != after[k].matrix()) changed.push_back(static_cast<map::SubmapId>(k));
    }
    EXPECT_EQ(changed, u->moved);
    if (!u->closures.empty()) {
      EXPECT_TRUE(u->optimized);
    }
    // Optimising the closed loop only: nothing older than the oldest submap a closure joins moves.
    if (c.optimize_closed_loop_only && u->closed_submap) {
      std::int64_t first_free = *u->closed_submap;
      for (const LoopClosure& lc : u->closures) first_free = std::min(first_free, lc.from);
      for (const map::SubmapId id : u->moved) EXPECT_GE(static_cast<std::int64_t>(id), first_free);
    }
    // Bounded solves: between the whole-graph ones, at most local_optimization_nodes submaps move.
    if (c.local_optimization_nodes > 0 && u->closed_submap &&
        before.size() + 1 > static_cast<std::size_t>(c.local_optimization_nodes)) {
      if (*u->closed_submap % c.full_optimization_every != 0) {
        EXPECT_LE(u->moved.size(), static_cast<std::size_t>(c.local_optimization_nodes));
        if (u->optimized) {
          EXPECT_EQ(u->optimize.free_nodes, c.local_optimization_nodes);
        }
      } else {
        EXPECT_TRUE(u->optimized) << "submap " << *u->closed_submap << ": the whole-graph solve is due";
        EXPECT_EQ(u->optimize.free_nodes, static_cast<int>(before.size() + 1));
      }
    }
    before = after;
  };
  auto timed = [&](const std::function<Result<MappingUpdate>()>& call) {
    const auto t0 = std::chrono::steady_clock::now();
    Result<MappingUpdate> u = call();
    check(u, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  };
  for (const ScanInput& in : run.inputs) timed([&] { return out.pipeline->feed(in); });
  timed([&] { return out.pipeline->finish(); });
  double se_odom = 0.0;
  double se_opt = 0.0;
  for (const SubmapRecord& r : out.pipeline->submaps()) {
    const geometry::Pose3& T_true = run.truth[testing::scanIndexOf(r.first_stamp_ns)];
    se_odom += (r.T_world_base_odom.translation() - T_true.translation()).squaredNorm();
    se_opt += (r.T_world_base.translation() - T_true.translation()).squaredNorm();
  }
  const double n = static_cast<double>(out.pipeline->submaps().size());
  out.rmse_odom_m = std::sqrt(se_odom / n);
  out.rmse_opt_m = std::sqrt(se_opt / n);
  for (const LoopClosure& lc : out.pipeline->closures()) {
    const auto& s = out.pipeline->submaps();
    const geometry::Pose3 T_from = run.truth[testing::scanIndexOf(s[static_cast<std::size_t>(lc.from)].first_stamp_ns)];
    const geometry::Pose3 T_to = run.truth[testing::scanIndexOf(s[static_cast<std::size_t>(lc.to)].first_stamp_ns)];
    const geometry::Pose3 T_true = T_from.inverse() * T_to;
    if (eval::closureError(lc, T_true).wrong) ++out.wrong;
  }
  const LoopCloseStats& st = out.pipeline->loopStats();
  std::cout << toString(mode) << " closures=" << closures << " submaps=" << n << " tried=" << st.tried
            << " accepted=" << st.accepted << " wrong=" << out.wrong << " rmse_odom=" << out.rmse_odom_m
            << " rmse_opt=" << out.rmse_opt_m;
  for (const auto& [k, v] : st.rejected_by_reason) std::cout << " " << k << "=" << v;
  std::cout << "\n";
  return out;
}

// The VogMap holds one entry per graph node with bit-identical poses (Alg. 1 deformation).
void expectMapEqualsGraph(const MappingPipeline& p) {
  const auto entries = p.map().entries();
  ASSERT_EQ(entries.size(), p.graph().numNodes());
  ASSERT_EQ(entries.size(), p.submaps().size());
  for (const map::SubmapEntry& e : entries) {
    auto pose = p.graph().pose(static_cast<NodeId>(e.id));
    ASSERT_TRUE(pose.ok());
    EXPECT_EQ(pose->matrix(), e.T_world_submap.matrix()) << "submap " << e.id;
    EXPECT_EQ(p.submaps()[e.id].T_world_base.matrix(), e.T_world_submap.matrix());
  }
}

TEST(MappingPipeline, PointToPointClosuresCorrectDriftAndNoneIsWrong) {
  const Outcome o = runPipeline(LoopClosureMode::kPointToPoint2d, true);
  expectMapEqualsGraph(*o.pipeline);
  EXPECT_GE(o.pipeline->loopStats().accepted, 3);
  EXPECT_EQ(o.wrong, 0);
  EXPECT_LT(o.rmse_opt_m, o.rmse_odom_m);
}

TEST(MappingPipeline, DegeneracyAwareClosuresCorrectDriftAndNoneIsWrong) {
  const Outcome o = runPipeline(LoopClosureMode::kDegenerate, true);
  expectMapEqualsGraph(*o.pipeline);
  // Partial factors: every closure constrains at least one and at most the three planar directions.
  for (const LoopClosure& lc : o.pipeline->closures()) {
    EXPECT_GE(lc.factor.rank(), 1);
    EXPECT_LE(lc.factor.rank(), 3);
  }
  EXPECT_GE(o.pipeline->loopStats().accepted, 3);
  EXPECT_EQ(o.wrong, 0);
  EXPECT_LT(o.rmse_opt_m, o.rmse_odom_m);
}

// Optimising only the loop each closure makes corrects the drift about as well as re-optimising the
// whole graph every time, and moves fewer submaps.
TEST(MappingPipeline, OptimisingTheClosedLoopOnlyCorrectsDriftAsTheWholeGraphDoes) {
  const Outcome loop = runPipeline(LoopClosureMode::kDegenerate, true,
                                   [](MappingPipelineConfig& c) { c.optimize_closed_loop_only = true; });
  const Outcome whole = runPipeline(LoopClosureMode::kDegenerate, true);
  expectMapEqualsGraph(*loop.pipeline);
  EXPECT_EQ(loop.wrong, 0);
  EXPECT_LT(loop.rmse_opt_m, loop.rmse_odom_m);
  EXPECT_LT(loop.rmse_opt_m, 1.25 * whole.rmse_opt_m + 0.02)
      << "closed loop only " << loop.rmse_opt_m << " m, whole graph " << whole.rmse_opt_m << " m";
}

// Bounded solves (a few nodes around each new submap, the whole graph every fourth submap): at most
// that many submaps move between the whole-graph solves (checked in runPipeline), and the drift is
// corrected about as well as by solving the whole graph every time. Both runs without the normals
// check: with it the two accept different closures on this run (25 and 26) and end at 0.177 and 0.113 m,
// the bounded solves' larger trajectory error that docs/long-mission reports; without it 0.091 and 0.079 m.
TEST(MappingPipeline, BoundedSolvesCorrectDriftAsTheWholeGraphDoes) {
  const auto no_normals_check = [](MappingPipelineConfig& c) {
    c.loop_closer.point_to_plane.max_normal_angle_rad = std::numbers::pi;
  };
  const Outcome bounded = runPipeline(LoopClosureMode::kDegenerate, true, [&](MappingPipelineConfig& c) {
    no_normals_check(c);
    c.local_optimization_nodes = 5;
    c.full_optimization_every = 4;
  });
  const Outcome whole = runPipeline(LoopClosureMode::kDegenerate, true, no_normals_check);
  expectMapEqualsGraph(*bounded.pipeline);
  EXPECT_GT(bounded.pipeline->submaps().size(), 12U);
  EXPECT_EQ(bounded.wrong, 0);
  EXPECT_LT(bounded.rmse_opt_m, bounded.rmse_odom_m);
  EXPECT_LT(bounded.rmse_opt_m, 1.25 * whole.rmse_opt_m + 0.02)
      << "bounded " << bounded.rmse_opt_m << " m, whole graph " << whole.rmse_opt_m << " m";
}

TEST(MappingPipeline, WithoutClosuresSubmapsKeepTheirOdometryPoses) {
  const Outcome o = runPipeline(LoopClosureMode::kPointToPoint2d, false);
  EXPECT_EQ(o.pipeline->loopStats().tried, 0);
  expectMapEqualsGraph(*o.pipeline);
  for (const SubmapRecord& r : o.pipeline->submaps()) {
    // x, y, yaw from odometry composition; the same up to rounding.
    EXPECT_LT((r.T_world_base.translation() - r.T_world_base_odom.translation()).norm(), 1e-9);
  }
}

// The merge thread's loop (DESIGN "Threads"): after every update, MergedMap::sync re-merges exactly the
// submaps the pipeline reported as moved and adds the new one; at the end the incrementally kept map is
// identical, voxel for voxel, to one merged from scratch at the final poses.
TEST(MappingPipeline, MergedMapFollowsDeformationIncrementally) {
  auto p = MappingPipeline::create(pipelineConfig(LoopClosureMode::kDegenerate));
  ASSERT_TRUE(p.ok());
  MappingPipeline& pipeline = **p;
  auto merged = map::MergedMap::create(pipeline.config().builder.grid);
  ASSERT_TRUE(merged.ok());
  const map::MergeConfig exact{0.0, 0.0};  // re-merge on any pose change
  int remerged_total = 0;
  auto follow = [&](const Result<MappingUpdate>& u) {
    ASSERT_TRUE(u.ok()) << u.error().message;
    if (!u->closed_submap && u->moved.empty()) return;
    auto stats = (*merged)->sync(pipeline.map().entries(), exact);
    ASSERT_TRUE(stats.ok()) << stats.error().message;
    EXPECT_EQ(stats->added, u->closed_submap ? 1 : 0);
    EXPECT_EQ(stats->removed, 0);
    EXPECT_EQ(stats->remerged, static_cast<int>(u->moved.size()));
    remerged_total += stats->remerged;
  };
  for (const ScanInput& in : sharedRun().inputs) follow(pipeline.feed(in));
  follow(pipeline.finish());
  EXPECT_GT(remerged_total, 0) << "no closure moved a submap: the test would not exercise re-merging";
  auto scratch = map::MergedMap::create(pipeline.config().builder.grid);
  ASSERT_TRUE(scratch.ok());
  for (const map::SubmapEntry& e : pipeline.map().entries()) ASSERT_TRUE((*scratch)->add(e).ok());
  EXPECT_EQ((*merged)->submapCount(), pipeline.map().entries().size());
  EXPECT_TRUE((*merged)->sameVoxels(**scratch));
}

// A short prefix of the run: bad input in the middle is rejected and the result is bit-identical to a
// run that never saw it; two runs are bit-identical (determinism).
TEST(MappingPipeline, RejectsBadInputWithoutChangingStateAndIsDeterministic) {
  const slam::testing::Run& run = sharedRun();
  const std::size_t n = 300;
  auto clean = MappingPipeline::create(pipelineConfig(LoopClosureMode::kDegenerate));
  auto dirty = MappingPipeline::create(pipelineConfig(LoopClosureMode::kDegenerate));
  ASSERT_TRUE(clean.ok() && dirty.ok());
  for (std::size_t k = 0; k < n; ++k) {
    ASSERT_TRUE((*clean)->feed(run.inputs[k]).ok());
    if (k == 85) {  // 5 scans after the third submap closed
      ScanInput nan_pose = run.inputs[k + 1];
      nan_pose.T_world_vehicle_odom.linear()(0, 0) = std::numeric_limits<double>::quiet_NaN();
      auto r1 = (*dirty)->feed(nan_pose);
      ASSERT_FALSE(r1.ok());
      EXPECT_NE(r1.error().message.find("pose"), std::string::npos) << r1.error().message;
      ScanInput old_stamp = run.inputs[k + 1];
      old_stamp.scan.stamp_ns = run.inputs[k - 1].scan.stamp_ns;
      EXPECT_FALSE((*dirty)->feed(old_stamp).ok());
      ScanInput wide = run.inputs[k + 1];
      wide.scan.range_m.push_back(3.0F);
      auto r3 = (*dirty)->feed(wide);
      ASSERT_FALSE(r3.ok());
      EXPECT_NE(r3.error().message.find("97 beams"), std::string::npos) << r3.error().message;
    }
    ASSERT_TRUE((*dirty)->feed(run.inputs[k]).ok());
  }
  ASSERT_TRUE((*clean)->finish().ok());
  ASSERT_TRUE((*dirty)->finish().ok());
  const auto a = (*clean)->map().poses();
  const auto b = (*dirty)->map().poses();
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GE(a.size(), 4U);
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].matrix(), b[k].matrix()) << "submap " << k;
  EXPECT_EQ((*clean)->graph().numFactors(), (*dirty)->graph().numFactors());
}

TEST(MappingPipeline, ConfigValidationNamesTheKey) {
  MappingPipelineConfig c;
  EXPECT_TRUE(c.validate().ok());
  c.depth_stddev_m = -1.0;
  auto p = MappingPipeline::create(c);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().message.find("depth_stddev_m"), std::string::npos) << p.error().message;
  c = {};
  c.loop_closer.max_heading_difference_rad = 0.0;
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("max_heading_difference_rad"), std::string::npos);
  c = {};
  c.local_optimization_nodes = -1;
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("local_optimization_nodes"), std::string::npos);
  c = {};
  c.full_optimization_every = 0;
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("full_optimization_every"), std::string::npos);
  c = {};
  c.consistency_recheck = true;  // without consistency_confidence
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("consistency_recheck"), std::string::npos);
  c.consistency_confidence = 0.999;
  c.recheck_max_solves = 0;
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("recheck_max_solves"), std::string::npos);
  EXPECT_TRUE(parseLoopClosureMode("p2p").ok());
  EXPECT_FALSE(parseLoopClosureMode("p2pl").ok());
}

}  // namespace
}  // namespace vog::slam

namespace vog::slam {
namespace {

TEST(ClosureConsistency, ChiSquareQuantilesMatchTheTables) {
  EXPECT_NEAR(chiSquareQuantile(1, 0.999), 10.828, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(2, 0.95), 5.991, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(3, 0.999), 16.266, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(6, 0.99), 16.812, 1e-3);
}

// Six nodes 1 m apart along x, drifted in y by odometry; three closures to the newest agree with the
// truth, a fourth is 0.6 m off across the line.
struct ClosureLine {
  PoseGraph graph;
  std::vector<LoopClosure> closures;
  static geometry::Pose3 truth(int k) { return geometry::poseFromXyzRpy(1.0 * k, 0.0, -2.0, 0.0, 0.0, 0.0); }
};

ClosureLine closureLine() {
  auto created = PoseGraph::create();
  EXPECT_TRUE(created.ok());
  ClosureLine line{std::move(created.value()), {}};
  const Eigen::Matrix3d odometry_information = Eigen::Vector3d(1.0 / 0.01, 1.0 / 0.01, 1.0 / 1e-4).asDiagonal();
  const Eigen::Matrix3d absolute_information = Eigen::Vector3d(400.0, 1e4, 1e4).asDiagonal();
  for (int k = 0; k <= 5; ++k) {
    EXPECT_TRUE(line.graph.addNode(k, geometry::poseFromXyzRpy(1.0 * k, 0.08 * k, -2.0, 0.0, 0.0, 0.0)).ok());
    EXPECT_TRUE(line.graph.addAbsoluteFactor(k, Eigen::Vector3d(-2.0, 0.0, 0.0), absolute_information).ok());
    if (k > 0) {
      EXPECT_TRUE(line.graph.addOdometryFactor(k - 1, k, Eigen::Vector3d(1.0, 0.08, 0.0), odometry_information).ok());
    }
  }
  Eigen::MatrixXd V_u = Eigen::MatrixXd::Zero(3, 6);
  V_u(0, kX) = V_u(1, kY) = V_u(2, kYaw) = 1.0;
  const Matrix6d covariance = (Vector6d() << 1e-4, 1e-4, 0, 0, 0, 1e-6).finished().asDiagonal();
  for (const int from : {0, 1, 2, 3}) {
    Vector6d x = toXyzRpy(ClosureLine::truth(from).inverse() * ClosureLine::truth(5));
    if (from == 3) x(kY) += 0.6;
    LoopClosure c;
    c.from = from;
    c.to = 5;
    auto factor = makePartialLoopClosure(V_u, x, covariance);
    EXPECT_TRUE(factor.ok()) << factor.error().message;
    c.factor = factor.value();
    line.closures.push_back(c);
  }
  return line;
}

// Closures already in the graph: the re-check switches the one that disagrees off, and the optimum is
// then that of the graph without it (the newest node back on the truth); a switched-off closure that
// agrees is switched back on.
TEST(ClosureConsistency, AnAcceptedClosureFoundInconsistentIsSwitchedOffAndOneThatAgreesBackOn) {
  ClosureLine line = closureLine();
  PoseGraph good_only = line.graph;
  for (const LoopClosure& c : line.closures) {
    ASSERT_TRUE(line.graph.addPartialLoopClosure(c.from, c.to, c.factor).ok());
    if (c.from != 3) {
      ASSERT_TRUE(good_only.addPartialLoopClosure(c.from, c.to, c.factor).ok());
    }
  }
  ASSERT_TRUE(line.graph.optimize().ok());
  ASSERT_TRUE(good_only.optimize().ok());
  // Under the robust loss the wrong closure bends the line a little (the most at node 3, which only
  // odometry holds).
  const auto largest_difference = [&] {
    double d = 0.0;
    for (int k = 0; k <= 5; ++k) {
      d = std::max(d, geometry::translationDistance(line.graph.pose(k).value(), good_only.pose(k).value()));
    }
    return d;
  };
  const double pulled = largest_difference();
  EXPECT_GT(pulled, 1e-3);

  MappingPipelineConfig config;
  config.consistency_confidence = 0.999;
  config.consistency_recheck = true;
  std::vector<const LoopClosure*> all;
  for (const LoopClosure& c : line.closures) all.push_back(&c);
  std::vector<bool> active(4, true);
  std::vector<std::pair<NodeId, NodeId>> off, on;
  ASSERT_TRUE(recheckClosures(line.graph, all, active, config, off, on).ok());
  EXPECT_EQ(active, (std::vector<bool>{true, true, true, false}));
  EXPECT_EQ(off, (std::vector<std::pair<NodeId, NodeId>>{{3, 5}}));
  EXPECT_TRUE(on.empty());
  EXPECT_LT(geometry::translationDistance(line.graph.pose(5).value(), ClosureLine::truth(5)), 0.05);
  EXPECT_LT(largest_difference(), 1e-3 * pulled) << "pulled " << pulled;

  // A good closure switched off earlier agrees with the optimum: switched back on; the wrong one stays off.
  ASSERT_TRUE(line.graph.setLoopClosureActive(1, 5, false).ok());
  active[1] = false;
  off.clear();
  ASSERT_TRUE(recheckClosures(line.graph, all, active, config, off, on).ok());
  EXPECT_EQ(active, (std::vector<bool>{true, true, true, false}));
  EXPECT_EQ(on, (std::vector<std::pair<NodeId, NodeId>>{{1, 5}}));
  EXPECT_TRUE(off.empty());

  // Without the check, or with sizes that differ, nothing is switched / an error.
  config.consistency_confidence = 0.0;
  std::vector<bool> untouched(4, true);
  ASSERT_TRUE(recheckClosures(line.graph, all, untouched, config, off, on).ok());
  EXPECT_EQ(untouched, std::vector<bool>(4, true));
  std::vector<bool> short_list(3, true);
  EXPECT_FALSE(recheckClosures(line.graph, all, short_list, config, off, on).ok());
}

// With the check, the fourth closure of the line is refused and the others enter; without it, all four
// enter and pull the newest node off.
TEST(ClosureConsistency, AClosureThatDisagreesWithTheOthersIsRefusedBeforeInsertion) {
  const ClosureLine line = closureLine();
  const PoseGraph& graph = line.graph;
  const std::vector<LoopClosure>& closures = line.closures;
  const auto truth = ClosureLine::truth;
  MappingPipelineConfig config;
  config.consistency_confidence = 0.999;
  auto checked = optimizeConsistent(graph, closures, 5, config);
  ASSERT_TRUE(checked.ok()) << checked.error().message;
  EXPECT_EQ(checked->refused, (std::vector<bool>{false, false, false, true}));
  ASSERT_TRUE(checked->optimize.has_value());
  EXPECT_LT(geometry::translationDistance(checked->graph.pose(5).value(), truth(5)), 0.05);

  config.consistency_confidence = 0.0;
  auto unchecked = optimizeConsistent(graph, closures, 5, config);
  ASSERT_TRUE(unchecked.ok()) << unchecked.error().message;
  EXPECT_EQ(unchecked->refused, (std::vector<bool>(4, false)));

  // Only the wrong closure: it disagrees with odometry alone and is refused; nothing is optimised.
  config.consistency_confidence = 0.999;
  auto alone = optimizeConsistent(graph, {closures[3]}, 5, config);
  ASSERT_TRUE(alone.ok()) << alone.error().message;
  EXPECT_EQ(alone->refused, (std::vector<bool>{true}));
  EXPECT_FALSE(alone->optimize.has_value());
}

}  // namespace
}  // namespace vog::slam
