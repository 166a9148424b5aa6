// Vehicle pose graph: odometry / absolute / loop-closure factors, robust loss against
// outlier closures, partial factors, and bad input.
#include "vog/slam/pose_graph.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>

namespace vog::slam {
namespace {

using geometry::Pose3;

constexpr double kSigmaXy = 0.05, kSigmaYaw = 0.01, kSigmaZ = 0.02, kSigmaRp = 0.005;

// Two laps of a circle (so node k and k + n/2 revisit the same place), depth and attitude varying
// slightly, as a hover-capable vehicle would fly around a structure.
std::vector<Pose3> circleTruth(int n) {
  std::vector<Pose3> truth;
  for (int i = 0; i < n; ++i) {
    const double a = 4.0 * std::numbers::pi * i / n;
    truth.push_back(geometry::poseFromXyzRpy(6.0 * std::cos(a), 6.0 * std::sin(a), -2.0 + 0.3 * std::sin(3 * a),
                                             0.02 * std::sin(a), 0.01 * std::cos(a), a + std::numbers::pi / 2));
  }
  return truth;
}

Eigen::Matrix3d odometryInformation() {
  Eigen::Matrix3d cov;
  cov << kSigmaXy * kSigmaXy, 0.3 * kSigmaXy * kSigmaXy, 0.0, 0.3 * kSigmaXy * kSigmaXy, kSigmaXy * kSigmaXy, 0.0, 0.0,
      0.0, kSigmaYaw * kSigmaYaw;  // correlated x-y noise: a non-diagonal information
  return cov.inverse();
}

Eigen::Matrix3d absoluteInformation() {
  return Eigen::Vector3d(1 / (kSigmaZ * kSigmaZ), 1 / (kSigmaRp * kSigmaRp), 1 / (kSigmaRp * kSigmaRp)).asDiagonal();
}

Matrix6d closureInformation() {
  Vector6d sigma;
  sigma << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  return sigma.cwiseInverse().cwiseAbs2().asDiagonal();
}

struct Scenario {
  std::vector<Pose3> truth;
  std::vector<Pose3> dead_reckoning;
  std::vector<Eigen::Vector3d> odometry;
  std::vector<Eigen::Vector3d> absolute;
};

Scenario makeScenario(unsigned seed, int n) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Scenario s;
  s.truth = circleTruth(n);
  const Eigen::LLT<Eigen::Matrix3d> odo_cov(odometryInformation().inverse());
  for (int i = 0; i + 1 < n; ++i) {
    const Eigen::Vector3d w(g(rng), g(rng), g(rng));
    s.odometry.push_back(
        planarOdometry(s.truth[static_cast<std::size_t>(i)], s.truth[static_cast<std::size_t>(i) + 1]) +
        odo_cov.matrixL() * w);
  }
  for (int i = 0; i < n; ++i) {
    const Vector6d x = toXyzRpy(s.truth[static_cast<std::size_t>(i)]);
    s.absolute.emplace_back(x(kZ) + kSigmaZ * g(rng), x(kRoll) + kSigmaRp * g(rng), x(kPitch) + kSigmaRp * g(rng));
  }
  // Dead reckoning: compose the planar odometry; z, roll, pitch from the absolute sensors.
  Vector6d x = toXyzRpy(s.truth[0]);
  x(kZ) = s.absolute[0](0);
  x(kRoll) = s.absolute[0](1);
  x(kPitch) = s.absolute[0](2);
  s.dead_reckoning.push_back(fromXyzRpy(x));
  for (int i = 0; i + 1 < n; ++i) {
    const Eigen::Vector3d& o = s.odometry[static_cast<std::size_t>(i)];
    const double c = std::cos(x(kYaw)), sn = std::sin(x(kYaw));
    x(kX) += c * o(0) - sn * o(1);
    x(kY) += sn * o(0) + c * o(1);
    x(kYaw) = geometry::wrapAngle(x(kYaw) + o(2));
    const Eigen::Vector3d& a = s.absolute[static_cast<std::size_t>(i) + 1];
    x(kZ) = a(0);
    x(kRoll) = a(1);
    x(kPitch) = a(2);
    s.dead_reckoning.push_back(fromXyzRpy(x));
  }
  return s;
}

PoseGraph buildGraph(const Scenario& s, const PoseGraphConfig& config) {
  auto graph = PoseGraph::create(config);
  EXPECT_TRUE(graph.ok());
  PoseGraph g = std::move(*graph);
  for (std::size_t i = 0; i < s.truth.size(); ++i) {
    EXPECT_TRUE(g.addNode(static_cast<NodeId>(i), s.dead_reckoning[i]).ok());
    EXPECT_TRUE(g.addAbsoluteFactor(static_cast<NodeId>(i), s.absolute[i], absoluteInformation()).ok());
    if (i > 0) {
      EXPECT_TRUE(g.addOdometryFactor(static_cast<NodeId>(i - 1), static_cast<NodeId>(i), s.odometry[i - 1],
                                      odometryInformation())
                      .ok());
    }
  }
  return g;
}

void addTrueClosures(PoseGraph& g, const Scenario& s, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const std::size_t half = s.truth.size() / 2;
  for (std::size_t i = 0; i < half; i += 4) {
    Vector6d x = toXyzRpy(s.truth[i].inverse() * s.truth[i + half]);
    Vector6d noise;
    noise << 0.05 * n(rng), 0.05 * n(rng), 0.05 * n(rng), 0.01 * n(rng), 0.01 * n(rng), 0.01 * n(rng);
    ASSERT_TRUE(g.addLoopClosure(static_cast<NodeId>(i), static_cast<NodeId>(i + half), fromXyzRpy(x + noise),
                                 closureInformation())
                    .ok());
  }
}

double meanTranslationError(const PoseGraph& g, const std::vector<Pose3>& truth) {
  double sum = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    auto p = g.pose(static_cast<NodeId>(i));
    EXPECT_TRUE(p.ok());
    EXPECT_TRUE(geometry::isValidPose(*p));
    sum += geometry::translationDistance(*p, truth[i]);
  }
  return sum / static_cast<double>(truth.size());
}

