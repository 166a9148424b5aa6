#include "vog/slam/pose_graph.hpp"

#include "vog/slam/information.hpp"
#include "solver_backend.hpp"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>

#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <functional>
#include <iterator>
#include <memory>
#include <sstream>
#include <unordered_set>

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

// g2o EDGE_SE2 residual on two 6-vectors with analytic Jacobians (only x, y, yaw enter):
// e_xy = R(yaw_a + z_th)^T (p_b - p_a) - R(z_th)^T z_xy, e_th = wrap(yaw_b - yaw_a - z_th); r = U e.
// This equals t2v(Z^-1 X_a^-1 X_b) (g2o types_slam2d EdgeSE2::computeError).
class Se2Cost final : public ceres::SizedCostFunction<3, 6, 6> {
 public:
  Se2Cost(const Eigen::Vector3d& z, const Eigen::Matrix3d& sqrt_information) : U_(sqrt_information) {
    z_th_ = z(2);
    z_xy_local_ = Eigen::Rotation2Dd(z(2)).toRotationMatrix().transpose() * z.head<2>();
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* a = parameters[0];
    const double* b = parameters[1];
    const double phi = a[kYaw] + z_th_;
    const double c = std::cos(phi), s = std::sin(phi);
    const double dx = b[kX] - a[kX], dy = b[kY] - a[kY];
    Eigen::Vector3d e;
    e << c * dx + s * dy - z_xy_local_(0), -s * dx + c * dy - z_xy_local_(1), geometry::wrapAngle(b[kYaw] - phi);
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r = U_ * e;
    if (jacobians != nullptr) {
      // Columns x, y, yaw of each 3 x 6 Jacobian; z, roll, pitch do not enter.
      if (jacobians[0] != nullptr) {
        Eigen::Matrix3d Ja;
        Ja << -c, -s, -s * dx + c * dy, s, -c, -c * dx - s * dy, 0, 0, -1;
        store(U_ * Ja, jacobians[0]);
      }
      if (jacobians[1] != nullptr) {
        Eigen::Matrix3d Jb;
        Jb << c, s, 0, -s, c, 0, 0, 0, 1;
        store(U_ * Jb, jacobians[1]);
      }
    }
    return true;
  }

 private:
  static void store(const Eigen::Matrix3d& J_xy_yaw, double* out) {
    Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> J(out);
    J.setZero();
    J.col(kX) = J_xy_yaw.col(0);
    J.col(kY) = J_xy_yaw.col(1);
    J.col(kYaw) = J_xy_yaw.col(2);
  }

  Eigen::Matrix3d U_;
  double z_th_ = 0.0;
  Eigen::Vector2d z_xy_local_;
};

// Unit quaternion of R = Rz(yaw) Ry(pitch) Rx(roll).
template <typename T>
Eigen::Quaternion<T> quaternionFromRpy(const T& roll, const T& pitch, const T& yaw) {
  using std::cos;
  using std::sin;
  const T h(0.5);
  const Eigen::Quaternion<T> qz(cos(h * yaw), T(0), T(0), sin(h * yaw));
  const Eigen::Quaternion<T> qy(cos(h * pitch), T(0), sin(h * pitch), T(0));
  const Eigen::Quaternion<T> qx(cos(h * roll), sin(h * roll), T(0), T(0));
  return qz * qy * qx;
}

// g2o EDGE_SE3:QUAT residual on two 6-vectors (autodiff): D = Z^-1 X_a^-1 X_b,
// e = (t_D, vec(q_D) with qw >= 0) (g2o types_slam3d EdgeSE3::computeError, toVectorMQT); r = U e.
class Se3Cost {
 public:
  Se3Cost(const geometry::Pose3& Z, const Matrix6d& sqrt_information) : U_(sqrt_information) {
    const geometry::Pose3 Zinv = Z.inverse();
    zq_inv_ = Eigen::Quaterniond(Zinv.linear()).normalized();
    zt_inv_ = Zinv.translation();
  }

