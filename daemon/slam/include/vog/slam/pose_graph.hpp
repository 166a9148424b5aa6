#pragma once
// Submap pose graph (thesis 4.2, Fig. 4.4; Teixeira et al. 2016): one node per submap base pose,
// 6-DOF (x, y, z, roll, pitch, yaw). Factors:
//  - odometry: relative x, y, yaw between consecutive base poses (dead reckoning);
//  - absolute: z, roll, pitch of one node (depth sensor and IMU);
//  - loop closure: full 6-DOF relative pose from ICP, or partial (thesis Alg. 8, Eq. 4.2-4.4),
//    constraining only the well-conditioned directions V_u; loop closures carry a robust loss so one
//    wrong closure cannot bend the whole map;
//  - SE2 and SE3 relative poses with g2o's error (EDGE_SE2, EDGE_SE3:QUAT; see g2o.hpp), no robust
//    loss: the public datasets are checked through this class, on the solver vogd runs.
// Every residual is whitened by U = L^T with L L^T = Omega (see information.hpp).
// Solved with Ceres (Levenberg-Marquardt, sparse normal Cholesky on the configured backend, Eigen's
// or SuiteSparse's CHOLMOD, falling back to the other when it is not compiled in;
// OptimizeResult::linear_solver says which).

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/slam/pose_vector.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace vog::slam {

using NodeId = std::int64_t;

enum class RobustLoss { kNone, kHuber, kCauchy };

// The sparse Cholesky behind each Levenberg-Marquardt step. Both reach the same optimum (to
// rounding, about 1e-14 m); their speed differs with the graph (measured in daemon/slam/README.md).
enum class SparseBackend { kEigen, kSuiteSparse };

// How each Levenberg-Marquardt step's linear system is solved.
//  - kSparseCholesky: the normal equations factorised exactly on `sparse_backend`. Each loop closure
//    adds fill-in; on a survey repeated over the same lanes, where every pass closes loops with every
//    earlier one, the factorisation's cost grows much faster than the graph.
//  - kChainPreconditionedCg: conjugate gradients on the normal equations (Ceres' CGNR), preconditioned
//    by the exact factorisation of the odometry chain alone: the odometry factors, SE2 / SE3 factors
//    between consecutive ids (a g2o file's odometry) and the absolute factors (Ceres' SUBSET
//    preconditioner; a chain has no fill-in; subgraph preconditioning, Dellaert et al., IROS 2010).
//    Each step costs products with the Jacobian, linear in the factors, times the CG iterations,
//    which grow with the loops. The step is inexact (truncated Newton), so a solve stops near, not at,
//    the optimum the factorisation reaches (within the function tolerance). Without a chain in the
//    problem, factorised as above (OptimizeResult::message says so).
enum class LinearSolver { kSparseCholesky, kChainPreconditionedCg };

struct PoseGraphConfig {
  RobustLoss loop_closure_loss = RobustLoss::kCauchy;
  // Scale of the robust loss in whitened units (standard deviations): residuals beyond it are
  // down-weighted.
  double loop_closure_loss_scale = 1.0;
  int max_iterations = 100;
  // Levenberg-Marquardt's first trust-region radius; Ceres' default. A larger one makes the first
  // steps almost Gauss-Newton, fewer iterations on graphs well inside the basin of convergence
  // (the g2o datasets), more risk on graphs that are not.
  double initial_trust_region_radius = 1e4;
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;
  double parameter_tolerance = 1e-10;
  // Odometry and loop closures are relative in x, y, yaw: hold those of the first node added
  // (gauge freedom). Its z, roll and pitch stay free under its absolute factor.
  bool anchor_first_node = true;
  SparseBackend sparse_backend = SparseBackend::kSuiteSparse;
  LinearSolver linear_solver = LinearSolver::kSparseCholesky;
  // A node whose z, roll and pitch no relative factor measures (odometry, SE2 factors and closures
  // of the planar registration do not) takes them from its one absolute factor and holds them, as
  // thesis 4.1 reduces the vehicle's pose estimation to x, y and yaw: three unknowns per node instead
  // of six in every factorisation. Off: they are solved with the rest, and closures that held them
  // in their registration pull on them through the relative rotation.
  bool attitude_from_absolute = false;

  Status validate() const;
};

// Thesis Alg. 8: a loop closure that constrains only the k well-conditioned directions (rows of
// V_u, k x 6, orthonormal) of the relative pose x_icp = (x, y, z, roll, pitch, yaw) of `to` in
// `from`. measurement = V_u x_icp, covariance = V_u Cov V_u^T (k x k). The factor's residual is
// (V_u Cov V_u^T)^{-1/2} V_u (h(x_from, x_to) - x_icp) (Eq. 4.4), angles wrapped before projection.
struct PartialLoopClosure {
  Eigen::MatrixXd V_u;
  Vector6d x_icp = Vector6d::Zero();
  Eigen::VectorXd measurement;
  Eigen::MatrixXd covariance;

  int rank() const { return static_cast<int>(V_u.rows()); }
};

// Builds and checks a partial closure: V_u must have 1..6 orthonormal rows of 6 finite entries,
// x_icp finite, and V_u Cov V_u^T positive definite.
Result<PartialLoopClosure> makePartialLoopClosure(const Eigen::MatrixXd& V_u, const Vector6d& x_icp,
                                                  const Matrix6d& covariance);

// Planar odometry between two base poses as the odometry factor measures it: (dx, dy) of b in the
// heading frame of a (rotated by -yaw_a), and wrap(yaw_b - yaw_a).
Eigen::Vector3d planarOdometry(const geometry::Pose3& T_world_a, const geometry::Pose3& T_world_b);

struct OptimizeResult {
  bool converged = false;
  int iterations = 0;
  int free_nodes = 0;         // nodes the solve could move (optimizeFrom / optimizeNodes: the free ones)
  double initial_cost = 0.0;  // Ceres cost: 0.5 * sum of robustified squared whitened residuals
  double final_cost = 0.0;
  double solve_ms = 0.0;
  std::string linear_solver;  // e.g. "SPARSE_NORMAL_CHOLESKY/SUITE_SPARSE"
  std::string message;        // solver termination message (and any backend fallback note)
};

// Lifecycle: add nodes, then factors between existing nodes, optimize(), read poses; more nodes and
// factors may be added afterwards and optimize() called again (warm-started from the current
// estimates). Invariants: every stored estimate is finite; every factor references existing nodes
// and carries a positive-definite information; a failed add or a failed optimize changes nothing.
class PoseGraph {
 public:
  static Result<PoseGraph> create(const PoseGraphConfig& config = {});

  Status addNode(NodeId id, const geometry::Pose3& T_world_node);
  // (dx, dy, dyaw) as planarOdometry() computes it; information 3x3 in that order.
  Status addOdometryFactor(NodeId from, NodeId to, const Eigen::Vector3d& dxy_dyaw, const Eigen::Matrix3d& information);
  // Absolute (z, roll, pitch); information 3x3 in that order.
  Status addAbsoluteFactor(NodeId id, const Eigen::Vector3d& z_roll_pitch, const Eigen::Matrix3d& information);
  // Full 6-DOF closure: T_from_to measured; information 6x6 over (x, y, z, roll, pitch, yaw).
  Status addLoopClosure(NodeId from, NodeId to, const geometry::Pose3& T_from_to, const Matrix6d& information);
  Status addPartialLoopClosure(NodeId from, NodeId to, const PartialLoopClosure& closure);
  // Planar relative pose (x, y, theta) of `to` in `from` with g2o's EDGE_SE2 error
  // e = t2v(Z^-1 X_from^-1 X_to) over (x, y, yaw); information 3x3 over e. No robust loss.
  Status addSe2Factor(NodeId from, NodeId to, const Eigen::Vector3d& xy_theta, const Eigen::Matrix3d& information);
  // 3D relative pose with g2o's EDGE_SE3:QUAT error e = (t, qx, qy, qz) of Z^-1 X_from^-1 X_to, unit
  // quaternion with qw >= 0; information 6x6 over e. No robust loss.
  Status addSe3Factor(NodeId from, NodeId to, const geometry::Pose3& T_from_to, const Matrix6d& information);
  // Switches the loop closures (full or partial) between `from` and `to` off or back on: a closure
  // switched off stays in the graph but no solve, initialisation or neighbourhood uses it until it is
  // switched on again. Errors, changing nothing, when no loop closure joins the two nodes.
  Status setLoopClosureActive(NodeId from, NodeId to, bool active);
  // Holds all six components of an existing node constant in optimize() (g2o's FIX).
  Status fixNode(NodeId id);

  // The roots of the initialisations below: the fixed nodes, else the first node added.
  // Spanning-tree initialisation: breadth-first from the roots over the relative factors (factor
  // order among a node's neighbours), each reached node set to its parent composed with the tree
  // factor. Odometry and SE2 factors set x, y, yaw only; SE3 factors and full loop closures set all
  // six components; partial closures are not used. Errors, changing nothing, when a node is not
  // reachable from the roots (the graph is disconnected).
  Status initializeFromSpanningTree();
  // Planar linear initialisation (Carlone et al., "A fast and accurate approximation for planar pose
  // graph optimization", IJRR 2014, with the headings as unit complex numbers (cos, sin), as in the
  // chordal relaxation of Carlone et al., ICRA 2015): first all headings from all relative factors
  // by one sparse linear least-squares problem (roots held), then x, y with those headings by a
  // second one, each factor weighted by its marginal information. z, roll and pitch are kept. Uses
  // odometry, SE2 and the (x, y, yaw) of full loop closures (exact when roll and pitch are zero, the
  // vehicle's case, pose_vector.hpp); partial closures are not used; SE3 factors are refused (3D
  // graphs: use the spanning tree). No iteration, so no local minimum: the start for optimize()
  // after a long drift (a large accumulated heading error) where odometry or a spanning tree leads
  // the solver into a wrong minimum. Errors, changing nothing, on a disconnected graph.
  Status initializeChordal();

  Result<OptimizeResult> optimize();
  // Optimises only the nodes with id >= first_free: the others are held at their estimates and the
  // factors between held nodes are left out, so the cost follows the part of the graph that is free,
  // not the whole graph. The held nodes' estimates stay bit for bit. Where a loop closure joins the
  // newest node to an older one, freeing the nodes from the older one on gives the whole graph's
  // optimum when nothing else links the free part to the held one (a chain with one loop), and
  // otherwise the optimum with the held part as it was estimated. When no factor joins the free part
  // to a held node, its first node is anchored as the first node is in optimize(). Errors as
  // optimize(), and when no node is free.
  Result<OptimizeResult> optimizeFrom(NodeId first_free);
  // Optimises only the nodes in `free` (all existing; errors naming a missing one or an empty set),
  // the others held as in optimizeFrom(): the cost follows the free set and its factors. When no
  // factor joins the free set to a held node, its lowest id is anchored (or the first node, if free).
  Result<OptimizeResult> optimizeNodes(const std::set<NodeId>& free);
  // Up to `max_nodes` existing nodes nearest to `seeds` in hops over the relative factors, breadth
  // first from all seeds at once, each hop's nodes taken in id order (deterministic). The free set of
  // a local solve around a new node and the nodes its closures reach.
  std::set<NodeId> neighbourhood(const std::vector<NodeId>& seeds, std::size_t max_nodes) const;

  bool hasNode(NodeId id) const { return nodes_.count(id) != 0; }
  Result<geometry::Pose3> pose(NodeId id) const;
  // The estimate as the graph stores it, (x, y, z, roll, pitch, yaw). Persistence keeps these rather
  // than pose(): a Pose3 -> xyzrpy round trip is not bit-exact, and a restored graph must warm-start
  // the next optimisation from exactly the same values.
  Result<Vector6d> estimate(NodeId id) const;
  // Overwrites the estimate of an existing node (restoring persisted estimates); must be finite.
  Status setEstimate(NodeId id, const Vector6d& x_world_node);
  std::vector<NodeId> nodeIds() const;
  std::size_t numNodes() const { return nodes_.size(); }
  std::size_t numFactors() const { return relative_.size() + absolute_.size(); }
  bool isFixed(NodeId id) const { return fixed_.count(id) != 0; }
  const PoseGraphConfig& config() const { return config_; }

 private:
  explicit PoseGraph(const PoseGraphConfig& config) : config_(config) {}
  Status checkNodes(NodeId from, NodeId to, const char* what) const;
  // optimize() over the `free_count` nodes for which `free` holds, the lowest of them window_first.
  Result<OptimizeResult> solve(const std::function<bool(NodeId)>& free, NodeId window_first, std::size_t free_count);

  enum class RelativeKind { kOdometry, kLoopClosure, kPartialLoopClosure, kSe2, kSe3 };
  // A relative factor. Odometry and closures: residual = sqrt_information * P * (h(from, to) -
  // measurement) where P selects the constrained components (odometry: x, y, yaw of the planar
  // relative pose; closures: V_u). SE2 / SE3: residual = sqrt_information * g2o error.
  struct RelativeFactor {
    RelativeKind kind;
    NodeId from;
    NodeId to;
    Vector6d measurement;              // odometry and SE2: (dx, dy, 0, 0, 0, dyaw); closures: x_icp; SE3: unused
    Eigen::MatrixXd projection;        // k x 6
    Eigen::MatrixXd sqrt_information;  // k x k, upper triangular
    geometry::Pose3 T_from_to = geometry::Pose3::Identity();  // SE3 only
    bool active = true;                                       // loop closures: setLoopClosureActive
  };
  std::vector<NodeId> roots() const;
  // Breadth-first order from the roots over the relative factors except partial closures: (node,
  // index of its tree factor, or -1 for a root); error naming a node that is not reached.
  Result<std::vector<std::pair<NodeId, std::ptrdiff_t>>> spanningTree() const;
  struct AbsoluteFactor {
    NodeId id;
    Eigen::Vector3d z_roll_pitch;
    Eigen::Matrix3d sqrt_information;
  };

  PoseGraphConfig config_;
  std::map<NodeId, Vector6d> nodes_;  // estimates, (x, y, z, roll, pitch, yaw)
  NodeId first_node_ = 0;
  std::set<NodeId> fixed_;
  std::vector<RelativeFactor> relative_;
  std::vector<AbsoluteFactor> absolute_;
};

}  // namespace vog::slam
