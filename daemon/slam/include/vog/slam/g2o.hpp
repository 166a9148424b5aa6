#pragma once
// g2o pose-graph files (2D: VERTEX_SE2 / EDGE_SE2; 3D: VERTEX_SE3:QUAT / EDGE_SE3:QUAT; FIX), used to
// validate the optimiser on public datasets. Parsing is pure (text in, graph or error out).
//
// chi2 is g2o's: e = t2v(Z^-1 (X_i^-1 X_j)), chi2 = sum_edges e^T Omega e, where t2v is
// (x, y, normalised theta) in 2D and (x, y, z, qx, qy, qz) of the unit quaternion with qw >= 0 in 3D
// (g2o types_slam3d EdgeSE3::computeError / isometry3d_mappings toVectorMQT). Omega is given in the
// file as its upper triangle, row by row. The optimiser minimises exactly this chi2 with the
// vertices given by FIX lines held constant, or the lowest-id vertex when there is no FIX line.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
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
  std::map<std::int64_t, Eigen::Vector3d> vertices_se2;         // (x, y, theta)
  std::map<std::int64_t, geometry::Pose3> vertices_se3;         // T_world_vertex
  std::vector<G2oEdgeSE2> edges_se2;
  std::vector<G2oEdgeSE3> edges_se3;
  std::set<std::int64_t> fixed;                                  // from FIX lines

  std::size_t numVertices() const { return is_3d ? vertices_se3.size() : vertices_se2.size(); }
  std::size_t numEdges() const { return is_3d ? edges_se3.size() : edges_se2.size(); }
};

// Parses a whole file's text. Errors name the 1-based line number and what was wrong (unknown tag,
// missing or non-numeric field, trailing fields, non-finite value, duplicate vertex, edge to a
// missing vertex, non-positive-definite information, zero quaternion, 2D/3D mix, empty graph).
Result<G2oGraph> parseG2o(std::string_view text);

// g2o chi2 of the graph at its current vertex estimates.
double g2oChi2(const G2oGraph& graph);

// A copy of the graph whose vertices are re-initialised by composing the odometry chain: starting at
// the lowest id, each next vertex (in id order) is its predecessor composed with the edge between the
// two (either direction). Errors when a consecutive edge is missing.
Result<G2oGraph> initializeFromOdometry(const G2oGraph& graph);

struct G2oSolveOptions {
  int max_iterations = 100;
  double function_tolerance = 1e-9;
  double gradient_tolerance = 1e-14;
  double parameter_tolerance = 1e-12;
  // Levenberg-Marquardt starts almost as Gauss-Newton (little damping): public pose graphs are well
  // inside the basin of convergence, and a rejected step still shrinks the region. On M3500 this
  // takes 6 iterations instead of 26 with Ceres' default 1e4, to the same chi2.
  double initial_trust_region_radius = 1e8;

  Status validate() const;
};

struct G2oSolveResult {
  bool converged = false;
  int iterations = 0;
  double chi2_initial = 0.0;
  double chi2_final = 0.0;
  double solve_ms = 0.0;  // Ceres Solve() only (problem construction excluded)
  std::string linear_solver;
  std::string message;
};

// Optimises the vertices of `graph` in place (Levenberg-Marquardt, sparse Cholesky) minimising g2o's
// chi2. On error the graph is unchanged.
Result<G2oSolveResult> optimizeG2o(G2oGraph& graph, const G2oSolveOptions& options = {});

}  // namespace vog::slam