  template <typename T>
  bool operator()(const T* const a, const T* const b, T* residuals) const {
    const Eigen::Quaternion<T> qa = quaternionFromRpy(a[kRoll], a[kPitch], a[kYaw]);
    const Eigen::Quaternion<T> qb = quaternionFromRpy(b[kRoll], b[kPitch], b[kYaw]);
    const Eigen::Matrix<T, 3, 1> ta(a[kX], a[kY], a[kZ]), tb(b[kX], b[kY], b[kZ]);
    const Eigen::Quaternion<T> qa_inv = qa.conjugate();
    const Eigen::Quaternion<T> zq = zq_inv_.cast<T>();
    const Eigen::Quaternion<T> q_d = zq * (qa_inv * qb);
    const Eigen::Matrix<T, 3, 1> t_d = zq * (qa_inv * (tb - ta)) + zt_inv_.cast<T>();
    const T sign = q_d.w() < T(0) ? T(-1) : T(1);
    Eigen::Matrix<T, 6, 1> e;
    e << t_d, sign * q_d.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residuals);
    r = U_.cast<T>() * e;
    return true;
  }

 private:
  Matrix6d U_;
  Eigen::Quaterniond zq_inv_;
  Eigen::Vector3d zt_inv_;
};

bool finite6(const Vector6d& v) { return v.allFinite(); }

// The pose components a factor kind constrains, indexed by PoseIndex.
using ComponentMask = std::array<bool, 6>;
constexpr ComponentMask kPlanarMask{true, true, false, false, false, true};
constexpr ComponentMask kAbsoluteMask{false, false, true, true, true, false};
constexpr ComponentMask kAllMask{true, true, true, true, true, true};

Eigen::Matrix2d rotation2(double angle_rad) { return Eigen::Rotation2Dd(angle_rad).toRotationMatrix(); }

}  // namespace

