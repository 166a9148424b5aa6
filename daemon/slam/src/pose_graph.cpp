#include "vog/slam/pose_graph.hpp"

#include "vog/slam/information.hpp"
#include "solver_backend.hpp"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>

namespace vog::slam {
namespace {

template <typename T>
T wrap(const T& a) {
  using std::atan2;
  using std::cos;
  using std::sin;
  return atan2(sin(a), cos(a));
}

// R = Rz(yaw) Ry(pitch) Rx(roll), as geometry::poseFromXyzRpy.
template <typename T>
Eigen::Matrix<T, 3, 3> rotationFromRpy(const T& roll, const T& pitch, const T& yaw) {
  using std::cos;
  using std::sin;
  const T cr = cos(roll), sr = sin(roll), cp = cos(pitch), sp = sin(pitch), cy = cos(yaw), sy = sin(yaw);
  Eigen::Matrix<T, 3, 3> R;
  R << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
      sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,   //
      -sp, cp * sr, cp * cr;
  return R;
}

// xyzrpy of T_a^-1 T_b from the two 6-vectors (the loop-closure model h of thesis Eq. 4.2).
template <typename T>
Eigen::Matrix<T, 6, 1> relativeXyzRpy(const T* a, const T* b) {
  using std::asin;
  using std::atan2;
  const Eigen::Matrix<T, 3, 3> Ra = rotationFromRpy(a[3], a[4], a[5]);
  const Eigen::Matrix<T, 3, 3> Rb = rotationFromRpy(b[3], b[4], b[5]);
  const Eigen::Matrix<T, 3, 1> dp(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
  const Eigen::Matrix<T, 3, 1> t = Ra.transpose() * dp;
  const Eigen::Matrix<T, 3, 3> R = Ra.transpose() * Rb;
  Eigen::Matrix<T, 6, 1> h;
  h << t(0), t(1), t(2), atan2(R(2, 1), R(2, 2)), asin(-R(2, 0)), atan2(R(1, 0), R(0, 0));
  return h;
}

// Planar odometry model: (dx, dy) in the heading frame of a, dyaw.
template <typename T>
Eigen::Matrix<T, 6, 1> planarRelative(const T* a, const T* b) {
  using std::cos;
  using std::sin;
  const T c = cos(a[5]), s = sin(a[5]);
  const T dx = b[0] - a[0], dy = b[1] - a[1];
  Eigen::Matrix<T, 6, 1> h;
  h << c * dx + s * dy, -s * dx + c * dy, T(0), T(0), T(0), b[5] - a[5];
  return h;
}

class RelativeCost {
 public:
  RelativeCost(bool planar, const Vector6d& measurement, const Eigen::MatrixXd& whitened_projection)
      : planar_(planar), measurement_(measurement), W_(whitened_projection) {}

  template <typename T>
  bool operator()(const T* const a, const T* const b, T* residuals) const {
    const Eigen::Matrix<T, 6, 1> h = planar_ ? planarRelative(a, b) : relativeXyzRpy(a, b);
    Eigen::Matrix<T, 6, 1> e;
    for (int i = 0; i < 6; ++i) e(i) = h(i) - T(measurement_(i));
    for (int i = kRoll; i <= kYaw; ++i) e(i) = wrap(e(i));
    for (Eigen::Index r = 0; r < W_.rows(); ++r) {
      T acc(0);
      for (int c = 0; c < 6; ++c) acc += T(W_(r, c)) * e(c);
      residuals[r] = acc;
    }
    return true;
  }

 private:
  bool planar_;
  Vector6d measurement_;
  Eigen::MatrixXd W_;  // sqrt_information * projection, k x 6
};

class AbsoluteCost {
 public:
  AbsoluteCost(const Eigen::Vector3d& z_roll_pitch, const Eigen::Matrix3d& sqrt_information)
      : m_(z_roll_pitch), U_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* const x, T* residuals) const {
    const Eigen::Matrix<T, 3, 1> e(x[kZ] - T(m_(0)), wrap(x[kRoll] - T(m_(1))), wrap(x[kPitch] - T(m_(2))));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residuals);
    r = U_.cast<T>() * e;
    return true;
  }