double meanTranslationError(const std::vector<Pose3>& est, const std::vector<Pose3>& truth) {
  double sum = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) sum += geometry::translationDistance(est[i], truth[i]);
  return sum / static_cast<double>(truth.size());
}

TEST(PlanarOdometry, MeasuresInHeadingFrame) {
  const Pose3 a = geometry::poseFromXyzRpy(1, 2, -3, 0.1, 0.05, std::numbers::pi / 2);
  const Pose3 b = geometry::poseFromXyzRpy(1, 4, -1, 0.0, 0.0, std::numbers::pi / 2 + 0.2);
  const Eigen::Vector3d o = planarOdometry(a, b);
  EXPECT_NEAR(o(0), 2.0, 1e-12);  // forward along a's heading (+y in the world)
  EXPECT_NEAR(o(1), 0.0, 1e-12);
  EXPECT_NEAR(o(2), 0.2, 1e-12);
}

TEST(PoseGraph, OdometryOnlyOptimumIsDeadReckoning) {
  const Scenario s = makeScenario(1, 40);
  PoseGraph g = buildGraph(s, {});
  auto r = g.optimize();
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->converged) << r->message;
  EXPECT_EQ(r->linear_solver, "SPARSE_NORMAL_CHOLESKY/SUITE_SPARSE") << r->message;
  // A tree of factors is satisfied exactly: the estimate stays at dead reckoning, cost ~ 0.
  EXPECT_LT(r->final_cost, 1e-12);
  for (std::size_t i = 0; i < s.truth.size(); ++i) {
    EXPECT_LT(geometry::translationDistance(*g.pose(static_cast<NodeId>(i)), s.dead_reckoning[i]), 1e-6) << i;
  }
}

// A chain with one loop: the nodes before the loop's older end hang off it as a tree, so the whole
// graph's optimum leaves them where the chain puts them and optimising from that end reaches it too.
TEST(PoseGraph, OptimizingFromALoopsOlderEndReachesTheWholeGraphsOptimum) {
  const Scenario s = makeScenario(3, 40);
  PoseGraph part = buildGraph(s, {});
  Vector6d x = toXyzRpy(s.truth[8].inverse() * s.truth[28]);
  x(kX) += 0.03;
  x(kYaw) -= 0.005;
  ASSERT_TRUE(part.addLoopClosure(8, 28, fromXyzRpy(x), closureInformation()).ok());
  PoseGraph whole = part;
  ASSERT_TRUE(whole.optimize().ok());
  auto r = part.optimizeFrom(8);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->converged) << r->message;
  EXPECT_EQ(r->free_nodes, 32);
  EXPECT_LT(r->final_cost, r->initial_cost);
  for (NodeId id = 0; id < 40; ++id) {
    const Pose3 a = *part.pose(id);
    const Pose3 b = *whole.pose(id);
    EXPECT_LT(geometry::translationDistance(a, b), 1e-4) << "node " << id;
    EXPECT_LT(geometry::rotationAngle(a, b), 1e-5) << "node " << id;
  }
}