Status PoseGraphConfig::validate() const {
  std::ostringstream os;
  if (!(std::isfinite(loop_closure_loss_scale) && loop_closure_loss_scale > 0.0)) {
    os << "loop_closure_loss_scale must be finite and > 0, got " << loop_closure_loss_scale;
  } else if (max_iterations < 1) {
    os << "max_iterations must be >= 1, got " << max_iterations;
  } else if (!(std::isfinite(initial_trust_region_radius) && initial_trust_region_radius > 0.0)) {
    os << "initial_trust_region_radius must be finite and > 0, got " << initial_trust_region_radius;
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
  relative_.push_back(
      RelativeFactor{RelativeKind::kLoopClosure, from, to, toXyzRpy(T_from_to), Eigen::MatrixXd::Identity(6, 6), *U});
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
  relative_.push_back(RelativeFactor{RelativeKind::kPartialLoopClosure, from, to, closure.x_icp, closure.V_u, *U});
  return Status::success();
}

Status PoseGraph::addSe2Factor(NodeId from, NodeId to, const Eigen::Vector3d& xy_theta,
                               const Eigen::Matrix3d& information) {
  if (Status s = checkNodes(from, to, "SE2 factor"); !s) return s;
  if (!xy_theta.allFinite()) return Error{"pose graph: SE2 factor measurement has NaN or infinite entries"};
  auto U = sqrtInformation(information, "pose graph: SE2 factor information");
  if (!U) return U.error();
  RelativeFactor f{RelativeKind::kSe2, from, to, Vector6d::Zero(), Eigen::MatrixXd(), *U};
  f.measurement << xy_theta(0), xy_theta(1), 0, 0, 0, xy_theta(2);
  relative_.push_back(std::move(f));
  return Status::success();
}

Status PoseGraph::addSe3Factor(NodeId from, NodeId to, const geometry::Pose3& T_from_to, const Matrix6d& information) {
  if (Status s = checkNodes(from, to, "SE3 factor"); !s) return s;
  if (!geometry::isValidPose(T_from_to)) return Error{"pose graph: SE3 factor has a non-finite or non-rigid pose"};
  auto U = sqrtInformation(information, "pose graph: SE3 factor information");
  if (!U) return U.error();
  RelativeFactor f{RelativeKind::kSe3, from, to, Vector6d::Zero(), Eigen::MatrixXd(), *U};
  f.T_from_to = T_from_to;
  relative_.push_back(std::move(f));
  return Status::success();
}

Status PoseGraph::setLoopClosureActive(NodeId from, NodeId to, bool active) {
  std::vector<RelativeFactor*> closures;
  for (RelativeFactor& f : relative_) {
    const bool closure = f.kind == RelativeKind::kLoopClosure || f.kind == RelativeKind::kPartialLoopClosure;
    if (closure && f.from == from && f.to == to) closures.push_back(&f);
  }
  if (closures.empty()) {
    return Error{"pose graph: no loop closure " + std::to_string(from) + " -> " + std::to_string(to) + " to switch " +
                 (active ? "on" : "off")};
  }
  for (RelativeFactor* f : closures) f->active = active;
  return Status::success();
}

Status PoseGraph::fixNode(NodeId id) {
  if (nodes_.count(id) == 0) return Error{"pose graph: cannot fix missing node " + std::to_string(id)};
  fixed_.insert(id);
  return Status::success();
}

std::vector<NodeId> PoseGraph::roots() const {
  if (!fixed_.empty()) return {fixed_.begin(), fixed_.end()};
  if (nodes_.empty()) return {};
  return {first_node_};
}

Result<std::vector<std::pair<NodeId, std::ptrdiff_t>>> PoseGraph::spanningTree() const {
  std::map<NodeId, std::vector<std::size_t>> adjacent;
  for (std::size_t k = 0; k < relative_.size(); ++k) {
    if (relative_[k].kind == RelativeKind::kPartialLoopClosure || !relative_[k].active) continue;
    adjacent[relative_[k].from].push_back(k);
    adjacent[relative_[k].to].push_back(k);
  }
  std::vector<std::pair<NodeId, std::ptrdiff_t>> order;
  std::set<NodeId> reached;
  std::deque<NodeId> queue;
  for (const NodeId r : roots()) {
    reached.insert(r);
    order.emplace_back(r, -1);
    queue.push_back(r);
  }
  while (!queue.empty()) {
    const NodeId u = queue.front();
    queue.pop_front();
    const auto it = adjacent.find(u);
    if (it == adjacent.end()) continue;
    for (const std::size_t k : it->second) {
      const NodeId v = relative_[k].from == u ? relative_[k].to : relative_[k].from;
      if (!reached.insert(v).second) continue;
      order.emplace_back(v, static_cast<std::ptrdiff_t>(k));
      queue.push_back(v);
    }
  }
  if (reached.size() != nodes_.size()) {
    for (const auto& [id, x] : nodes_) {
      if (reached.count(id) != 0) continue;
      std::ostringstream os;
      os << "pose graph: the graph is disconnected: node " << id << " is not connected to node " << roots().front()
         << " by any chain of relative factors (" << reached.size() << " of " << nodes_.size() << " nodes reached)";
      return Error{os.str()};
    }
  }
  return order;
}

Status PoseGraph::initializeFromSpanningTree() {
  if (nodes_.empty()) return Error{"pose graph: nothing to initialise (no nodes)"};
  auto tree = spanningTree();
  if (!tree) return Error{"spanning-tree initialisation: " + tree.error().message};
  std::map<NodeId, Vector6d> work = nodes_;
  for (const auto& [v, k] : *tree) {
    if (k < 0) continue;
    const RelativeFactor& f = relative_[static_cast<std::size_t>(k)];
    const bool forward = f.to == v;  // the parent is `from`
    const Vector6d& parent = work.at(forward ? f.from : f.to);
    Vector6d& child = work.at(v);
    if (f.kind == RelativeKind::kOdometry || f.kind == RelativeKind::kSe2) {
      // Both measure (dx, dy) of `to` in the heading frame of `from`, and dyaw.
      const Eigen::Vector2d d(f.measurement(kX), f.measurement(kY));
      const double dyaw = f.measurement(kYaw);
      if (forward) {
        const Eigen::Vector2d p = parent.head<2>() + rotation2(parent(kYaw)) * d;
        child(kX) = p.x();
        child(kY) = p.y();
        child(kYaw) = geometry::wrapAngle(parent(kYaw) + dyaw);
      } else {
        const double yaw = parent(kYaw) - dyaw;
        const Eigen::Vector2d p = parent.head<2>() - rotation2(yaw) * d;
        child(kX) = p.x();
        child(kY) = p.y();
        child(kYaw) = geometry::wrapAngle(yaw);
      }
    } else {
      const geometry::Pose3 Z = f.kind == RelativeKind::kSe3 ? f.T_from_to : fromXyzRpy(f.measurement);
      child = toXyzRpy(fromXyzRpy(parent) * (forward ? Z : Z.inverse()));
    }
    if (!finite6(child)) {
      return Error{"spanning-tree initialisation: non-finite estimate for node " + std::to_string(v)};
    }
  }
  nodes_ = std::move(work);
  return Status::success();
}

Status PoseGraph::initializeChordal() {
  if (nodes_.empty()) return Error{"pose graph: nothing to initialise (no nodes)"};
  // The planar view of each usable factor: (dx, dy) of `to` in the heading frame of `from`, dyaw,
  // the marginal information of the heading and of (x, y) in the error's frame, which is the
  // heading frame of `from` turned by `frame_offset` (g2o's SE2 error is expressed in Z's frame).
  struct Planar {
    NodeId from, to;
    Eigen::Vector2d d;
    double dyaw;
    double info_yaw;
    Eigen::Matrix2d sqrt_info_xy;  // S with S^T S = marginal (x, y) information
    double frame_offset;
  };
  std::vector<Planar> planar;
  for (const RelativeFactor& f : relative_) {
    if (f.kind == RelativeKind::kPartialLoopClosure || !f.active) continue;
    if (f.kind == RelativeKind::kSe3) {
      std::ostringstream os;
      os << "chordal initialisation: SE3 factor " << f.from << " -> " << f.to
         << " is 3D; the initialisation is planar (use the spanning tree for 3D graphs)";
      return Error{os.str()};
    }
    const Eigen::MatrixXd info = f.sqrt_information.transpose() * f.sqrt_information;
    Eigen::Matrix3d cov;  // over (x, y, yaw)
    if (f.kind == RelativeKind::kLoopClosure) {
      const Matrix6d cov6 = info.inverse();
      const std::array<int, 3> idx{kX, kY, kYaw};
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
          cov(r, c) = cov6(idx[static_cast<std::size_t>(r)], idx[static_cast<std::size_t>(c)]);
      }
    } else {
      cov = Eigen::Matrix3d(info).inverse();
    }
    const Eigen::Matrix2d info_xy = cov.topLeftCorner<2, 2>().inverse();
    const Eigen::LLT<Eigen::Matrix2d> llt(info_xy);
    if (llt.info() != Eigen::Success || !(cov(2, 2) > 0.0)) {
      std::ostringstream os;
      os << "chordal initialisation: factor " << f.from << " -> " << f.to << " has a singular planar information";
      return Error{os.str()};
    }
    planar.push_back(Planar{f.from, f.to, Eigen::Vector2d(f.measurement(kX), f.measurement(kY)), f.measurement(kYaw),
                            1.0 / cov(2, 2), llt.matrixU(), f.kind == RelativeKind::kSe2 ? f.measurement(kYaw) : 0.0});
  }
  auto tree = spanningTree();
  if (!tree) return Error{"chordal initialisation: " + tree.error().message};

  std::map<NodeId, int> index;  // unknowns: every node but the roots
  const std::vector<NodeId> root_ids = roots();
  const std::set<NodeId> root_set(root_ids.begin(), root_ids.end());
  for (const auto& [id, x] : nodes_) {
    if (root_set.count(id) == 0) index.emplace(id, static_cast<int>(index.size()));
  }
  if (index.empty()) return Status::success();
  const int n = static_cast<int>(index.size());
  std::map<NodeId, Vector6d> work = nodes_;

  // Solves min sum_f ||to_f x_to - from_f x_from - rhs_f||^2 over one 2-vector per node (each factor's
  // rows already whitened), the roots' blocks known and moved to the right-hand side.
  struct Rows {
    Eigen::Matrix2d to;    // coefficient of the `to` block
    Eigen::Matrix2d from;  // coefficient of the `from` block
    Eigen::Vector2d rhs;
  };
  auto solve = [&](const std::vector<Rows>& rows, auto known_value) -> Result<Eigen::VectorXd> {
    std::vector<Eigen::Triplet<double>> triplets;
    Eigen::VectorXd b = Eigen::VectorXd::Zero(2 * static_cast<Eigen::Index>(planar.size()));
    for (std::size_t k = 0; k < planar.size(); ++k) {
      const auto row0 = static_cast<int>(2 * k);
      Eigen::Vector2d rhs = rows[k].rhs;
      const std::array<std::pair<NodeId, Eigen::Matrix2d>, 2> blocks{
          std::pair{planar[k].to, Eigen::Matrix2d(rows[k].to)},
          std::pair{planar[k].from, Eigen::Matrix2d(-rows[k].from)}};
      for (const auto& [id, M] : blocks) {
        const auto it = index.find(id);
        if (it == index.end()) {
          rhs -= M * known_value(id);
          continue;
        }
        for (int r = 0; r < 2; ++r) {
          for (int c = 0; c < 2; ++c) triplets.emplace_back(row0 + r, 2 * it->second + c, M(r, c));
        }
      }
      b.segment<2>(row0) = rhs;
    }
    Eigen::SparseMatrix<double> A(2 * static_cast<Eigen::Index>(planar.size()), 2 * n);
    A.setFromTriplets(triplets.begin(), triplets.end());
    const Eigen::SparseMatrix<double> H = A.transpose() * A;
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(H);
    if (ldlt.info() != Eigen::Success) return Error{"chordal initialisation: the linear system is singular"};
    Eigen::VectorXd x = ldlt.solve(A.transpose() * b);
    if (ldlt.info() != Eigen::Success || !x.allFinite()) {
      return Error{"chordal initialisation: the linear system is singular"};
    }
    return x;
  };

  // Headings as unit complex numbers u = (cos, sin): u_to = R(dyaw) u_from, linear in u.
  std::vector<Rows> rotation_rows;
  for (const Planar& p : planar) {
    const double w = std::sqrt(p.info_yaw);
    rotation_rows.push_back(Rows{w * Eigen::Matrix2d::Identity(), w * rotation2(p.dyaw), Eigen::Vector2d::Zero()});
  }
  auto u = solve(rotation_rows, [&](NodeId id) {
    const double yaw = nodes_.at(id)(kYaw);
    return Eigen::Vector2d(std::cos(yaw), std::sin(yaw));
  });
  if (!u) return u.error();
  for (const auto& [id, k] : index) {
    const Eigen::Vector2d uk = u->segment<2>(2 * k);
    if (!(uk.norm() > 1e-9)) {
      return Error{"chordal initialisation: heading of node " + std::to_string(id) + " is undetermined"};
    }
    work.at(id)(kYaw) = std::atan2(uk.y(), uk.x());
  }

  // Positions with the headings fixed: S R(yaw_from + offset)^T (p_to - p_from) = S R(offset)^T d.
  std::vector<Rows> translation_rows;
  for (const Planar& p : planar) {
    const Eigen::Matrix2d M = p.sqrt_info_xy * rotation2(work.at(p.from)(kYaw) + p.frame_offset).transpose();
    translation_rows.push_back(Rows{M, M, p.sqrt_info_xy * rotation2(p.frame_offset).transpose() * p.d});
  }
  auto xy = solve(translation_rows, [&](NodeId id) { return Eigen::Vector2d(nodes_.at(id).head<2>()); });
  if (!xy) return xy.error();
  for (const auto& [id, k] : index) {
    work.at(id)(kX) = (*xy)(2 * k);
    work.at(id)(kY) = (*xy)(2 * k + 1);
  }
  nodes_ = std::move(work);
  return Status::success();
}

