#pragma once
// g2o pose-graph files (2D: VERTEX_SE2 / EDGE_SE2; 3D: VERTEX_SE3:QUAT / EDGE_SE3:QUAT; FIX), used to
// validate the optimiser on public datasets. Parsing is pure (text in, graph or error out).
//
// chi2 is g2o's: e = t2v(Z^-1 (X_i^-1 X_j)), chi2 = sum_edges e^T Omega e, where t2v is
// (x, y, normalised theta) in 2D and (x, y, z, qx, qy, qz) of the unit quaternion with qw >= 0 in 3D
// (g2o types_slam3d EdgeSE3::computeError / isometry3d_mappings toVectorMQT). Omega is given in the
// file as its upper triangle, row by row. The optimiser minimises exactly this chi2 with the
// vertices given by FIX lines held constant, or the lowest-id vertex when there is no FIX line.
// It is the vehicle's PoseGraph (pose_graph.hpp) with one SE2 or SE3 factor per edge: the same
// solver, options and backend as vogd's own graphs. Its nodes are (x, y, z, roll, pitch, yaw)
// (pose_vector.hpp): a 3D graph with vertices near pitch +-90 deg is outside what it handles well.
//
// A file may have edges and no VERTEX lines (a common form of public datasets): the vertices are
// then the edges' ids, initialised along a spanning tree from the fixed vertex (identity), and a
// disconnected graph is an error.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/slam/pose_graph.hpp"
#include "vog/slam/pose_vector.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace vog::slam {

struct G2oEdgeSE2 {
  std::int64_t from = 0;
  std::int64_t to = 0;
  Eigen::Vector3d measurement = Eigen::Vector3d::Zero();  // (x, y, theta) of `to` in `from`
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
};

struct G2oEdgeSE3 {
  std::int64_t from = 0;
  std::int64_t to = 0;
  geometry::Pose3 T_from_to = geometry::Pose3::Identity();
  Matrix6d information = Matrix6d::Identity();  // over (x, y, z, qx, qy, qz)
};

// A parsed graph is either 2D or 3D (mixing is rejected). Vertices are keyed by id.
struct G2oGraph {
  bool is_3d = false;
  std::map<std::int64_t, Eigen::Vector3d> vertices_se2;  // (x, y, theta)
  std::map<std::int64_t, geometry::Pose3> vertices_se3;  // T_world_vertex
  std::vector<G2oEdgeSE2> edges_se2;
  std::vector<G2oEdgeSE3> edges_se3;
  std::set<std::int64_t> fixed;  // from FIX lines
  // True when the file had no VERTEX lines: the vertices were created from the edges' ids and
  // initialised by initializeFromSpanningTree().
  bool vertices_from_edges = false;

  std::size_t numVertices() const { return is_3d ? vertices_se3.size() : vertices_se2.size(); }
  std::size_t numEdges() const { return is_3d ? edges_se3.size() : edges_se2.size(); }
};

// Parses a whole file's text. Errors name the 1-based line number and what was wrong (unknown tag,
// missing or non-numeric field, trailing fields, non-finite value, duplicate vertex, edge to a
// missing vertex, non-positive-definite information, zero quaternion, 2D/3D mix), or the graph
// (empty; without VERTEX lines: disconnected, naming a vertex that no chain of edges reaches).
Result<G2oGraph> parseG2o(std::string_view text);

// g2o chi2 of the graph at its current vertex estimates.
double g2oChi2(const G2oGraph& graph);

// A copy of the graph whose vertices are re-initialised by composing the odometry chain: starting at
// the lowest id, each next vertex (in id order) is its predecessor composed with the edge between the
// two (either direction). Errors when a consecutive edge is missing.
Result<G2oGraph> initializeFromOdometry(const G2oGraph& graph);

// A copy of the graph initialised by PoseGraph::initializeFromSpanningTree (breadth-first from the
// fixed vertices, or the lowest id, composing each tree edge). Works for any connected graph; errors
// on a disconnected one.
Result<G2oGraph> initializeFromSpanningTree(const G2oGraph& graph);

// A copy of the graph initialised by PoseGraph::initializeChordal (headings by a linear least-squares
// problem over all edges, then positions by a second one). 2D graphs only; errors on a 3D or a
// disconnected graph. A start from which the solver avoids the local minima that odometry
// initialisation falls into after a large accumulated heading error.
Result<G2oGraph> initializeChordal(const G2oGraph& graph);

// The graph as a PoseGraph with `config`: nodes in id order at the vertex estimates (2D vertices at
// z = roll = pitch = 0), one addSe2Factor / addSe3Factor per edge in file order, and the FIX
// vertices (or the lowest id when there is none) fixed.
Result<PoseGraph> toPoseGraph(const G2oGraph& graph, const PoseGraphConfig& config = {});

struct G2oSolveResult {
  bool converged = false;
  int iterations = 0;
  double chi2_initial = 0.0;
  double chi2_final = 0.0;
  double solve_ms = 0.0;  // Ceres Solve() only (problem construction excluded)
  std::string linear_solver;
  std::string message;
};

// Optimises the vertices of `graph` in place with PoseGraph::optimize() on toPoseGraph(graph, config),
// minimising g2o's chi2 (config.validate() is the one check of the options). On error the graph is
// unchanged.
Result<G2oSolveResult> optimizeG2o(G2oGraph& graph, const PoseGraphConfig& config = {});

}  // namespace vog::slam