// With closures reaching before the free part, the held nodes keep their estimates bit for bit and act
// as fixed ends of the closures that join them.
TEST(PoseGraph, OptimizingFromANodeHoldsTheOlderNodesBitForBit) {
  const Scenario s = makeScenario(4, 40);
  PoseGraph g = buildGraph(s, {});
  addTrueClosures(g, s, 21);
  std::vector<Vector6d> before;
  for (NodeId id = 0; id < 40; ++id) before.push_back(*g.estimate(id));
  auto r = g.optimizeFrom(30);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->free_nodes, 10);
  EXPECT_LT(r->final_cost, r->initial_cost);
  int moved = 0;
  for (NodeId id = 0; id < 40; ++id) {
    const Vector6d now = *g.estimate(id);
    if (id < 30) {
      EXPECT_EQ(now, before[static_cast<std::size_t>(id)]) << "held node " << id;
    } else if (now != before[static_cast<std::size_t>(id)]) {
      ++moved;
    }
  }
  EXPECT_EQ(moved, 10);
  // A free part past the last node is an error that changes nothing.
  auto none = g.optimizeFrom(40);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("40"), std::string::npos) << none.error().message;
}

// Breadth first from all seeds at once, each hop in id order, up to the budget.
TEST(PoseGraph, NeighbourhoodIsTheNearestNodesInHops) {
  const Scenario s = makeScenario(5, 40);
  PoseGraph g = buildGraph(s, {});
  ASSERT_TRUE(g.addLoopClosure(8, 28, s.truth[8].inverse() * s.truth[28], closureInformation()).ok());
  EXPECT_EQ(g.neighbourhood({28}, 1), (std::set<NodeId>{28}));
  EXPECT_EQ(g.neighbourhood({28}, 4), (std::set<NodeId>{8, 27, 28, 29}));
  EXPECT_EQ(g.neighbourhood({28}, 6), (std::set<NodeId>{7, 8, 9, 27, 28, 29}));
  EXPECT_EQ(g.neighbourhood({39, 0}, 4), (std::set<NodeId>{0, 1, 38, 39}));
  EXPECT_EQ(g.neighbourhood({0, 39, 77}, 4), (std::set<NodeId>{0, 1, 38, 39}));  // a missing seed is no node
  EXPECT_EQ(g.neighbourhood({5}, 1000).size(), 40U);
  EXPECT_TRUE(g.neighbourhood({}, 10).empty());
}

// A free set holds every other node bit for bit; the whole set reaches optimize()'s optimum.
TEST(PoseGraph, OptimizingANodeSetHoldsTheOthersBitForBit) {
  const Scenario s = makeScenario(6, 40);
  PoseGraph g = buildGraph(s, {});
  addTrueClosures(g, s, 22);
  PoseGraph whole = g;
  PoseGraph all_free = g;
  ASSERT_TRUE(whole.optimize().ok());
  std::vector<Vector6d> before;
  for (NodeId id = 0; id < 40; ++id) before.push_back(*g.estimate(id));
  const std::set<NodeId> free = g.neighbourhood({39, 19}, 12);
  auto r = g.optimizeNodes(free);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->free_nodes, 12);
  EXPECT_LT(r->final_cost, r->initial_cost);
  for (NodeId id = 0; id < 40; ++id) {
    const Vector6d now = *g.estimate(id);
    if (free.count(id) == 0) {
      EXPECT_EQ(now, before[static_cast<std::size_t>(id)]) << "held node " << id;
    } else {
      EXPECT_NE(now, before[static_cast<std::size_t>(id)]) << "free node " << id;
    }
  }
  std::set<NodeId> all;
  for (NodeId id = 0; id < 40; ++id) all.insert(id);
  ASSERT_TRUE(all_free.optimizeNodes(all).ok());
  for (NodeId id = 0; id < 40; ++id) EXPECT_EQ(*all_free.estimate(id), *whole.estimate(id)) << "node " << id;
  // A missing node or an empty set is an error that changes nothing.
  const Vector6d kept = *g.estimate(3);
  auto missing = g.optimizeNodes({3, 41});
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("41"), std::string::npos) << missing.error().message;
  EXPECT_FALSE(g.optimizeNodes({}).ok());
  EXPECT_EQ(*g.estimate(3), kept);
}

TEST(PoseGraph, LoopClosuresCorrectDrift) {
  const Scenario s = makeScenario(2, 40);
  PoseGraph g = buildGraph(s, {});
  addTrueClosures(g, s, 20);
  const double before = meanTranslationError(s.dead_reckoning, s.truth);
  auto r = g.optimize();
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->converged) << r->message;
  EXPECT_LT(r->final_cost, r->initial_cost);
  const double after = meanTranslationError(g, s.truth);
  EXPECT_LT(after, 0.5 * before) << "before " << before << " after " << after;
  // The anchor node keeps its x, y, yaw.
  const Vector6d x0 = toXyzRpy(*g.pose(0));
  EXPECT_NEAR(x0(kX), toXyzRpy(s.truth[0])(kX), 1e-12);
  EXPECT_NEAR(x0(kYaw), toXyzRpy(s.truth[0])(kYaw), 1e-12);
}