Result<OptimizeResult> PoseGraph::optimize() {
  if (nodes_.empty()) return Error{"pose graph: nothing to optimize (no nodes)"};
  return solve([](NodeId) { return true; }, nodes_.begin()->first, nodes_.size());
}

Result<OptimizeResult> PoseGraph::optimizeFrom(NodeId first_free) {
  if (nodes_.empty()) return Error{"pose graph: nothing to optimize (no nodes)"};
  const auto first = nodes_.lower_bound(first_free);
  if (first == nodes_.end()) {
    return Error{"pose graph: no node to optimize from " + std::to_string(first_free) + " on (the last is " +
                 std::to_string(nodes_.rbegin()->first) + ")"};
  }
  return solve([first_free](NodeId id) { return id >= first_free; }, first->first,
               static_cast<std::size_t>(std::distance(first, nodes_.end())));
}

Result<OptimizeResult> PoseGraph::optimizeNodes(const std::set<NodeId>& free) {
  if (free.empty()) return Error{"pose graph: no node to optimize (the free set is empty)"};
  for (const NodeId id : free) {
    if (nodes_.count(id) == 0) return Error{"pose graph: cannot optimize missing node " + std::to_string(id)};
  }
  return solve([&free](NodeId id) { return free.count(id) != 0; }, *free.begin(), free.size());
}

