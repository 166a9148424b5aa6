#include "vog/slam/g2o.hpp"

#include "solver_backend.hpp"
#include "vog/slam/information.hpp"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <Eigen/Geometry>

#include <charconv>
#include <chrono>
#include <cmath>
#include <sstream>
#include <unordered_map>

namespace vog::slam {
namespace {

std::string lineError(std::size_t line, const std::string& what) {
  return "g2o line " + std::to_string(line) + ": " + what;
}

std::vector<std::string_view> splitWhitespace(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < s.size() && s[i] != ' ' && s[i] != '\t' && s[i] != '\r') ++i;
    if (i > start) out.push_back(s.substr(start, i - start));
  }
  return out;
}

bool parseNumber(std::string_view tok, double& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return ec == std::errc() && ptr == tok.data() + tok.size() && std::isfinite(out);
}

bool parseId(std::string_view tok, std::int64_t& out) {
  const auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return ec == std::errc() && ptr == tok.data() + tok.size();
}

// Reads `n` numbers starting at token `first`; on failure names the offending field.
Status parseNumbers(const std::vector<std::string_view>& tok, std::size_t first, std::size_t n, double* out,
                    std::size_t line) {
  for (std::size_t k = 0; k < n; ++k) {
    if (!parseNumber(tok[first + k], out[k])) {
      return Error{lineError(line, std::string(tok[0]) + " field " + std::to_string(first + k) + " '" +
                                       std::string(tok[first + k]) + "' is not a finite number")};
    }
  }
  return Status::success();
}

template <int N>
Result<Eigen::Matrix<double, N, N>> upperTriangleInformation(const double* v, std::size_t line) {
  Eigen::Matrix<double, N, N> info;
  int k = 0;
  for (int r = 0; r < N; ++r) {
    for (int c = r; c < N; ++c) {
      info(r, c) = v[k];
      info(c, r) = v[k];
      ++k;
    }
  }
  auto U = sqrtInformation(info, "information");
  if (!U) return Error{lineError(line, U.error().message)};
  return info;
}

Eigen::Isometry2d se2(const Eigen::Vector3d& v) {
  Eigen::Isometry2d T = Eigen::Isometry2d::Identity();
  T.linear() = Eigen::Rotation2Dd(v(2)).toRotationMatrix();
  T.translation() = v.head<2>();
  return T;
}

Eigen::Vector3d t2v(const Eigen::Isometry2d& T) {
  return {T.translation().x(), T.translation().y(), std::atan2(T.linear()(1, 0), T.linear()(0, 0))};
}

// g2o toVectorMQT: translation and the vector part of the unit quaternion with qw >= 0.
Vector6d t2vMqt(const geometry::Pose3& T) {
  Eigen::Quaterniond q(T.linear());
  q.normalize();
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  Vector6d e;
  e << T.translation(), q.vec();
  return e;
}

double edgeChi2(const G2oGraph& g, const G2oEdgeSE2& e) {
  const Eigen::Vector3d err =
      t2v(se2(e.measurement).inverse() * (se2(g.vertices_se2.at(e.from)).inverse() * se2(g.vertices_se2.at(e.to))));
  return err.dot(e.information * err);
}

double edgeChi2(const G2oGraph& g, const G2oEdgeSE3& e) {
  const Vector6d err =
      t2vMqt(e.T_from_to.inverse() * (g.vertices_se3.at(e.from).inverse() * g.vertices_se3.at(e.to)));
  return err.dot(e.information * err);
}