// The two sparse Cholesky backends solve the same normal equations: the same optimum, each named.
TEST(PoseGraph, SparseBackendsReachTheSameOptimum) {
  const Scenario s = makeScenario(4, 40);
  std::vector<Pose3> optimum[2];
  const SparseBackend backends[] = {SparseBackend::kEigen, SparseBackend::kSuiteSparse};
  for (int b = 0; b < 2; ++b) {
    PoseGraphConfig config;
    config.sparse_backend = backends[b];
    PoseGraph g = buildGraph(s, config);
    addTrueClosures(g, s, 40);
    auto r = g.optimize();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(r->converged) << r->message;
    EXPECT_GT(r->iterations, 1);
    EXPECT_EQ(r->linear_solver, b == 0 ? "SPARSE_NORMAL_CHOLESKY/EIGEN_SPARSE" : "SPARSE_NORMAL_CHOLESKY/SUITE_SPARSE")
        << r->message;
    for (std::size_t i = 0; i < s.truth.size(); ++i) optimum[b].push_back(*g.pose(static_cast<NodeId>(i)));
  }
  for (std::size_t i = 0; i < s.truth.size(); ++i) {
    EXPECT_LT(geometry::translationDistance(optimum[0][i], optimum[1][i]), 1e-9) << i;
    EXPECT_LT(geometry::rotationAngle(optimum[0][i], optimum[1][i]), 1e-9) << i;
  }
}

// Conjugate gradients preconditioned by the odometry chain solve the same problem inexactly step by
// step: run to the library's tolerances they reach the factorisation's optimum, with the chain as
// odometry factors or as SE2 factors between consecutive ids (as a g2o file gives). With SE2 factors
// between every second id only there is no chain: the solve factorises and says so.
TEST(PoseGraph, ChainPreconditionedConjugateGradientsReachTheCholeskyOptimum) {
  const Scenario s = makeScenario(4, 40);
  enum class Chain { kOdometry, kSe2, kNone };
  const auto solveWith = [&](LinearSolver solver, Chain chain, OptimizeResult& result) {
    PoseGraphConfig config;
    config.linear_solver = solver;
    PoseGraph g = chain == Chain::kOdometry ? buildGraph(s, config) : PoseGraph::create(config).value();
    if (chain != Chain::kOdometry) {  // odometry as SE2 factors, or every second node only with none
      const std::size_t step = chain == Chain::kNone ? 2 : 1;
      for (std::size_t i = 0; i < s.truth.size(); i += step) {
        EXPECT_TRUE(g.addNode(static_cast<NodeId>(i), s.dead_reckoning[i]).ok());
        EXPECT_TRUE(g.addAbsoluteFactor(static_cast<NodeId>(i), s.absolute[i], absoluteInformation()).ok());
        if (i == 0) continue;
        const Eigen::Vector3d d = planarOdometry(s.dead_reckoning[i - step], s.dead_reckoning[i]);
        EXPECT_TRUE(
            g.addSe2Factor(static_cast<NodeId>(i - step), static_cast<NodeId>(i), d, odometryInformation()).ok());
      }
    }
    addTrueClosures(g, s, 40);
    auto r = g.optimize();
    EXPECT_TRUE(r.ok()) << r.error().message;
    if (!r.ok()) return std::vector<Pose3>{};
    EXPECT_TRUE(r->converged) << r->message;
    EXPECT_LT(r->final_cost, r->initial_cost);
    result = *r;
    std::vector<Pose3> poses;
    for (const NodeId id : g.nodeIds()) poses.push_back(*g.pose(id));
    return poses;
  };
  for (const Chain chain : {Chain::kOdometry, Chain::kSe2, Chain::kNone}) {
    SCOPED_TRACE(chain == Chain::kOdometry ? "odometry" : chain == Chain::kSe2 ? "SE2" : "no chain");
    OptimizeResult exact_result, cg_result;
    const std::vector<Pose3> exact = solveWith(LinearSolver::kSparseCholesky, chain, exact_result);
    const std::vector<Pose3> cg = solveWith(LinearSolver::kChainPreconditionedCg, chain, cg_result);
    ASSERT_EQ(exact.size(), cg.size());
    ASSERT_FALSE(exact.empty());
    EXPECT_EQ(exact_result.linear_solver, "SPARSE_NORMAL_CHOLESKY/SUITE_SPARSE");
    if (chain == Chain::kNone) {
      EXPECT_EQ(cg_result.linear_solver, "SPARSE_NORMAL_CHOLESKY/SUITE_SPARSE");
      EXPECT_NE(cg_result.message.find("No odometry chain"), std::string::npos) << cg_result.message;
    } else {
      EXPECT_EQ(cg_result.linear_solver, "CGNR/SUBSET(chain, absolute)/SUITE_SPARSE");
    }
    for (std::size_t i = 0; i < exact.size(); ++i) {
      EXPECT_LT(geometry::translationDistance(exact[i], cg[i]), 1e-4) << i;
      EXPECT_LT(geometry::rotationAngle(exact[i], cg[i]), 1e-5) << i;
    }
  }
}