 private:
  Eigen::Vector3d m_;
  Eigen::Matrix3d U_;
};

bool finite6(const Vector6d& v) { return v.allFinite(); }

}  // namespace

Status PoseGraphConfig::validate() const {
  std::ostringstream os;
  if (!(std::isfinite(loop_closure_loss_scale) && loop_closure_loss_scale > 0.0)) {
    os << "loop_closure_loss_scale must be finite and > 0, got " << loop_closure_loss_scale;
  } else if (max_iterations < 1) {
    os << "max_iterations must be >= 1, got " << max_iterations;
  } else if (!(function_tolerance > 0.0)) {
    os << "function_tolerance must be > 0, got " << function_tolerance;
  } else if (!(gradient_tolerance > 0.0)) {
    os << "gradient_tolerance must be > 0, got " << gradient_tolerance;
  } else if (!(parameter_tolerance > 0.0)) {
    os << "parameter_tolerance must be > 0, got " << parameter_tolerance;
  } else {
    return Status::success();
  }
  return Error{"pose graph config: " + os.str()};
}

Result<PartialLoopClosure> makePartialLoopClosure(const Eigen::MatrixXd& V_u, const Vector6d& x_icp,
                                                  const Matrix6d& covariance) {
  if (V_u.cols() != 6 || V_u.rows() < 1 || V_u.rows() > 6) {
    std::ostringstream os;
    os << "partial loop closure: V_u must be k x 6 with 1 <= k <= 6, got " << V_u.rows() << "x" << V_u.cols();
    return Error{os.str()};
  }
  if (!V_u.allFinite()) return Error{"partial loop closure: V_u has NaN or infinite entries"};
  const Eigen::MatrixXd gram = V_u * V_u.transpose();
  if (!gram.isApprox(Eigen::MatrixXd::Identity(V_u.rows(), V_u.rows()), 1e-6)) {
    return Error{"partial loop closure: rows of V_u are not orthonormal"};
  }
  if (!x_icp.allFinite()) return Error{"partial loop closure: x_icp has NaN or infinite entries"};
  PartialLoopClosure closure;
  closure.V_u = V_u;
  closure.x_icp = x_icp;
  closure.measurement = V_u * x_icp;
  closure.covariance = V_u * covariance * V_u.transpose();
  // Rejects a singular or NaN projected covariance.
  const auto info = informationFromCovariance(closure.covariance, "partial loop closure covariance V_u Cov V_u^T");
  if (!info) return info.error();
  return closure;
}

Eigen::Vector3d planarOdometry(const geometry::Pose3& T_world_a, const geometry::Pose3& T_world_b) {
  const Vector6d a = toXyzRpy(T_world_a);
  const Vector6d b = toXyzRpy(T_world_b);
  const Vector6d h = planarRelative(a.data(), b.data());
  return {h(kX), h(kY), geometry::wrapAngle(h(kYaw))};
}

Result<PoseGraph> PoseGraph::create(const PoseGraphConfig& config) {
  if (Status s = config.validate(); !s) return s.error();
  return PoseGraph(config);
}

Status PoseGraph::addNode(NodeId id, const geometry::Pose3& T_world_node) {
  if (nodes_.count(id) != 0) return Error{"pose graph: node " + std::to_string(id) + " already exists"};
  if (!geometry::isValidPose(T_world_node)) {
    return Error{"pose graph: node " + std::to_string(id) + " has a non-finite or non-rigid pose"};
  }
  if (nodes_.empty()) first_node_ = id;
  nodes_.emplace(id, toXyzRpy(T_world_node));
  return Status::success();
}

Status PoseGraph::checkNodes(NodeId from, NodeId to, const char* what) const {
  for (const NodeId id : {from, to}) {
    if (nodes_.count(id) == 0) {
      std::ostringstream os;
      os << "pose graph: " << what << " " << from << " -> " << to << " references missing node " << id;
      return Error{os.str()};
    }
  }
  if (from == to) {
    std::ostringstream os;
    os << "pose graph: " << what << " connects node " << from << " to itself";
    return Error{os.str()};
  }
  return Status::success();
}