// SE2 edge residual with analytic Jacobians: e_xy = R(th_i + z_th)^T (p_j - p_i) - R(z_th)^T z_xy,
// e_th = wrap(th_j - th_i - z_th); r = U e with U^T U = Omega.
class Se2EdgeCost final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  Se2EdgeCost(const Eigen::Vector3d& z, const Eigen::Matrix3d& sqrt_information) : U_(sqrt_information) {
    z_th_ = z(2);
    z_xy_local_ = Eigen::Rotation2Dd(z(2)).toRotationMatrix().transpose() * z.head<2>();
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* a = parameters[0];
    const double* b = parameters[1];
    const double phi = a[2] + z_th_;
    const double c = std::cos(phi), s = std::sin(phi);
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    Eigen::Vector3d e;
    e << c * dx + s * dy - z_xy_local_(0), -s * dx + c * dy - z_xy_local_(1), geometry::wrapAngle(b[2] - phi);
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r = U_ * e;
    if (jacobians != nullptr) {
      Eigen::Matrix3d Jb;
      Jb << c, s, 0, -s, c, 0, 0, 0, 1;
      if (jacobians[0] != nullptr) {
        Eigen::Matrix3d Ja;
        Ja << -c, -s, -s * dx + c * dy, s, -c, -c * dx - s * dy, 0, 0, -1;
        Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J0(jacobians[0]);
        J0 = U_ * Ja;
      }
      if (jacobians[1] != nullptr) {
        Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J1(jacobians[1]);
        J1 = U_ * Jb;
      }
    }
    return true;
  }

 private:
  Eigen::Matrix3d U_;
  double z_th_ = 0.0;
  Eigen::Vector2d z_xy_local_;
};

// SE3 edge residual (autodiff): delta = Z^-1 X_i^-1 X_j, e = (t_delta, vec(q_delta) with qw >= 0).
class Se3EdgeCost {
 public:
  Se3EdgeCost(const geometry::Pose3& Z, const Matrix6d& sqrt_information) : U_(sqrt_information) {
    const geometry::Pose3 Zinv = Z.inverse();
    zq_inv_ = Eigen::Quaterniond(Zinv.linear()).normalized();
    zt_inv_ = Zinv.translation();
  }