// Test (3): random wrong closures are down-weighted by the robust loss.
TEST(PoseGraph, OutlierClosuresDownWeightedByCauchyLoss) {
  const Scenario s = makeScenario(3, 40);
  auto addOutliers = [&](PoseGraph& g) {
    std::mt19937 rng(99);
    std::uniform_int_distribution<int> node(0, 39);
    std::uniform_real_distribution<double> offset(-5.0, 5.0), yaw(-1.0, 1.0);
    int added = 0;
    while (added < 6) {
      const int i = node(rng), j = node(rng);
      if (std::abs(i - j) < 3) continue;
      ASSERT_TRUE(g.addLoopClosure(i, j, geometry::poseFromXyzRpy(offset(rng), offset(rng), 0, 0, 0, yaw(rng)),
                                   closureInformation())
                      .ok());
      ++added;
    }
  };
  PoseGraph clean = buildGraph(s, {});
  addTrueClosures(clean, s, 30);
  ASSERT_TRUE(clean.optimize().ok());
  const double err_clean = meanTranslationError(clean, s.truth);

  PoseGraph robust = buildGraph(s, {});
  addTrueClosures(robust, s, 30);
  addOutliers(robust);
  auto r = robust.optimize();
  ASSERT_TRUE(r.ok()) << r.error().message;
  const double err_robust = meanTranslationError(robust, s.truth);

  PoseGraphConfig plain_config;
  plain_config.loop_closure_loss = RobustLoss::kNone;
  PoseGraph plain = buildGraph(s, plain_config);
  addTrueClosures(plain, s, 30);
  addOutliers(plain);
  ASSERT_TRUE(plain.optimize().ok());
  const double err_plain = meanTranslationError(plain, s.truth);

  EXPECT_LT(err_robust, 1.5 * err_clean + 0.02) << "clean " << err_clean << " robust " << err_robust;
  // Without the robust loss the same outliers bend the map (the test would catch a missing loss).
  EXPECT_GT(err_plain, 5.0 * err_robust) << "plain " << err_plain << " robust " << err_robust;
}

// A closure switched off is left out of the solve: the optimum is bit for bit that of the graph without
// it; switched on again it pulls as before. Switching a closure that does not exist is an error.
TEST(PoseGraph, AClosureSwitchedOffIsLeftOutUntilSwitchedOn) {
  const Scenario s = makeScenario(5, 30);
  const Pose3 wrong = geometry::poseFromXyzRpy(3.0, -2.0, 0, 0, 0, 0.5);
  PoseGraphConfig plain;  // no robust loss, so that the wrong closure visibly pulls
  plain.loop_closure_loss = RobustLoss::kNone;
  PoseGraph without = buildGraph(s, plain);
  addTrueClosures(without, s, 30);
  PoseGraph with = buildGraph(s, plain);
  addTrueClosures(with, s, 30);
  ASSERT_TRUE(with.addLoopClosure(4, 20, wrong, closureInformation()).ok());
  PoseGraph switched = with;
  ASSERT_TRUE(switched.setLoopClosureActive(4, 20, false).ok());
  ASSERT_TRUE(without.optimize().ok());
  ASSERT_TRUE(switched.optimize().ok());
  ASSERT_TRUE(with.optimize().ok());
  for (int k = 0; k < 30; ++k) {
    EXPECT_EQ(switched.estimate(k).value(), without.estimate(k).value()) << "node " << k;
  }
  EXPECT_GT((with.estimate(20).value() - without.estimate(20).value()).head<2>().norm(), 0.1);
  ASSERT_TRUE(switched.setLoopClosureActive(4, 20, true).ok());
  ASSERT_TRUE(switched.optimize().ok());
  EXPECT_LT((switched.estimate(20).value() - with.estimate(20).value()).head<2>().norm(), 1e-4);
  const Status missing = switched.setLoopClosureActive(20, 4, false);  // the closure runs 4 -> 20
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("20 -> 4"), std::string::npos) << missing.error().message;
  EXPECT_FALSE(switched.setLoopClosureActive(0, 1, false).ok());  // odometry, not a closure
}