Status PoseGraph::addOdometryFactor(NodeId from, NodeId to, const Eigen::Vector3d& dxy_dyaw,
                                    const Eigen::Matrix3d& information) {
  if (Status s = checkNodes(from, to, "odometry factor"); !s) return s;
  if (!dxy_dyaw.allFinite()) return Error{"pose graph: odometry factor measurement has NaN or infinite entries"};
  auto U = sqrtInformation(information, "pose graph: odometry factor information");
  if (!U) return U.error();
  RelativeFactor f{RelativeKind::kOdometry, from, to, Vector6d::Zero(), Eigen::MatrixXd::Zero(3, 6), *U};
  f.measurement << dxy_dyaw(0), dxy_dyaw(1), 0, 0, 0, dxy_dyaw(2);
  f.projection(0, kX) = 1.0;
  f.projection(1, kY) = 1.0;
  f.projection(2, kYaw) = 1.0;
  relative_.push_back(std::move(f));
  return Status::success();
}

Status PoseGraph::addAbsoluteFactor(NodeId id, const Eigen::Vector3d& z_roll_pitch,
                                    const Eigen::Matrix3d& information) {
  if (nodes_.count(id) == 0) {
    return Error{"pose graph: absolute factor references missing node " + std::to_string(id)};
  }
  if (!z_roll_pitch.allFinite()) return Error{"pose graph: absolute factor measurement has NaN or infinite entries"};
  auto U = sqrtInformation(information, "pose graph: absolute factor information");
  if (!U) return U.error();
  absolute_.push_back(AbsoluteFactor{id, z_roll_pitch, Eigen::Matrix3d(*U)});
  return Status::success();
}

Status PoseGraph::addLoopClosure(NodeId from, NodeId to, const geometry::Pose3& T_from_to,
                                 const Matrix6d& information) {
  if (Status s = checkNodes(from, to, "loop closure"); !s) return s;
  if (!geometry::isValidPose(T_from_to)) return Error{"pose graph: loop closure has a non-finite or non-rigid pose"};
  auto U = sqrtInformation(information, "pose graph: loop closure information");
  if (!U) return U.error();
  relative_.push_back(RelativeFactor{RelativeKind::kLoopClosure, from, to, toXyzRpy(T_from_to),
                                     Eigen::MatrixXd::Identity(6, 6), *U});
  return Status::success();
}

Status PoseGraph::addPartialLoopClosure(NodeId from, NodeId to, const PartialLoopClosure& closure) {
  if (Status s = checkNodes(from, to, "partial loop closure"); !s) return s;
  // Re-check: the struct is public and may have been edited after makePartialLoopClosure().
  Matrix6d cov_full = Matrix6d::Zero();
  if (closure.V_u.cols() == 6 && closure.covariance.rows() == closure.V_u.rows() &&
      closure.covariance.cols() == closure.V_u.rows()) {
    cov_full = closure.V_u.transpose() * closure.covariance * closure.V_u;
  } else {
    return Error{"pose graph: partial loop closure has inconsistent V_u / covariance sizes"};
  }
  auto checked = makePartialLoopClosure(closure.V_u, closure.x_icp, cov_full);
  if (!checked) return Error{"pose graph: " + checked.error().message};
  auto info = informationFromCovariance(closure.covariance, "pose graph: partial loop closure covariance");
  if (!info) return info.error();
  auto U = sqrtInformation(*info, "pose graph: partial loop closure information");
  if (!U) return U.error();
  relative_.push_back(
      RelativeFactor{RelativeKind::kLoopClosure, from, to, closure.x_icp, closure.V_u, *U});
  return Status::success();
}

