// Vehicle-box collision against the scene: a uniform grid over conservative collision triangles
// and an exact separating-axis box/triangle test.

#include "world_impl.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace vog::sim {

namespace {
constexpr std::int64_t kMaxCellsPerTriangle = 20000;

int cellOf(double v, double cell) { return static_cast<int>(std::floor(v / cell)); }
}  // namespace

std::uint64_t CollisionIndex::key(int ix, int iy, int iz) const {
  // 21 bits per axis (two's complement, masked): unique for |index| < 2^20 cells.
  const auto m = [](int v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v)) & 0x1FFFFFu; };
  return (m(ix) << 42) | (m(iy) << 21) | m(iz);
}

void CollisionIndex::build(std::vector<Triangle> tris, double cell_size_m) {
  cell_m = cell_size_m;
  triangles = std::move(tris);
  cells.clear();
  large.clear();
  for (std::uint32_t t = 0; t < triangles.size(); ++t) {
    Eigen::AlignedBox3d b;
    b.extend(triangles[t].a).extend(triangles[t].b).extend(triangles[t].c);
    const int x0 = cellOf(b.min().x(), cell_m), x1 = cellOf(b.max().x(), cell_m);
    const int y0 = cellOf(b.min().y(), cell_m), y1 = cellOf(b.max().y(), cell_m);
    const int z0 = cellOf(b.min().z(), cell_m), z1 = cellOf(b.max().z(), cell_m);
    const std::int64_t n = std::int64_t{x1 - x0 + 1} * (y1 - y0 + 1) * (z1 - z0 + 1);
    if (n > kMaxCellsPerTriangle) {
      large.push_back(t);
      continue;
    }
    for (int x = x0; x <= x1; ++x)
      for (int y = y0; y <= y1; ++y)
        for (int z = z0; z <= z1; ++z) cells[key(x, y, z)].push_back(t);
  }
}

std::vector<std::uint32_t> CollisionIndex::candidates(const Eigen::AlignedBox3d& box) const {
  std::vector<std::uint32_t> out(large);
  const int x0 = cellOf(box.min().x(), cell_m), x1 = cellOf(box.max().x(), cell_m);
  const int y0 = cellOf(box.min().y(), cell_m), y1 = cellOf(box.max().y(), cell_m);
  const int z0 = cellOf(box.min().z(), cell_m), z1 = cellOf(box.max().z(), cell_m);
  for (int x = x0; x <= x1; ++x)
    for (int y = y0; y <= y1; ++y)
      for (int z = z0; z <= z1; ++z) {
        const auto it = cells.find(key(x, y, z));
        if (it != cells.end()) out.insert(out.end(), it->second.begin(), it->second.end());
      }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

bool boxTriangleOverlap(const geometry::Pose3& T_world_box, const Eigen::Vector3d& h, const Triangle& tri) {
  // Work in the box frame: the box is the AABB [-h, h].
  const geometry::Pose3 T_box_world = T_world_box.inverse();
  const std::array<Eigen::Vector3d, 3> v = {T_box_world * tri.a, T_box_world * tri.b, T_box_world * tri.c};
  // Box face normals.
  for (int i = 0; i < 3; ++i) {
    const double lo = std::min({v[0][i], v[1][i], v[2][i]});
    const double hi = std::max({v[0][i], v[1][i], v[2][i]});
    if (lo > h[i] || hi < -h[i]) return false;
  }
  const std::array<Eigen::Vector3d, 3> e = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  // Triangle normal.
  const Eigen::Vector3d n = e[0].cross(e[1]);
  {
    const double d = n.dot(v[0]);
    const double r = h.dot(n.cwiseAbs());
    if (std::abs(d) > r) return false;
  }
  // Cross products of box axes and triangle edges.
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d a = Eigen::Vector3d::Unit(i).cross(e[static_cast<std::size_t>(j)]);
      const double p0 = a.dot(v[0]), p1 = a.dot(v[1]), p2 = a.dot(v[2]);
      const double r = h.dot(a.cwiseAbs());
      if (std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r) return false;
    }
  }
  return true;
}

bool World::boxCollides(const geometry::Pose3& T_world_box, const Eigen::Vector3d& half_extents_m) const {
  Eigen::AlignedBox3d aabb;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d c((i & 1) ? half_extents_m.x() : -half_extents_m.x(),
                            (i & 2) ? half_extents_m.y() : -half_extents_m.y(),
                            (i & 4) ? half_extents_m.z() : -half_extents_m.z());
    aabb.extend(T_world_box * c);
  }
  for (const std::uint32_t t : impl_->collision.candidates(aabb)) {
    if (boxTriangleOverlap(T_world_box, half_extents_m, impl_->collision.triangles[t])) return true;
  }
  // A box entirely inside a closed solid touches no surface: test its centre against the solids.
  const Eigen::Vector3d c = T_world_box.translation();
  for (const auto& o : scene_.objects) {
    const Eigen::Vector3d p = o.T_world_object.inverse() * c;
    if (o.type == ObjectType::kBox) {
      if ((p.cwiseAbs() - 0.5 * o.size_m).maxCoeff() <= 0.0) return true;
    } else if (o.type == ObjectType::kCylinder) {
      if (std::abs(p.z()) <= 0.5 * o.length_m && p.head<2>().norm() <= o.radius_m) return true;
    }
  }
  return false;
}

}  // namespace vog::sim