// Thesis Alg. 8 / Eq. 4.2-4.4: a partial closure moves only the constrained directions.
TEST(PoseGraph, PartialClosureConstrainsOnlyItsDirections) {
  auto graph = PoseGraph::create();
  ASSERT_TRUE(graph.ok());
  PoseGraph g = std::move(*graph);
  const Pose3 T0 = geometry::poseFromXyzRpy(0, 0, -2, 0, 0, 0);
  const Pose3 T1_odom = geometry::poseFromXyzRpy(3.0, 1.0, -2, 0, 0, 0.1);
  ASSERT_TRUE(g.addNode(0, T0).ok());
  ASSERT_TRUE(g.addNode(1, T1_odom).ok());
  const Eigen::Matrix3d weak = Eigen::Vector3d(1.0, 1.0, 1.0).asDiagonal();  // 1 m / 1 rad odometry
  ASSERT_TRUE(g.addOdometryFactor(0, 1, planarOdometry(T0, T1_odom), weak).ok());
  const Eigen::Matrix3d abs_info = Eigen::Matrix3d::Identity() * 1e4;
  ASSERT_TRUE(g.addAbsoluteFactor(0, Eigen::Vector3d(-2, 0, 0), abs_info).ok());
  ASSERT_TRUE(g.addAbsoluteFactor(1, Eigen::Vector3d(-2, 0, 0), abs_info).ok());

  // ICP says x = 3.4 and yaw = 0.05 (a wall facing x); y from ICP (5.0) is meaningless and excluded.
  Vector6d x_icp;
  x_icp << 3.4, 5.0, 0.0, 0.0, 0.0, 0.05;
  Eigen::MatrixXd V_u = Eigen::MatrixXd::Zero(2, 6);
  V_u(0, kX) = 1.0;
  V_u(1, kYaw) = 1.0;
  Matrix6d cov = Matrix6d::Identity() * 1e-6;
  auto closure = makePartialLoopClosure(V_u, x_icp, cov);
  ASSERT_TRUE(closure.ok()) << closure.error().message;
  EXPECT_EQ(closure->rank(), 2);
  EXPECT_NEAR(closure->measurement(0), 3.4, 1e-12);
  EXPECT_NEAR(closure->measurement(1), 0.05, 1e-12);
  ASSERT_TRUE(g.addPartialLoopClosure(0, 1, *closure).ok());
  auto r = g.optimize();
  ASSERT_TRUE(r.ok()) << r.error().message;
  const Vector6d x1 = toXyzRpy(*g.pose(1));
  // Relative pose of 1 in 0 (node 0 anchored at identity yaw): x and yaw follow the closure ...
  EXPECT_NEAR(x1(kX), 3.4, 1e-3);
  EXPECT_NEAR(x1(kYaw), 0.05, 1e-4);
  // ... and y stays at its odometry value (node 0 is anchored at yaw 0, so the odometry's heading
  // frame is the world frame), far from the excluded ICP value 5.0.
  EXPECT_NEAR(x1(kY), 1.0, 1e-3);
}

// Two nodes at different depths, each with an absolute factor (node 0 added off its measurement),
// odometry, and a closure of the planar registration (directions x and yaw) that disagrees with the
// odometry: its x in node 0's frame depends on node 0's pitch, since the nodes differ in depth.
struct AttitudeCase {
  Eigen::Vector3d m0{-2.0, 0.02, 0.3}, m1{-3.0, -0.01, 0.05};  // z, roll, pitch
  PoseGraph graph;
};