Result<OptimizeResult> PoseGraph::optimize() {
  OptimizeResult result;
  if (nodes_.empty()) return Error{"pose graph: nothing to optimize (no nodes)"};

  std::map<NodeId, Vector6d> work = nodes_;  // the solver writes here; committed only on success
  ceres::Problem::Options problem_options;
  ceres::Problem problem(problem_options);
  for (const RelativeFactor& f : relative_) {
    const Eigen::MatrixXd W = f.sqrt_information * f.projection;
    const bool planar = f.kind == RelativeKind::kOdometry;
    auto* cost = new ceres::AutoDiffCostFunction<RelativeCost, ceres::DYNAMIC, 6, 6>(
        new RelativeCost(planar, f.measurement, W), static_cast<int>(W.rows()));
    ceres::LossFunction* loss = nullptr;
    if (f.kind == RelativeKind::kLoopClosure) {
      switch (config_.loop_closure_loss) {
        case RobustLoss::kNone: break;
        case RobustLoss::kHuber: loss = new ceres::HuberLoss(config_.loop_closure_loss_scale); break;
        case RobustLoss::kCauchy: loss = new ceres::CauchyLoss(config_.loop_closure_loss_scale); break;
      }
    }
    problem.AddResidualBlock(cost, loss, work.at(f.from).data(), work.at(f.to).data());
  }
  for (const AbsoluteFactor& f : absolute_) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AbsoluteCost, 3, 6>(
                                 new AbsoluteCost(f.z_roll_pitch, f.sqrt_information)),
                             nullptr, work.at(f.id).data());
  }
  if (problem.NumResidualBlocks() == 0) return Error{"pose graph: nothing to optimize (no factors)"};
  double* anchor = work.at(first_node_).data();
  if (config_.anchor_first_node && problem.HasParameterBlock(anchor)) {
    problem.SetManifold(anchor, new ceres::SubsetManifold(6, {kX, kY, kYaw}));
  }

  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = config_.max_iterations;
  options.function_tolerance = config_.function_tolerance;
  options.gradient_tolerance = config_.gradient_tolerance;
  options.parameter_tolerance = config_.parameter_tolerance;
  options.num_threads = 1;  // STYLE 5: algorithms create no threads
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  std::string note;
  detail::selectLinearSolver(options, result.linear_solver, note);
  std::string why;
  if (!options.IsValid(&why)) return Error{"pose graph: invalid solver options: " + why};

  ceres::Solver::Summary summary;
  const auto t0 = std::chrono::steady_clock::now();
  ceres::Solve(options, &problem, &summary);
  result.solve_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;  // iteration 0 is the initial state
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.message = note + summary.message;
  if (summary.termination_type == ceres::FAILURE) {
    return Error{"pose graph: solver failed: " + summary.message};
  }
  for (const auto& [id, x] : work) {
    if (!finite6(x)) return Error{"pose graph: solver produced a non-finite estimate for node " + std::to_string(id)};
  }
  for (auto& [id, x] : work) {
    for (int i = kRoll; i <= kYaw; ++i) x(i) = geometry::wrapAngle(x(i));
  }
  nodes_ = std::move(work);
  return result;
}

Result<geometry::Pose3> PoseGraph::pose(NodeId id) const {
  const auto it = nodes_.find(id);
  if (it == nodes_.end()) return Error{"pose graph: no node " + std::to_string(id)};
  return fromXyzRpy(it->second);
}

Result<Vector6d> PoseGraph::estimate(NodeId id) const {
  const auto it = nodes_.find(id);
  if (it == nodes_.end()) return Error{"pose graph: no node " + std::to_string(id)};
  return it->second;
}

Status PoseGraph::setEstimate(NodeId id, const Vector6d& x_world_node) {
  const auto it = nodes_.find(id);
  if (it == nodes_.end()) return Error{"pose graph: no node " + std::to_string(id)};
  if (!x_world_node.allFinite()) {
    return Error{"pose graph: estimate of node " + std::to_string(id) + " is not finite"};
  }
  it->second = x_world_node;
  return Status::success();
}

std::vector<NodeId> PoseGraph::nodeIds() const {
  std::vector<NodeId> ids;
  ids.reserve(nodes_.size());
  for (const auto& kv : nodes_) ids.push_back(kv.first);
  return ids;
}

}  // namespace vog::slam