  template <typename T>
  bool operator()(const T* ti, const T* qi, const T* tj, const T* qj, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> Qi(qi), Qj(qj);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> Ti(ti), Tj(tj);
    const Eigen::Quaternion<T> Qi_inv = Qi.conjugate();
    const Eigen::Quaternion<T> q_ij = Qi_inv * Qj;
    const Eigen::Matrix<T, 3, 1> t_ij = Qi_inv * (Tj - Ti);
    const Eigen::Quaternion<T> zq = zq_inv_.cast<T>();
    Eigen::Quaternion<T> q_d = zq * q_ij;
    const Eigen::Matrix<T, 3, 1> t_d = zq * t_ij + zt_inv_.cast<T>();
    Eigen::Matrix<T, 6, 1> e;
    const T sign = q_d.w() < T(0) ? T(-1) : T(1);
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

}  // namespace

Result<G2oGraph> parseG2o(std::string_view text) {
  G2oGraph g;
  bool seen_2d = false, seen_3d = false;
  std::vector<std::size_t> edge_lines;
  std::vector<std::pair<std::int64_t, std::size_t>> fix_lines;
  std::size_t line_no = 0;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    const std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    const auto tok = splitWhitespace(line);
    if (tok.empty() || tok[0].front() == '#') {
      if (end == text.size()) break;
      continue;
    }
    const std::string tag(tok[0]);
    auto expectFields = [&](std::size_t n) -> Status {
      if (tok.size() != n) {
        std::ostringstream os;
        os << tag << " expects " << n - 1 << " fields, got " << tok.size() - 1;
        return Error{lineError(line_no, os.str())};
      }
      return Status::success();
    };
    auto readId = [&](std::size_t k, std::int64_t& id) -> Status {
      if (!parseId(tok[k], id)) {
        return Error{lineError(line_no, tag + " field " + std::to_string(k) + " '" + std::string(tok[k]) +
                                            "' is not an integer id")};
      }
      return Status::success();
    };
    auto mixCheck = [&](bool is3d) -> Status {
      if ((is3d && seen_2d) || (!is3d && seen_3d)) return Error{lineError(line_no, "mixes 2D and 3D types")};
      (is3d ? seen_3d : seen_2d) = true;
      return Status::success();
    };

    if (tag == "VERTEX_SE2") {
      if (Status s = expectFields(5); !s) return s.error();
      if (Status s = mixCheck(false); !s) return s.error();
      std::int64_t id = 0;
      double v[3];
      if (Status s = readId(1, id); !s) return s.error();
      if (Status s = parseNumbers(tok, 2, 3, v, line_no); !s) return s.error();
      if (!g.vertices_se2.emplace(id, Eigen::Vector3d(v[0], v[1], geometry::wrapAngle(v[2]))).second) {
        return Error{lineError(line_no, "duplicate vertex id " + std::to_string(id))};
      }
    } else if (tag == "EDGE_SE2") {
      if (Status s = expectFields(12); !s) return s.error();
      if (Status s = mixCheck(false); !s) return s.error();
      G2oEdgeSE2 e;
      double v[9];
      if (Status s = readId(1, e.from); !s) return s.error();
      if (Status s = readId(2, e.to); !s) return s.error();
      if (Status s = parseNumbers(tok, 3, 9, v, line_no); !s) return s.error();
      e.measurement = Eigen::Vector3d(v[0], v[1], v[2]);
      auto info = upperTriangleInformation<3>(v + 3, line_no);
      if (!info) return info.error();
      e.information = *info;
      g.edges_se2.push_back(e);
      edge_lines.push_back(line_no);
    } else if (tag == "VERTEX_SE3:QUAT") {
      if (Status s = expectFields(9); !s) return s.error();
      if (Status s = mixCheck(true); !s) return s.error();
      std::int64_t id = 0;
      double v[7];
      if (Status s = readId(1, id); !s) return s.error();
      if (Status s = parseNumbers(tok, 2, 7, v, line_no); !s) return s.error();
      Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
      if (q.norm() < 1e-6) return Error{lineError(line_no, "zero quaternion")};
      geometry::Pose3 T = geometry::Pose3::Identity();
      T.linear() = q.normalized().toRotationMatrix();
      T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
      if (!g.vertices_se3.emplace(id, T).second) {
        return Error{lineError(line_no, "duplicate vertex id " + std::to_string(id))};
      }
    } else if (tag == "EDGE_SE3:QUAT") {
      if (Status s = expectFields(31); !s) return s.error();
      if (Status s = mixCheck(true); !s) return s.error();
      G2oEdgeSE3 e;
      double v[28];
      if (Status s = readId(1, e.from); !s) return s.error();
      if (Status s = readId(2, e.to); !s) return s.error();
      if (Status s = parseNumbers(tok, 3, 28, v, line_no); !s) return s.error();
      Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
      if (q.norm() < 1e-6) return Error{lineError(line_no, "zero quaternion")};
      e.T_from_to.linear() = q.normalized().toRotationMatrix();
      e.T_from_to.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
      auto info = upperTriangleInformation<6>(v + 7, line_no);
      if (!info) return info.error();
      e.information = *info;
      g.edges_se3.push_back(e);
      edge_lines.push_back(line_no);
    } else if (tag == "FIX") {
      if (tok.size() < 2) return Error{lineError(line_no, "FIX expects at least one vertex id")};
      for (std::size_t k = 1; k < tok.size(); ++k) {
        std::int64_t id = 0;
        if (Status s = readId(k, id); !s) return s.error();
        fix_lines.emplace_back(id, line_no);
      }
    } else {
      return Error{lineError(line_no, "unsupported tag '" + tag + "'")};
    }
    if (end == text.size()) break;
  }

  g.is_3d = seen_3d;
  if (g.numVertices() == 0) return Error{"g2o: graph has no vertices"};
  for (std::size_t k = 0; k < g.numEdges(); ++k) {
    const std::int64_t from = g.is_3d ? g.edges_se3[k].from : g.edges_se2[k].from;
    const std::int64_t to = g.is_3d ? g.edges_se3[k].to : g.edges_se2[k].to;
    for (const std::int64_t id : {from, to}) {
      const bool exists = g.is_3d ? g.vertices_se3.count(id) != 0 : g.vertices_se2.count(id) != 0;
      if (!exists) return Error{lineError(edge_lines[k], "edge references missing vertex " + std::to_string(id))};
    }
    if (from == to) return Error{lineError(edge_lines[k], "edge connects vertex " + std::to_string(from) + " to itself")};
  }
  for (const auto& [id, line] : fix_lines) {
    const bool exists = g.is_3d ? g.vertices_se3.count(id) != 0 : g.vertices_se2.count(id) != 0;
    if (!exists) return Error{lineError(line, "FIX references missing vertex " + std::to_string(id))};
    g.fixed.insert(id);
  }
  return g;
}