std::set<NodeId> PoseGraph::neighbourhood(const std::vector<NodeId>& seeds, std::size_t max_nodes) const {
  std::map<NodeId, std::vector<NodeId>> adjacent;
  for (const RelativeFactor& f : relative_) {
    if (!f.active) continue;
    adjacent[f.from].push_back(f.to);
    adjacent[f.to].push_back(f.from);
  }
  std::set<NodeId> reached;
  std::set<NodeId> ring;  // the nodes first reached at the current hop count, in id order
  for (const NodeId id : seeds) {
    if (nodes_.count(id) != 0) ring.insert(id);
  }
  while (!ring.empty() && reached.size() < max_nodes) {
    std::set<NodeId> next;
    for (const NodeId id : ring) {
      if (reached.size() == max_nodes) break;
      if (!reached.insert(id).second) continue;
      const auto it = adjacent.find(id);
      if (it == adjacent.end()) continue;
      for (const NodeId n : it->second) {
        if (reached.count(n) == 0) next.insert(n);
      }
    }
    ring = std::move(next);
  }
  return reached;
}

Result<OptimizeResult> PoseGraph::solve(const std::function<bool(NodeId)>& free, NodeId window_first,
                                        std::size_t free_count) {
  OptimizeResult result;
  const bool windowed = free_count != nodes_.size();
  bool joins_held = false;  // some factor links a free node to a held one (fixes the window's gauge)

  std::map<NodeId, Vector6d> work = nodes_;  // the solver writes here; committed only on success
  std::map<NodeId, ComponentMask> constrained;
  auto mark = [&](NodeId id, const ComponentMask& mask) {
    ComponentMask& m = constrained[id];
    for (std::size_t i = 0; i < 6; ++i) m[i] = m[i] || mask[i];
  };
  // Whether a relative factor measures z, roll or pitch: SE3 factors and full closures do; odometry,
  // SE2 factors and closures whose directions lie in (x, y, yaw) (the planar registration) do not.
  const auto measures_attitude = [](const RelativeFactor& f) {
    switch (f.kind) {
      case RelativeKind::kOdometry:
      case RelativeKind::kSe2: return false;
      case RelativeKind::kSe3: return true;
      case RelativeKind::kLoopClosure:
      case RelativeKind::kPartialLoopClosure: break;
    }
    return !f.projection.col(kZ).isZero(0.0) || !f.projection.col(kRoll).isZero(0.0) ||
           !f.projection.col(kPitch).isZero(0.0);
  };
  ceres::Problem::Options problem_options;
  ceres::Problem problem(problem_options);
  // LinearSolver::kChainPreconditionedCg's preconditioner, collected only for it: the odometry, the
  // SE2 / SE3 factors between consecutive ids (a g2o file's odometry edges) and the absolute factors.
  const bool use_cg = config_.linear_solver == LinearSolver::kChainPreconditionedCg;
  std::unordered_set<ceres::ResidualBlockId> chain;
  bool has_chain = false;  // some relative factor of the chain is in the problem
  for (const RelativeFactor& f : relative_) {
    if (!f.active || (!free(f.from) && !free(f.to))) continue;
    joins_held = joins_held || !free(f.from) || !free(f.to);
    ceres::CostFunction* cost = nullptr;
    ceres::LossFunction* loss = nullptr;
    switch (f.kind) {
      case RelativeKind::kSe2:
        cost = new Se2Cost(Eigen::Vector3d(f.measurement(kX), f.measurement(kY), f.measurement(kYaw)),
                           Eigen::Matrix3d(f.sqrt_information));
        break;
      case RelativeKind::kSe3:
        cost =
            new ceres::AutoDiffCostFunction<Se3Cost, 6, 6, 6>(new Se3Cost(f.T_from_to, Matrix6d(f.sqrt_information)));
        break;
      case RelativeKind::kOdometry:
      case RelativeKind::kLoopClosure:
      case RelativeKind::kPartialLoopClosure: {
        const Eigen::MatrixXd W = f.sqrt_information * f.projection;
        const bool planar = f.kind == RelativeKind::kOdometry;
        cost = new ceres::AutoDiffCostFunction<RelativeCost, ceres::DYNAMIC, 6, 6>(
            new RelativeCost(planar, f.measurement, W), static_cast<int>(W.rows()));
        if (!planar) {
          switch (config_.loop_closure_loss) {
            case RobustLoss::kNone: break;
            case RobustLoss::kHuber: loss = new ceres::HuberLoss(config_.loop_closure_loss_scale); break;
            case RobustLoss::kCauchy: loss = new ceres::CauchyLoss(config_.loop_closure_loss_scale); break;
          }
        }
        break;
      }
    }
    const ComponentMask& mask = measures_attitude(f) ? kAllMask : kPlanarMask;
    mark(f.from, mask);
    mark(f.to, mask);
    const ceres::ResidualBlockId block =
        problem.AddResidualBlock(cost, loss, work.at(f.from).data(), work.at(f.to).data());
    const bool consecutive = f.to == f.from + 1 || f.from == f.to + 1;
    if (use_cg && (f.kind == RelativeKind::kOdometry ||
                   ((f.kind == RelativeKind::kSe2 || f.kind == RelativeKind::kSe3) && consecutive))) {
      chain.insert(block);
      has_chain = true;
    }
  }
  // PoseGraphConfig::attitude_from_absolute: z, roll and pitch that no relative factor measures are
  // the one absolute factor's, held.
  std::map<NodeId, int> absolute_count;  // only with the option
  if (config_.attitude_from_absolute)
    for (const AbsoluteFactor& f : absolute_) ++absolute_count[f.id];
  const auto attitude_held = [&](NodeId id) {
    if (!config_.attitude_from_absolute || fixed_.count(id) != 0 || absolute_count.at(id) != 1) return false;
    const auto it = constrained.find(id);
    return it == constrained.end() || !(it->second[kZ] || it->second[kRoll] || it->second[kPitch]);
  };
  for (const AbsoluteFactor& f : absolute_) {
    if (!free(f.id)) continue;
    if (attitude_held(f.id)) {
      Vector6d& x = work.at(f.id);
      x(kZ) = f.z_roll_pitch(0);
      x(kRoll) = f.z_roll_pitch(1);
      x(kPitch) = f.z_roll_pitch(2);
      continue;
    }
    const ceres::ResidualBlockId block = problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<AbsoluteCost, 3, 6>(new AbsoluteCost(f.z_roll_pitch, f.sqrt_information)),
        nullptr, work.at(f.id).data());
    if (use_cg) chain.insert(block);
    mark(f.id, kAbsoluteMask);
  }
  if (problem.NumResidualBlocks() == 0) return Error{"pose graph: nothing to optimize (no factors)"};
  // Held constant: fixed nodes; the gauge (x, y, yaw of the first node); and components no factor
  // constrains (z, roll, pitch of a node with only planar factors), which keeps a planar graph's
  // linear system at three unknowns per node without changing its solution.
  for (auto& [id, x] : work) {
    if (!problem.HasParameterBlock(x.data())) continue;
    if (fixed_.count(id) != 0 || !free(id)) {
      problem.SetParameterBlockConstant(x.data());
      continue;
    }
    const bool anchored =
        config_.anchor_first_node &&
        (windowed ? !joins_held && id == (free(first_node_) ? first_node_ : window_first) : id == first_node_);
    std::vector<int> held;
    for (int i = 0; i < 6; ++i) {
      const bool gauge = anchored && (i == kX || i == kY || i == kYaw);
      if (gauge || !constrained.at(id)[static_cast<std::size_t>(i)]) held.push_back(i);
    }
    if (held.size() == 6) {
      problem.SetParameterBlockConstant(x.data());
    } else if (!held.empty()) {
      problem.SetManifold(x.data(), new ceres::SubsetManifold(6, held));
    }
  }

  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = config_.max_iterations;
  options.initial_trust_region_radius = config_.initial_trust_region_radius;
  options.function_tolerance = config_.function_tolerance;
  options.gradient_tolerance = config_.gradient_tolerance;
  options.parameter_tolerance = config_.parameter_tolerance;
  options.num_threads = 1;  // STYLE 5: algorithms create no threads
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  std::string note;
  detail::selectLinearSolver(options, config_.sparse_backend, result.linear_solver, note);
  if (use_cg && options.linear_solver_type == ceres::SPARSE_NORMAL_CHOLESKY) {
    if (has_chain) {
      options.linear_solver_type = ceres::CGNR;
      options.preconditioner_type = ceres::SUBSET;
      options.residual_blocks_for_subset_preconditioner = std::move(chain);
      result.linear_solver =
          "CGNR/SUBSET(chain, absolute)/" + result.linear_solver.substr(result.linear_solver.find('/') + 1);
    } else {
      note += "No odometry chain to precondition conjugate gradients with; factorised exactly. ";
    }
  }
  std::string why;
  if (!options.IsValid(&why)) return Error{"pose graph: invalid solver options: " + why};

  ceres::Solver::Summary summary;
  const auto t0 = std::chrono::steady_clock::now();
  ceres::Solve(options, &problem, &summary);
  result.solve_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  result.free_nodes = static_cast<int>(free_count);
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
    if (!free(id)) continue;
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
