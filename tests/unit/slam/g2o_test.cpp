// g2o import and chi2: public datasets against independently computed reference optima,
// synthetic 3D graphs, and malformed input.
#include "vog/slam/g2o.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

namespace vog::slam {
namespace {

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Direct evaluation of g2o's 2D chi2 from the file text, independent of parseG2o/g2oChi2: explicit
// trigonometry, e = t2v(Z^-1 X_i^-1 X_j).
double directChi2Se2(const std::string& text) {
  std::map<long, std::array<double, 3>> v;
  std::istringstream in(text);
  std::string tag;
  std::vector<std::string> edge_lines;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    ls >> tag;
    if (tag == "VERTEX_SE2") {
      long id;
      double x, y, t;
      ls >> id >> x >> y >> t;
      v[id] = {x, y, t};
    } else if (tag == "EDGE_SE2") {
      edge_lines.push_back(line);
    }
  }
  double chi2 = 0.0;
  for (const std::string& l : edge_lines) {
    std::istringstream ls(l);
    long i, j;
    double zx, zy, zt, I11, I12, I13, I22, I23, I33;
    ls >> tag >> i >> j >> zx >> zy >> zt >> I11 >> I12 >> I13 >> I22 >> I23 >> I33;
    const auto& a = v.at(i);
    const auto& b = v.at(j);
    // X_i^-1 X_j
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    const double rx = std::cos(a[2]) * dx + std::sin(a[2]) * dy;
    const double ry = -std::sin(a[2]) * dx + std::cos(a[2]) * dy;
    const double rt = b[2] - a[2];
    // Z^-1 (...)
    const double ex = std::cos(zt) * (rx - zx) + std::sin(zt) * (ry - zy);
    const double ey = -std::sin(zt) * (rx - zx) + std::cos(zt) * (ry - zy);
    const double et = std::atan2(std::sin(rt - zt), std::cos(rt - zt));
    chi2 += ex * (I11 * ex + I12 * ey + I13 * et) + ey * (I12 * ex + I22 * ey + I23 * et) +
            et * (I13 * ex + I23 * ey + I33 * et);
  }
  return chi2;
}

struct Dataset {
  const char* file;
  double reference_chi2;
};

class PublicDataset : public ::testing::TestWithParam<Dataset> {};

TEST_P(PublicDataset, InitialChi2MatchesDirectEvaluationAndOptimumMatchesReference) {
  const Dataset d = GetParam();
  const std::string text = readFile(vog::test::sharedDataDir() / "posegraph" / d.file);
  ASSERT_FALSE(text.empty()) << d.file;
  auto graph = parseG2o(text);
  ASSERT_TRUE(graph.ok()) << graph.error().message;
  EXPECT_FALSE(graph->is_3d);

  const double direct = directChi2Se2(text);
  EXPECT_NEAR(g2oChi2(*graph), direct, 1e-9 * direct);

  for (const bool odom_init : {false, true}) {
    G2oGraph g = *graph;
    if (odom_init) {
      auto o = initializeFromOdometry(g);
      ASSERT_TRUE(o.ok()) << o.error().message;
      g = std::move(*o);
    }
    auto r = optimizeG2o(g);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_NEAR(r->chi2_initial, g2oChi2(odom_init ? *initializeFromOdometry(*graph) : *graph), 1e-9 * r->chi2_initial);
    // Target: within 0.01 % of the reference optimum, from either initialisation.
    EXPECT_NEAR(r->chi2_final, d.reference_chi2, 1e-4 * d.reference_chi2) << d.file << (odom_init ? " odom" : " file");
    EXPECT_TRUE(r->converged) << r->message;
    // The first vertex is the gauge: unchanged.
    EXPECT_EQ(g.vertices_se2.begin()->second, graph->vertices_se2.begin()->second);
  }
}

INSTANTIATE_TEST_SUITE_P(G2o, PublicDataset,
                         ::testing::Values(Dataset{"M3500.g2o", 137.9129509}, Dataset{"intel.g2o", 45.00469581}),
                         [](const ::testing::TestParamInfo<Dataset>& param_info) {
                           std::string name = param_info.param.file;
                           return name.substr(0, name.find('.'));
                         });

// A synthetic 3D graph: ground-truth poses on a helix, noisy relative measurements with a non-diagonal
// information, loop edges every 10 vertices. Written as g2o text, parsed back and optimised.
struct Synthetic3d {
  std::string text;
  std::vector<geometry::Pose3> truth;
};

Synthetic3d makeSynthetic3d(unsigned seed, int n) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  Synthetic3d s;
  for (int i = 0; i < n; ++i) {
    const double a = 0.3 * i;
    s.truth.push_back(
        geometry::poseFromXyzRpy(3 * std::cos(a), 3 * std::sin(a), 0.1 * i, 0.05 * std::sin(a), 0.02 * i, a + 1.57));
  }
  Matrix6d info = Matrix6d::Identity() * 400.0;
  info.bottomRightCorner<3, 3>() *= 10.0;
  info(0, 1) = info(1, 0) = 100.0;
  info(3, 5) = info(5, 3) = -300.0;
  std::ostringstream os;
  os.precision(17);
  auto writeEdge = [&](int i, int j) {
    const geometry::Pose3 Z0 = s.truth[static_cast<std::size_t>(i)].inverse() * s.truth[static_cast<std::size_t>(j)];
    const Eigen::Vector3d dt(0.02 * noise(rng), 0.02 * noise(rng), 0.02 * noise(rng));
    const Eigen::Vector3d dr(0.005 * noise(rng), 0.005 * noise(rng), 0.005 * noise(rng));
    geometry::Pose3 Z = Z0;
    Z.translation() += dt;
    Z.linear() = Z.linear() * Eigen::AngleAxisd(dr.norm(), dr.normalized()).toRotationMatrix();
    const Eigen::Quaterniond q(Z.linear());
    os << "EDGE_SE3:QUAT " << i << " " << j << " " << Z.translation().transpose() << " " << q.x() << " " << q.y() << " "
       << q.z() << " " << q.w();
    for (int r = 0; r < 6; ++r) {
      for (int c = r; c < 6; ++c) os << " " << info(r, c);
    }
    os << "\n";
  };
  for (int i = 0; i < n; ++i) {
    // Initial vertices: truth perturbed by a drift that grows along the chain.
    geometry::Pose3 T = s.truth[static_cast<std::size_t>(i)];
    T.translation() += Eigen::Vector3d(0.03 * i, -0.02 * i, 0.01 * i);
    T.linear() = T.linear() * Eigen::AngleAxisd(0.004 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Quaterniond q(T.linear());
    os << "VERTEX_SE3:QUAT " << i << " " << T.translation().transpose() << " " << q.x() << " " << q.y() << " " << q.z()
       << " " << q.w() << "\n";
  }
  os << "FIX 0\n";
  for (int i = 0; i + 1 < n; ++i) writeEdge(i, i + 1);
  for (int i = 0; i + 10 < n; i += 10) writeEdge(i + 10, i);
  s.text = os.str();
  return s;
}

TEST(G2o3d, OptimisationRecoversHelixAndChi2MatchesQuaternionDefinition) {
  const Synthetic3d s = makeSynthetic3d(7, 60);
  auto graph = parseG2o(s.text);
  ASSERT_TRUE(graph.ok()) << graph.error().message;
  ASSERT_TRUE(graph->is_3d);
  EXPECT_EQ(graph->numVertices(), 60u);
  EXPECT_EQ(graph->numEdges(), 59u + 5u);
  EXPECT_EQ(graph->fixed.count(0), 1u);

  // Direct chi2 of one edge: e = (t, qvec with qw >= 0) of Z^-1 X_i^-1 X_j.
  const G2oEdgeSE3& e0 = graph->edges_se3.front();
  const geometry::Pose3 D =
      e0.T_from_to.inverse() * graph->vertices_se3.at(e0.from).inverse() * graph->vertices_se3.at(e0.to);
  Eigen::Quaterniond q(D.linear());
  if (q.w() < 0) q.coeffs() *= -1;
  Vector6d err;
  err << D.translation(), q.vec();
  G2oGraph single = *graph;
  single.edges_se3.resize(1);
  EXPECT_NEAR(g2oChi2(single), err.dot(e0.information * err), 1e-9);

  auto r = optimizeG2o(*graph);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_LT(r->chi2_final, 1e-2 * r->chi2_initial);
  // With 64 six-dimensional residuals of unit whitened variance, chi2 is about its DOF, not more than 3x.
  EXPECT_LT(r->chi2_final, 3.0 * 6 * 64);
  double max_err = 0.0;
  for (int i = 0; i < 60; ++i) {
    max_err = std::max(max_err,
                       geometry::translationDistance(graph->vertices_se3.at(i), s.truth[static_cast<std::size_t>(i)]));
  }
  EXPECT_LT(max_err, 0.3);
  // Odometry initialisation composes the chain and reaches the same optimum.
  auto fresh = parseG2o(s.text);
  ASSERT_TRUE(fresh.ok());
  auto odom = initializeFromOdometry(*fresh);
  ASSERT_TRUE(odom.ok()) << odom.error().message;
  auto r2 = optimizeG2o(*odom);
  ASSERT_TRUE(r2.ok());
  EXPECT_NEAR(r2->chi2_final, r->chi2_final, 1e-4 * r->chi2_final);
}

void expectError(const std::string& text, const std::string& needle) {
  auto g = parseG2o(text);
  ASSERT_FALSE(g.ok()) << "accepted: " << text;
  EXPECT_NE(g.error().message.find(needle), std::string::npos) << g.error().message;
}

TEST(G2oParse, MalformedLinesRejectedWithLineNumber) {
  const std::string v = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
  expectError(v + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0\n", "line 3");      // too few fields
  expectError(v + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1 7\n", "line 3");  // trailing field
  expectError(v + "EDGE_SE2 0 1 1 x 0 1 0 0 1 0 1\n", "'x' is not a finite number");
  expectError(v + "EDGE_SE2 0 1 1 nan 0 1 0 0 1 0 1\n", "line 3");
  expectError(v + "EDGE_SE2 0 1.5 1 0 0 1 0 0 1 0 1\n", "not an integer id");
  expectError(v + "\n# comment\nEDGE_SE2 0 7 1 0 0 1 0 0 1 0 1\n", "line 5: edge references missing vertex 7");
  expectError(v + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 0\n", "line 3: information");    // singular information
  expectError(v + "EDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n", "not positive definite");  // indefinite
  expectError(v + "VERTEX_SE2 1 0 0 0\n", "line 3: duplicate vertex id 1");
  expectError(v + "VERTEX_XY 2 0 0\n", "line 3: unsupported tag 'VERTEX_XY'");
  expectError(v + "VERTEX_SE3:QUAT 2 0 0 0 0 0 0 1\n", "line 3: mixes 2D and 3D");
  expectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 0\n", "line 1: zero quaternion");
  expectError(v + "FIX 9\n", "line 3: FIX references missing vertex 9");
  expectError("# nothing\n", "no vertices");
  // A valid file with CRLF line ends and comments parses.
  auto ok = parseG2o("# header\r\nVERTEX_SE2 0 0 0 0\r\nVERTEX_SE2 1 1 0 0\r\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\r\n");
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->numEdges(), 1u);
  EXPECT_NEAR(g2oChi2(*ok), 0.0, 1e-12);
}

// A file with only EDGE_SE2 lines (intel without its VERTEX lines): the vertices come from the
// edges, initialised along a spanning tree, and the solve reaches the same optimum as from the file.
TEST(G2oEdgeOnly, IntelWithoutVerticesSolvesToTheReferenceChi2) {
  const std::string text = readFile(vog::test::sharedDataDir() / "posegraph" / "intel.g2o");
  ASSERT_FALSE(text.empty());
  std::istringstream in(text);
  std::string line, edges_only;
  while (std::getline(in, line)) {
    if (line.rfind("VERTEX", 0) != 0) edges_only += line + "\n";
  }
  auto with_vertices = parseG2o(text);
  ASSERT_TRUE(with_vertices.ok()) << with_vertices.error().message;
  auto graph = parseG2o(edges_only);
  ASSERT_TRUE(graph.ok()) << graph.error().message;
  EXPECT_TRUE(graph->vertices_from_edges);
  EXPECT_FALSE(with_vertices->vertices_from_edges);
  EXPECT_EQ(graph->numVertices(), with_vertices->numVertices());
  EXPECT_EQ(graph->numEdges(), with_vertices->numEdges());
  EXPECT_EQ(graph->vertices_se2.begin()->second, Eigen::Vector3d::Zero());  // first vertex at identity

  auto from_file = optimizeG2o(*with_vertices);
  ASSERT_TRUE(from_file.ok()) << from_file.error().message;
  auto from_edges = optimizeG2o(*graph);
  ASSERT_TRUE(from_edges.ok()) << from_edges.error().message;
  EXPECT_NEAR(from_edges->chi2_final, from_file->chi2_final, 1e-6 * from_file->chi2_final);
  EXPECT_NEAR(from_edges->chi2_final, 45.00469581, 1e-4 * 45.00469581);
  // The odometry chain initialisation also works on it (intel has every consecutive edge).
  auto odom = initializeFromOdometry(*graph);
  ASSERT_TRUE(odom.ok()) << odom.error().message;
}

TEST(G2oEdgeOnly, BrokenChainIsInitialisedAlongTheTreeAndDisconnectedIsAnError) {
  // Vertex 2 is reached only through 3: the odometry chain (1 -> 2) is broken, the tree is not.
  const std::string info = " 100 0 0 100 0 100\n";
  const std::string text = "EDGE_SE2 0 1 1 0 0" + info + "EDGE_SE2 1 3 2 0 0" + info + "EDGE_SE2 3 2 -1 0 0" + info;
  auto graph = parseG2o(text);
  ASSERT_TRUE(graph.ok()) << graph.error().message;
  ASSERT_EQ(graph->numVertices(), 4u);
  EXPECT_TRUE(graph->vertices_se2.at(2).isApprox(Eigen::Vector3d(2, 0, 0), 1e-12)) << graph->vertices_se2.at(2);
  EXPECT_TRUE(graph->vertices_se2.at(3).isApprox(Eigen::Vector3d(3, 0, 0), 1e-12)) << graph->vertices_se2.at(3);
  EXPECT_NEAR(g2oChi2(*graph), 0.0, 1e-18);
  auto odom = initializeFromOdometry(*graph);
  ASSERT_FALSE(odom.ok());
  EXPECT_NE(odom.error().message.find("consecutive vertices 1 and 2"), std::string::npos) << odom.error().message;

  // Vertices 5 and 6 are connected to each other but not to 0.
  auto split = parseG2o(text + "EDGE_SE2 5 6 1 0 0" + info);
  ASSERT_FALSE(split.ok());
  EXPECT_NE(split.error().message.find("no VERTEX lines"), std::string::npos) << split.error().message;
  EXPECT_NE(split.error().message.find("disconnected: node 5"), std::string::npos) << split.error().message;
  // With a FIX line the tree starts there (the fixed vertex keeps the identity).
  auto fixed = parseG2o("FIX 3\n" + text);
  ASSERT_TRUE(fixed.ok()) << fixed.error().message;
  EXPECT_EQ(fixed->vertices_se2.at(3), Eigen::Vector3d::Zero());
  EXPECT_TRUE(fixed->vertices_se2.at(0).isApprox(Eigen::Vector3d(-3, 0, 0), 1e-12)) << fixed->vertices_se2.at(0);
}

TEST(G2oParse, OdometryInitialisationNeedsConsecutiveEdges) {
  auto g = parseG2o("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\nEDGE_SE2 0 2 2 0 0 1 0 0 1 0 1\n");
  ASSERT_TRUE(g.ok());
  auto o = initializeFromOdometry(*g);
  ASSERT_FALSE(o.ok());
  EXPECT_NE(o.error().message.find("0 and 1"), std::string::npos) << o.error().message;
}

// A 2D graph on a circle traversed `laps` times: ground-truth vertices, noisy odometry edges
// (i -> i + 1) and closures to the same place one lap earlier, each edge with its own noise and the
// matching diagonal information (seeded, deterministic).
struct LoopScenarioParams {
  unsigned seed = 1;
  int per_lap = 50;
  int laps = 3;
  double radius_m = 10.0;
  double sigma_xy_m = 0.05;
  double sigma_theta_rad = 0.02;
  int closure_every = 5;
  double closure_sigma_xy_m = 0.05;
  double closure_sigma_theta_rad = 0.02;
};

G2oGraph makeLoopScenario(const LoopScenarioParams& p) {
  std::mt19937 rng(p.seed);
  std::normal_distribution<double> g(0.0, 1.0);
  G2oGraph graph;
  const int n = p.per_lap * p.laps;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * std::numbers::pi * i / p.per_lap;
    graph.vertices_se2[i] = Eigen::Vector3d(p.radius_m * std::cos(a), p.radius_m * std::sin(a),
                                            geometry::wrapAngle(a + std::numbers::pi / 2));
  }
  auto edge = [&](int i, int j, double sxy, double sth) {
    const Eigen::Matrix3d info = Eigen::Vector3d(1.0 / (sxy * sxy), 1.0 / (sxy * sxy), 1.0 / (sth * sth)).asDiagonal();
    const Eigen::Vector3d& a = graph.vertices_se2.at(i);
    const Eigen::Vector3d& b = graph.vertices_se2.at(j);
    const double c = std::cos(a(2)), s = std::sin(a(2));
    const double dx = b(0) - a(0), dy = b(1) - a(1);
    G2oEdgeSE2 e;
    e.from = i;
    e.to = j;
    e.measurement = Eigen::Vector3d(c * dx + s * dy + sxy * g(rng), -s * dx + c * dy + sxy * g(rng),
                                    geometry::wrapAngle(b(2) - a(2) + sth * g(rng)));
    e.information = info;
    graph.edges_se2.push_back(e);
  };
  for (int i = 0; i + 1 < n; ++i) edge(i, i + 1, p.sigma_xy_m, p.sigma_theta_rad);
  for (int i = p.per_lap; i < n; i += p.closure_every) {
    edge(i - p.per_lap, i, p.closure_sigma_xy_m, p.closure_sigma_theta_rad);
  }
  return graph;
}

double solvedChi2(G2oGraph g) {
  auto r = optimizeG2o(g);
  if (!r.ok()) return -1.0;
  return r->chi2_final;
}

// Three laps of a 100-pose circle with heading noise of 0.2 rad per step (tens of degrees of
// accumulated heading error within a lap) and a closure to the previous lap every 10 poses: from
// odometry the solver stops in a local minimum; from the chordal initialisation it reaches the
// optimum found from the ground truth.
TEST(G2oInit, ChordalAvoidsTheLocalMinimumOdometryEndsIn) {
  for (const unsigned seed : {2u, 3u}) {
    LoopScenarioParams p;
    p.seed = seed;
    p.per_lap = 100;
    p.laps = 3;
    p.sigma_xy_m = 0.1;
    p.sigma_theta_rad = 0.2;
    p.closure_sigma_xy_m = 0.05;
    p.closure_sigma_theta_rad = 0.05;
    p.closure_every = 10;
    const G2oGraph truth = makeLoopScenario(p);
    const double chi2_truth = solvedChi2(truth);
    ASSERT_GT(chi2_truth, 0.0);
    auto odom = initializeFromOdometry(truth);
    ASSERT_TRUE(odom.ok()) << odom.error().message;
    const double chi2_odom = solvedChi2(*odom);
    auto chordal = initializeChordal(truth);
    ASSERT_TRUE(chordal.ok()) << chordal.error().message;
    // The initialisation holds the gauge vertex and is no worse a start than odometry.
    EXPECT_EQ(chordal->vertices_se2.at(0), truth.vertices_se2.at(0));
    EXPECT_LT(g2oChi2(*chordal), g2oChi2(*odom)) << "seed " << seed;
    const double chi2_chordal = solvedChi2(*chordal);
    EXPECT_GT(chi2_odom, 2.0 * chi2_truth) << "seed " << seed << ": odometry start no longer ends in a local minimum";
    EXPECT_NEAR(chi2_chordal, chi2_truth, 1e-6 * chi2_truth) << "seed " << seed << " odom " << chi2_odom;
  }
}

TEST(G2oInit, ChordalRefusesDisconnectedAnd3dGraphs) {
  LoopScenarioParams p;
  G2oGraph graph = makeLoopScenario(p);
  graph.vertices_se2[1000] = Eigen::Vector3d::Zero();  // no edge reaches it
  auto chordal = initializeChordal(graph);
  ASSERT_FALSE(chordal.ok());
  EXPECT_NE(chordal.error().message.find("disconnected: node 1000"), std::string::npos) << chordal.error().message;
  auto tree = initializeFromSpanningTree(graph);
  ASSERT_FALSE(tree.ok());
  EXPECT_NE(tree.error().message.find("disconnected: node 1000"), std::string::npos) << tree.error().message;
  auto graph3d = parseG2o(makeSynthetic3d(7, 12).text);
  ASSERT_TRUE(graph3d.ok()) << graph3d.error().message;
  auto refused = initializeChordal(*graph3d);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("3D"), std::string::npos) << refused.error().message;
  // The spanning tree handles 3D: composing exact edges would give zero chi2; noisy ones, a start
  // from which the solve reaches the optimum found from the file's vertices.
  auto tree3d = initializeFromSpanningTree(*graph3d);
  ASSERT_TRUE(tree3d.ok()) << tree3d.error().message;
  G2oGraph from_file = *graph3d;
  auto r_file = optimizeG2o(from_file);
  auto r_tree = optimizeG2o(*tree3d);
  ASSERT_TRUE(r_file.ok() && r_tree.ok());
  EXPECT_NEAR(r_tree->chi2_final, r_file->chi2_final, 1e-6 * r_file->chi2_final);
}

}  // namespace
}  // namespace vog::slam