double g2oChi2(const G2oGraph& graph) {
  double chi2 = 0.0;
  if (graph.is_3d) {
    for (const auto& e : graph.edges_se3) chi2 += edgeChi2(graph, e);
  } else {
    for (const auto& e : graph.edges_se2) chi2 += edgeChi2(graph, e);
  }
  return chi2;
}

Result<G2oGraph> initializeFromOdometry(const G2oGraph& graph) {
  G2oGraph out = graph;
  auto key = [](std::int64_t a, std::int64_t b) { return std::to_string(a) + ":" + std::to_string(b); };
  std::unordered_map<std::string, std::size_t> by_pair;
  for (std::size_t k = 0; k < graph.numEdges(); ++k) {
    const std::int64_t from = graph.is_3d ? graph.edges_se3[k].from : graph.edges_se2[k].from;
    const std::int64_t to = graph.is_3d ? graph.edges_se3[k].to : graph.edges_se2[k].to;
    by_pair.emplace(key(from, to), k);
  }
  std::vector<std::int64_t> ids;
  if (graph.is_3d) {
    for (const auto& kv : graph.vertices_se3) ids.push_back(kv.first);
  } else {
    for (const auto& kv : graph.vertices_se2) ids.push_back(kv.first);
  }
  for (std::size_t n = 1; n < ids.size(); ++n) {
    const std::int64_t prev = ids[n - 1], cur = ids[n];
    bool forward = true;
    auto it = by_pair.find(key(prev, cur));
    if (it == by_pair.end()) {
      it = by_pair.find(key(cur, prev));
      forward = false;
    }
    if (it == by_pair.end()) {
      return Error{"g2o odometry initialisation: no edge between consecutive vertices " + std::to_string(prev) +
                   " and " + std::to_string(cur)};
    }
    if (graph.is_3d) {
      const geometry::Pose3& Z = graph.edges_se3[it->second].T_from_to;
      out.vertices_se3[cur] = out.vertices_se3[prev] * (forward ? Z : Z.inverse());
    } else {
      const Eigen::Isometry2d Z = se2(graph.edges_se2[it->second].measurement);
      Eigen::Vector3d v = t2v(se2(out.vertices_se2[prev]) * (forward ? Z : Z.inverse()));
      out.vertices_se2[cur] = v;
    }
  }
  return out;
}

Status G2oSolveOptions::validate() const {
  std::ostringstream os;
  if (max_iterations < 1) {
    os << "max_iterations must be >= 1, got " << max_iterations;
  } else if (!(function_tolerance > 0.0)) {
    os << "function_tolerance must be > 0, got " << function_tolerance;
  } else if (!(gradient_tolerance > 0.0)) {
    os << "gradient_tolerance must be > 0, got " << gradient_tolerance;
  } else if (!(parameter_tolerance > 0.0)) {
    os << "parameter_tolerance must be > 0, got " << parameter_tolerance;
  } else if (!(initial_trust_region_radius > 0.0) || !std::isfinite(initial_trust_region_radius)) {
    os << "initial_trust_region_radius must be finite and > 0, got " << initial_trust_region_radius;
  } else {
    return Status::success();
  }
  return Error{"g2o solve options: " + os.str()};
}