AttitudeCase attitudeCase(const PoseGraphConfig& config) {
  auto graph = PoseGraph::create(config);
  EXPECT_TRUE(graph.ok());
  AttitudeCase c{.graph = std::move(*graph)};
  PoseGraph& g = c.graph;
  const Pose3 T0 = geometry::poseFromXyzRpy(0, 0, -2.1, 0.0, 0.0, 0.0);
  const Pose3 T1 = geometry::poseFromXyzRpy(3.0, 1.0, -3.0, 0.0, 0.0, 0.1);
  EXPECT_TRUE(g.addNode(0, T0).ok());
  EXPECT_TRUE(g.addNode(1, T1).ok());
  EXPECT_TRUE(g.addOdometryFactor(0, 1, planarOdometry(T0, T1), Eigen::Matrix3d::Identity()).ok());
  const Eigen::Matrix3d weak = Eigen::Matrix3d::Identity() * 1e2;  // 0.1 m / 0.1 rad
  EXPECT_TRUE(g.addAbsoluteFactor(0, c.m0, weak).ok());
  EXPECT_TRUE(g.addAbsoluteFactor(1, c.m1, weak).ok());
  Vector6d x_icp;
  x_icp << 3.4, 0.0, 0.0, 0.0, 0.0, 0.05;
  Eigen::MatrixXd V_u = Eigen::MatrixXd::Zero(2, 6);
  V_u(0, kX) = 1.0;
  V_u(1, kYaw) = 1.0;
  auto closure = makePartialLoopClosure(V_u, x_icp, Matrix6d::Identity() * 1e-6);
  EXPECT_TRUE(closure.ok()) << closure.error().message;
  EXPECT_TRUE(g.addPartialLoopClosure(0, 1, *closure).ok());
  auto r = g.optimize();
  EXPECT_TRUE(r.ok()) << r.error().message;
  // The closure's directions hold either way.
  const Vector6d rel = toXyzRpy(g.pose(0)->inverse() * *g.pose(1));
  EXPECT_NEAR(rel(kX), 3.4, 1e-4);
  EXPECT_NEAR(rel(kYaw), 0.05, 1e-4);
  return c;
}

// attitude_from_absolute: no relative factor measures depth or attitude, so each node's z, roll and
// pitch are its absolute factor's, exactly.
TEST(PoseGraph, AttitudeFromAbsoluteHoldsTheMeasurement) {
  PoseGraphConfig config;
  config.attitude_from_absolute = true;
  const AttitudeCase c = attitudeCase(config);
  for (const auto& [id, m] : {std::pair{NodeId{0}, c.m0}, std::pair{NodeId{1}, c.m1}}) {
    const Vector6d x = toXyzRpy(*c.graph.pose(id));
    EXPECT_NEAR(x(kZ), m(0), 1e-12) << "node " << id;
    EXPECT_NEAR(x(kRoll), m(1), 1e-12) << "node " << id;
    EXPECT_NEAR(x(kPitch), m(2), 1e-12) << "node " << id;
  }
}

// Without it (the default) the attitudes are solved with the rest: the closure tilts node 0.
TEST(PoseGraph, AttitudeSolvedWithTheRestMovesUnderAPlanarClosure) {
  const AttitudeCase c = attitudeCase({});
  const Vector6d x0 = toXyzRpy(*c.graph.pose(0));
  EXPECT_GT(std::abs(x0(kPitch) - c.m0(2)), 1e-6);
  EXPECT_NEAR(x0(kPitch), c.m0(2), 1e-3);
}

TEST(PoseGraph, BadInputRejectedAndGraphUnchanged) {
  auto bad_config = PoseGraphConfig{};
  bad_config.loop_closure_loss_scale = -1.0;
  auto c = PoseGraph::create(bad_config);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("loop_closure_loss_scale"), std::string::npos);

  PoseGraph g = std::move(*PoseGraph::create());
  ASSERT_TRUE(g.optimize().ok() == false);  // no nodes
  ASSERT_TRUE(g.addNode(0, Pose3::Identity()).ok());
  ASSERT_TRUE(g.addNode(1, geometry::poseFromXyzRpy(1, 0, 0, 0, 0, 0)).ok());
  EXPECT_FALSE(g.addNode(1, Pose3::Identity()).ok());  // duplicate
  Pose3 nan_pose = Pose3::Identity();
  nan_pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(g.addNode(2, nan_pose).ok());

  const auto missing = g.addOdometryFactor(0, 7, Eigen::Vector3d(1, 0, 0), Eigen::Matrix3d::Identity());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("missing node 7"), std::string::npos) << missing.error().message;
  Eigen::Matrix3d singular = Eigen::Matrix3d::Identity();
  singular(2, 2) = 0.0;
  EXPECT_FALSE(g.addOdometryFactor(0, 1, Eigen::Vector3d(1, 0, 0), singular).ok());
  Eigen::Matrix3d nan_info = Eigen::Matrix3d::Identity();
  nan_info(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(g.addOdometryFactor(0, 1, Eigen::Vector3d(1, 0, 0), nan_info).ok());
  EXPECT_FALSE(g.addOdometryFactor(0, 1, Eigen::Vector3d(std::nan(""), 0, 0), Eigen::Matrix3d::Identity()).ok());
  EXPECT_FALSE(g.addAbsoluteFactor(9, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()).ok());
  EXPECT_FALSE(g.addLoopClosure(0, 0, Pose3::Identity(), Matrix6d::Identity()).ok());  // self loop
  Matrix6d nan6 = Matrix6d::Identity();
  nan6(3, 4) = nan6(4, 3) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(g.addLoopClosure(0, 1, Pose3::Identity(), nan6).ok());
  EXPECT_FALSE(g.addLoopClosure(0, 1, Pose3::Identity(), Matrix6d::Zero()).ok());
  EXPECT_EQ(g.numFactors(), 0u);

  // Partial closures: non-orthonormal V_u, singular projected covariance, wrong shapes.
  Eigen::MatrixXd V = Eigen::MatrixXd::Zero(2, 6);
  V(0, 0) = 1.0;
  V(1, 0) = 1.0;
  EXPECT_FALSE(makePartialLoopClosure(V, Vector6d::Zero(), Matrix6d::Identity()).ok());
  V(1, 0) = 0.0;
  V(1, 5) = 1.0;
  Matrix6d cov_singular = Matrix6d::Identity();
  cov_singular(5, 5) = 0.0;
  auto p = makePartialLoopClosure(V, Vector6d::Zero(), cov_singular);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().message.find("V_u Cov V_u^T"), std::string::npos) << p.error().message;
  EXPECT_FALSE(makePartialLoopClosure(Eigen::MatrixXd::Zero(0, 6), Vector6d::Zero(), Matrix6d::Identity()).ok());
  auto good = makePartialLoopClosure(V, Vector6d::Zero(), Matrix6d::Identity());
  ASSERT_TRUE(good.ok());
  EXPECT_FALSE(g.addPartialLoopClosure(0, 5, *good).ok());
  PartialLoopClosure tampered = *good;
  tampered.covariance(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(g.addPartialLoopClosure(0, 1, tampered).ok());
  EXPECT_EQ(g.numFactors(), 0u);
  EXPECT_FALSE(g.optimize().ok());  // no factors
  EXPECT_TRUE(g.pose(0).ok());
  EXPECT_FALSE(g.pose(42).ok());
}

