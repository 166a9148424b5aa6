#include "vog/slam/g2o.hpp"

#include "vog/slam/information.hpp"

#include <Eigen/Geometry>

#include <array>
#include <charconv>
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
  const Vector6d err = t2vMqt(e.T_from_to.inverse() * (g.vertices_se3.at(e.from).inverse() * g.vertices_se3.at(e.to)));
  return err.dot(e.information * err);
}

// Writes the PoseGraph's estimates back into the graph's vertices; fixed vertices are left as they
// were (bit-exact, no round trip through the 6-vector).
void copyEstimates(const PoseGraph& pose_graph, G2oGraph& g) {
  if (g.is_3d) {
    for (auto& [id, T] : g.vertices_se3) {
      if (!pose_graph.isFixed(id)) T = fromXyzRpy(*pose_graph.estimate(id));
    }
  } else {
    for (auto& [id, v] : g.vertices_se2) {
      if (pose_graph.isFixed(id)) continue;
      const Vector6d x = *pose_graph.estimate(id);
      v = Eigen::Vector3d(x(kX), x(kY), x(kYaw));
    }
  }
}

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
        return Error{lineError(
            line_no, tag + " field " + std::to_string(k) + " '" + std::string(tok[k]) + "' is not an integer id")};
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
  if (g.numVertices() == 0 && g.numEdges() == 0) return Error{"g2o: graph has no vertices and no edges"};
  if (g.numVertices() == 0) {
    // Edge-only file: the vertices are the edges' ids, initialised below.
    g.vertices_from_edges = true;
    for (std::size_t k = 0; k < g.numEdges(); ++k) {
      for (const std::int64_t id : g.is_3d ? std::array{g.edges_se3[k].from, g.edges_se3[k].to}
                                           : std::array{g.edges_se2[k].from, g.edges_se2[k].to}) {
        if (g.is_3d) {
          g.vertices_se3.emplace(id, geometry::Pose3::Identity());
        } else {
          g.vertices_se2.emplace(id, Eigen::Vector3d::Zero());
        }
      }
    }
  }
  for (std::size_t k = 0; k < g.numEdges(); ++k) {
    const std::int64_t from = g.is_3d ? g.edges_se3[k].from : g.edges_se2[k].from;
    const std::int64_t to = g.is_3d ? g.edges_se3[k].to : g.edges_se2[k].to;
    for (const std::int64_t id : {from, to}) {
      const bool exists = g.is_3d ? g.vertices_se3.count(id) != 0 : g.vertices_se2.count(id) != 0;
      if (!exists) return Error{lineError(edge_lines[k], "edge references missing vertex " + std::to_string(id))};
    }
    if (from == to)
      return Error{lineError(edge_lines[k], "edge connects vertex " + std::to_string(from) + " to itself")};
  }
  for (const auto& [id, line] : fix_lines) {
    const bool exists = g.is_3d ? g.vertices_se3.count(id) != 0 : g.vertices_se2.count(id) != 0;
    if (!exists) return Error{lineError(line, "FIX references missing vertex " + std::to_string(id))};
    g.fixed.insert(id);
  }
  if (g.vertices_from_edges) {
    auto init = initializeFromSpanningTree(g);
    if (!init) {
      return Error{"g2o: the file has no VERTEX lines; initialising the vertices from the edges: " +
                   init.error().message};
    }
    return init;
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

Result<PoseGraph> toPoseGraph(const G2oGraph& graph, const PoseGraphConfig& config) {
  auto created = PoseGraph::create(config);
  if (!created) return created.error();
  PoseGraph pose_graph = std::move(*created);
  if (graph.is_3d) {
    for (const auto& [id, T] : graph.vertices_se3) {
      if (Status s = pose_graph.addNode(id, T); !s) return Error{"g2o: " + s.error().message};
    }
    for (const G2oEdgeSE3& e : graph.edges_se3) {
      if (Status s = pose_graph.addSe3Factor(e.from, e.to, e.T_from_to, e.information); !s) {
        return Error{"g2o: " + s.error().message};
      }
    }
  } else {
    for (const auto& [id, v] : graph.vertices_se2) {
      Vector6d x;
      x << v(0), v(1), 0.0, 0.0, 0.0, v(2);
      if (Status s = pose_graph.addNode(id, fromXyzRpy(x)); !s) return Error{"g2o: " + s.error().message};
      // Exactly the file's values (the Pose3 round trip is not bit-exact).
      if (Status s = pose_graph.setEstimate(id, x); !s) return Error{"g2o: " + s.error().message};
    }
    for (const G2oEdgeSE2& e : graph.edges_se2) {
      if (Status s = pose_graph.addSe2Factor(e.from, e.to, e.measurement, e.information); !s) {
        return Error{"g2o: " + s.error().message};
      }
    }
  }
  if (graph.numVertices() == 0) return Error{"g2o: graph has no vertices"};
  std::set<std::int64_t> fixed = graph.fixed;
  if (fixed.empty()) fixed.insert(graph.is_3d ? graph.vertices_se3.begin()->first : graph.vertices_se2.begin()->first);
  for (const std::int64_t id : fixed) {
    if (Status s = pose_graph.fixNode(id); !s) return Error{"g2o: " + s.error().message};
  }
  return pose_graph;
}

Result<G2oGraph> initializeFromSpanningTree(const G2oGraph& graph) {
  auto pose_graph = toPoseGraph(graph);
  if (!pose_graph) return pose_graph.error();
  if (Status s = pose_graph->initializeFromSpanningTree(); !s) return s.error();
  G2oGraph out = graph;
  copyEstimates(*pose_graph, out);
  return out;
}

Result<G2oGraph> initializeChordal(const G2oGraph& graph) {
  if (graph.is_3d) return Error{"g2o: chordal initialisation is planar; this graph is 3D (use the spanning tree)"};
  auto pose_graph = toPoseGraph(graph);
  if (!pose_graph) return pose_graph.error();
  if (Status s = pose_graph->initializeChordal(); !s) return s.error();
  G2oGraph out = graph;
  copyEstimates(*pose_graph, out);
  return out;
}

Result<G2oSolveResult> optimizeG2o(G2oGraph& graph, const PoseGraphConfig& config) {
  if (graph.numVertices() == 0) return Error{"g2o: graph has no vertices"};
  if (graph.numEdges() == 0) return Error{"g2o: graph has no edges"};
  auto pose_graph = toPoseGraph(graph, config);
  if (!pose_graph) return pose_graph.error();
  G2oSolveResult result;
  result.chi2_initial = g2oChi2(graph);
  auto solved = pose_graph->optimize();
  if (!solved) return Error{"g2o: " + solved.error().message};
  result.converged = solved->converged;
  result.iterations = solved->iterations;
  result.solve_ms = solved->solve_ms;
  result.linear_solver = solved->linear_solver;
  result.message = solved->message;
  copyEstimates(*pose_graph, graph);
  result.chi2_final = g2oChi2(graph);
  return result;
}

}  // namespace vog::slam
