#include "vog/sim/render.hpp"

#include "vog/geometry/pose.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace vog::sim {

Status writePly(const std::filesystem::path& file, const geometry::PointCloud& cloud) {
  std::FILE* f = std::fopen(file.c_str(), "wb");
  if (f == nullptr) return Error{"cannot write " + file.string()};
  const bool normals = cloud.hasNormals();
  std::fprintf(f, "ply\nformat ascii 1.0\ncomment vog ground truth, metres, world frame (z up)\nelement vertex %zu\n",
               cloud.size());
  std::fprintf(f, "property double x\nproperty double y\nproperty double z\n");
  if (normals) std::fprintf(f, "property double nx\nproperty double ny\nproperty double nz\n");
  std::fprintf(f, "end_header\n");
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    if (normals) {
      const Eigen::Vector3d& n = cloud.normals[i];
      std::fprintf(f, "%.6f %.6f %.6f %.5f %.5f %.5f\n", p.x(), p.y(), p.z(), n.x(), n.y(), n.z());
    } else {
      std::fprintf(f, "%.6f %.6f %.6f\n", p.x(), p.y(), p.z());
    }
  }
  const bool bad = std::ferror(f) != 0;
  if (std::fclose(f) != 0 || bad) return Error{"error while writing " + file.string()};
  return {};
}

Result<geometry::PointCloud> readPly(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return Error{"cannot open " + file.string()};
  std::string line;
  int line_no = 0;
  auto where = [&] { return file.string() + ":" + std::to_string(line_no) + ": "; };
  std::size_t n_vertices = 0;
  std::vector<std::string> props;
  bool ascii = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 && line != "ply") return Error{where() + "not a PLY file"};
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") {
      std::string fmt;
      ls >> fmt;
      ascii = fmt == "ascii";
    } else if (word == "element") {
      std::string name;
      ls >> name >> n_vertices;
      if (name != "vertex") return Error{where() + "only a vertex element is supported"};
    } else if (word == "property") {
      std::string type, name;
      ls >> type >> name;
      props.push_back(name);
    } else if (word == "end_header") {
      break;
    }
  }
  if (!ascii) return Error{file.string() + ": only ASCII PLY is supported"};
  const bool has_normals = props.size() == 6 && props[3] == "nx";
  if (props.size() < 3 || props[0] != "x" || props[1] != "y" || props[2] != "z")
    return Error{file.string() + ": vertex properties must start with x y z"};
  geometry::PointCloud cloud;
  for (std::size_t i = 0; i < n_vertices; ++i) {
    if (!std::getline(in, line))
      return Error{file.string() + ": expected " + std::to_string(n_vertices) + " vertices, got " + std::to_string(i)};
    ++line_no;
    std::istringstream ls(line);
    std::vector<double> v(props.size());
    for (double& x : v)
      if (!(ls >> x) || !std::isfinite(x)) return Error{where() + "bad vertex"};
    cloud.points.emplace_back(v[0], v[1], v[2]);
    if (has_normals) cloud.normals.emplace_back(v[3], v[4], v[5]);
  }
  return cloud;
}

namespace {
// Height colour ramp: dark blue -> teal -> green -> yellow (perceptually ordered, like viridis).
void heightColour(double t, std::uint8_t& r, std::uint8_t& g, std::uint8_t& b) {
  static constexpr double kStops[4][3] = {{68, 1, 84}, {49, 104, 142}, {53, 183, 121}, {253, 231, 37}};
  t = std::clamp(t, 0.0, 1.0) * 3.0;
  const int i = std::min(2, static_cast<int>(t));
  const double f = t - i;
  r = static_cast<std::uint8_t>(std::lround(kStops[i][0] + f * (kStops[i + 1][0] - kStops[i][0])));
  g = static_cast<std::uint8_t>(std::lround(kStops[i][1] + f * (kStops[i + 1][1] - kStops[i][1])));
  b = static_cast<std::uint8_t>(std::lround(kStops[i][2] + f * (kStops[i + 1][2] - kStops[i][2])));
}
}  // namespace

RgbImage renderTopView(const World& world, const geometry::PointCloud& surface, double px_per_m) {
  const Eigen::AlignedBox3d& box = world.scene().bounds_world;
  const Eigen::Vector2d lo = box.min().head<2>() - Eigen::Vector2d(1.0, 1.0);
  const Eigen::Vector2d hi = box.max().head<2>() + Eigen::Vector2d(1.0, 1.0);
  const int w = static_cast<int>(std::ceil((hi.x() - lo.x()) * px_per_m));
  const int h = static_cast<int>(std::ceil((hi.y() - lo.y()) * px_per_m));
  RgbImage img(w, h, 20, 20, 28);
  auto px = [&](const Eigen::Vector2d& p) {
    return Eigen::Vector2i(static_cast<int>(std::floor((p.x() - lo.x()) * px_per_m)),
                           static_cast<int>(std::floor((hi.y() - p.y()) * px_per_m)));  // north up
  };
  // Keep the highest point per pixel (what is seen from above).
  std::vector<double> top(static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height),
                          -std::numeric_limits<double>::infinity());
  const double z_lo = box.min().z(), z_hi = box.max().z();
  for (const auto& p : surface.points) {
    const Eigen::Vector2i q = px(p.head<2>());
    if (q.x() < 0 || q.y() < 0 || q.x() >= img.width || q.y() >= img.height) continue;
    double& t =
        top[static_cast<std::size_t>(q.y()) * static_cast<std::size_t>(img.width) + static_cast<std::size_t>(q.x())];
    if (p.z() <= t) continue;
    t = p.z();
    std::uint8_t r, g, b;
    heightColour((p.z() - z_lo) / (z_hi - z_lo), r, g, b);
    img.set(q.x(), q.y(), r, g, b);
  }
  // Exploration box outline.
  const Eigen::Vector2i a = px(box.min().head<2>()), c = px(box.max().head<2>());
  for (int x = std::min(a.x(), c.x()); x <= std::max(a.x(), c.x()); ++x) {
    img.set(x, a.y(), 200, 200, 200);
    img.set(x, c.y(), 200, 200, 200);
  }
  for (int y = std::min(a.y(), c.y()); y <= std::max(a.y(), c.y()); ++y) {
    img.set(a.x(), y, 200, 200, 200);
    img.set(c.x(), y, 200, 200, 200);
  }
  // Start pose: a disc and a heading tick 0.8 m long.
  const Eigen::Vector2d s = world.scene().T_world_start.translation().head<2>();
  const double yaw = geometry::yawOf(world.scene().T_world_start.linear());
  const Eigen::Vector2i sc = px(s);
  const int rad = std::max(2, static_cast<int>(0.15 * px_per_m));
  for (int dy = -rad; dy <= rad; ++dy)
    for (int dx = -rad; dx <= rad; ++dx)
      if (dx * dx + dy * dy <= rad * rad) img.set(sc.x() + dx, sc.y() + dy, 230, 40, 40);
  for (double t = 0.0; t <= 0.8; t += 0.5 / px_per_m) {
    const Eigen::Vector2i q = px(s + t * Eigen::Vector2d(std::cos(yaw), std::sin(yaw)));
    img.set(q.x(), q.y(), 230, 40, 40);
  }
  return img;
}

}  // namespace vog::sim