TEST(PoseGraph, G2oFactorsFixAndInitialisationsRejectBadInput) {
  auto bad_config = PoseGraphConfig{};
  bad_config.initial_trust_region_radius = 0.0;
  auto c = PoseGraph::create(bad_config);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("initial_trust_region_radius"), std::string::npos) << c.error().message;

  PoseGraph g = std::move(*PoseGraph::create());
  EXPECT_FALSE(g.initializeFromSpanningTree().ok());  // no nodes
  ASSERT_TRUE(g.addNode(0, Pose3::Identity()).ok());
  ASSERT_TRUE(g.addNode(1, geometry::poseFromXyzRpy(1, 0, 0, 0, 0, 0)).ok());
  const auto missing = g.fixNode(42);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("missing node 42"), std::string::npos) << missing.error().message;
  EXPECT_FALSE(g.addSe2Factor(0, 1, Eigen::Vector3d(std::nan(""), 0, 0), Eigen::Matrix3d::Identity()).ok());
  EXPECT_FALSE(g.addSe2Factor(0, 1, Eigen::Vector3d(1, 0, 0), Eigen::Matrix3d::Zero()).ok());
  EXPECT_FALSE(g.addSe2Factor(0, 0, Eigen::Vector3d(1, 0, 0), Eigen::Matrix3d::Identity()).ok());
  EXPECT_FALSE(g.addSe3Factor(0, 1, Pose3::Identity(), Matrix6d::Zero()).ok());
  EXPECT_FALSE(g.addSe3Factor(1, 7, Pose3::Identity(), Matrix6d::Identity()).ok());
  EXPECT_EQ(g.numFactors(), 0u);
  // Two nodes and no factor: disconnected; the estimates are unchanged.
  const auto tree = g.initializeFromSpanningTree();
  ASSERT_FALSE(tree.ok());
  EXPECT_NE(tree.error().message.find("disconnected: node 1"), std::string::npos) << tree.error().message;
  EXPECT_FALSE(g.initializeChordal().ok());
  EXPECT_EQ((*g.estimate(1))(kX), 1.0);
  // A 3D factor is refused by the planar chordal initialisation and composed by the tree.
  ASSERT_TRUE(g.addSe3Factor(0, 1, geometry::poseFromXyzRpy(2, 0, 0.5, 0.1, 0, 0), Matrix6d::Identity()).ok());
  const auto chordal = g.initializeChordal();
  ASSERT_FALSE(chordal.ok());
  EXPECT_NE(chordal.error().message.find("SE3 factor 0 -> 1"), std::string::npos) << chordal.error().message;
  ASSERT_TRUE(g.initializeFromSpanningTree().ok());
  EXPECT_TRUE(g.pose(1)->isApprox(geometry::poseFromXyzRpy(2, 0, 0.5, 0.1, 0, 0), 1e-12));
}

}  // namespace
}  // namespace vog::slam