Result<G2oSolveResult> optimizeG2o(G2oGraph& graph, const G2oSolveOptions& opts) {
  if (Status s = opts.validate(); !s) return s.error();
  if (graph.numVertices() == 0) return Error{"g2o: graph has no vertices"};
  if (graph.numEdges() == 0) return Error{"g2o: graph has no edges"};
  G2oSolveResult result;
  result.chi2_initial = g2oChi2(graph);

  ceres::Problem::Options problem_options;
  ceres::Problem problem(problem_options);
  std::set<std::int64_t> fixed = graph.fixed;
  if (fixed.empty()) fixed.insert(graph.is_3d ? graph.vertices_se3.begin()->first : graph.vertices_se2.begin()->first);

  // Working copies; written back only after a successful solve.
  std::map<std::int64_t, Eigen::Vector3d> se2 = graph.vertices_se2;
  std::map<std::int64_t, Eigen::Vector3d> t3;
  std::map<std::int64_t, Eigen::Quaterniond> q3;
  if (graph.is_3d) {
    for (const auto& [id, T] : graph.vertices_se3) {
      t3[id] = T.translation();
      q3[id] = Eigen::Quaterniond(T.linear()).normalized();
    }
    for (const auto& e : graph.edges_se3) {
      const auto U = sqrtInformation(e.information, "g2o edge information");
      if (!U) return U.error();
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Se3EdgeCost, 6, 3, 4, 3, 4>(
                                   new Se3EdgeCost(e.T_from_to, Matrix6d(*U))),
                               nullptr, t3[e.from].data(), q3[e.from].coeffs().data(), t3[e.to].data(),
                               q3[e.to].coeffs().data());
    }
    for (auto& [id, q] : q3) {
      if (problem.HasParameterBlock(q.coeffs().data())) {
        problem.SetManifold(q.coeffs().data(), new ceres::EigenQuaternionManifold);
      }
    }
    for (const std::int64_t id : fixed) {
      if (problem.HasParameterBlock(t3[id].data())) {
        problem.SetParameterBlockConstant(t3[id].data());
        problem.SetParameterBlockConstant(q3[id].coeffs().data());
      }
    }
  } else {
    for (const auto& e : graph.edges_se2) {
      const auto U = sqrtInformation(e.information, "g2o edge information");
      if (!U) return U.error();
      problem.AddResidualBlock(new Se2EdgeCost(e.measurement, Eigen::Matrix3d(*U)), nullptr, se2[e.from].data(),
                               se2[e.to].data());
    }
    for (const std::int64_t id : fixed) {
      if (problem.HasParameterBlock(se2[id].data())) problem.SetParameterBlockConstant(se2[id].data());
    }
  }

  ceres::Solver::Options options;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = opts.max_iterations;
  options.initial_trust_region_radius = opts.initial_trust_region_radius;
  options.function_tolerance = opts.function_tolerance;
  options.gradient_tolerance = opts.gradient_tolerance;
  options.parameter_tolerance = opts.parameter_tolerance;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  std::string note;
  detail::selectLinearSolver(options, result.linear_solver, note);

  ceres::Solver::Summary summary;
  const auto t0 = std::chrono::steady_clock::now();
  ceres::Solve(options, &problem, &summary);
  result.solve_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.message = note + summary.message;
  if (summary.termination_type == ceres::FAILURE) return Error{"g2o: solver failed: " + summary.message};

  if (graph.is_3d) {
    for (const auto& [id, t] : t3) {
      if (!t.allFinite() || !q3[id].coeffs().allFinite()) {
        return Error{"g2o: solver produced a non-finite estimate for vertex " + std::to_string(id)};
      }
    }
    for (auto& [id, T] : graph.vertices_se3) {
      T.linear() = q3[id].normalized().toRotationMatrix();
      T.translation() = t3[id];
    }
  } else {
    for (const auto& [id, v] : se2) {
      if (!v.allFinite()) return Error{"g2o: solver produced a non-finite estimate for vertex " + std::to_string(id)};
    }
    for (auto& [id, v] : se2) v(2) = geometry::wrapAngle(v(2));
    graph.vertices_se2 = std::move(se2);
  }
  result.chi2_final = g2oChi2(graph);
  return result;
}

}  // namespace vog::slam
