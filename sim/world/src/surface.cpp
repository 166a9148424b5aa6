// Dense ground-truth surface sampling and the observable subset.

#include "vog/sim/rng.hpp"
#include "world_impl.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace vog::sim {

geometry::PointCloud World::sampleSurface(double spacing_m, std::uint64_t seed) const {
  geometry::PointCloud cloud;
  if (!(spacing_m > 0.0) || !std::isfinite(spacing_m)) return cloud;
  std::mt19937_64 rng = makeRng(seed, RngStream::kSurface);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double per_m2 = 1.0 / (spacing_m * spacing_m);

  for (const Triangle& t : triangles_) {
    const Eigen::Vector3d cross = (t.b - t.a).cross(t.c - t.a);
    const double area = 0.5 * cross.norm();
    if (area <= 0.0) continue;
    const Eigen::Vector3d n = cross.normalized();
    // Stochastic rounding keeps the expected density exact on small triangles.
    const auto count = static_cast<std::size_t>(std::floor(area * per_m2 + uni(rng)));
    for (std::size_t k = 0; k < count; ++k) {
      // Uniform point in a triangle (Osada et al. 2002, Sec. 4.2).
      const double r1 = std::sqrt(uni(rng));
      const double r2 = uni(rng);
      cloud.points.push_back((1.0 - r1) * t.a + r1 * (1.0 - r2) * t.b + r1 * r2 * t.c);
      cloud.normals.push_back(n);
    }
  }

  for (const AnalyticCylinder& c : impl_->cylinders) {
    const int n_theta = std::max(8, static_cast<int>(std::ceil(2.0 * std::numbers::pi * c.radius_m / spacing_m)));
    const int n_z = std::max(1, static_cast<int>(std::ceil((c.z1_m - c.z0_m) / spacing_m)));
    // A tank is seen from inside: its normals point to the axis.
    const double side_sign = c.caps ? 1.0 : -1.0;
    for (int j = 0; j < n_z; ++j) {
      const double z = c.z0_m + (c.z1_m - c.z0_m) * (j + 0.5) / n_z;
      for (int k = 0; k < n_theta; ++k) {
        const double a = 2.0 * std::numbers::pi * (k + 0.5) / n_theta;
        const Eigen::Vector3d radial(std::cos(a), std::sin(a), 0.0);
        cloud.points.push_back(c.T_world_local * Eigen::Vector3d(c.radius_m * radial + Eigen::Vector3d(0, 0, z)));
        cloud.normals.push_back(c.T_world_local.linear() * (side_sign * radial));
      }
    }
    if (!c.caps) continue;
    const int n_rings = std::max(1, static_cast<int>(std::ceil(c.radius_m / spacing_m)));
    for (const double zc : {c.z0_m, c.z1_m}) {
      const Eigen::Vector3d n_local(0, 0, zc == c.z1_m ? 1.0 : -1.0);
      for (int i = 0; i < n_rings; ++i) {
        const double rho = c.radius_m * (i + 0.5) / n_rings;
        const int n_ring = std::max(1, static_cast<int>(std::lround(2.0 * std::numbers::pi * rho / spacing_m)));
        for (int k = 0; k < n_ring; ++k) {
          const double a = 2.0 * std::numbers::pi * (k + 0.5) / n_ring;
          cloud.points.push_back(c.T_world_local * Eigen::Vector3d(rho * std::cos(a), rho * std::sin(a), zc));
          cloud.normals.push_back(c.T_world_local.linear() * n_local);
        }
      }
    }
  }
  return cloud;
}

ObservableConfig ObservableConfig::ofFan(const geometry::SonarFan& fan) {
  ObservableConfig c;
  c.max_range_m = fan.max_range_m;
  c.min_range_m = fan.min_range_m;
  c.min_elevation_rad = std::numbers::pi / 2;
  c.max_elevation_rad = -std::numbers::pi / 2;
  // Along the fan's arc at its beams' edges (the arc's elevation may peak between its ends).
  for (int i = 0; i <= fan.n_beams; ++i) {
    const double azimuth = -0.5 * fan.fov_rad + fan.fov_rad * static_cast<double>(i) / fan.n_beams;
    const Eigen::Vector3d d =
        fan.T_vehicle_sensor.linear() * Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), 0.0);
    const double elevation = std::asin(std::clamp(d.z() / d.norm(), -1.0, 1.0));
    c.min_elevation_rad = std::min(c.min_elevation_rad, elevation);
    c.max_elevation_rad = std::max(c.max_elevation_rad, elevation);
  }
  return c;
}

Status ObservableConfig::validate() const {
  if (!(max_range_m > 0.0) || !std::isfinite(max_range_m))
    return Error{"observable.max_range_m must be finite and > 0, got " + std::to_string(max_range_m)};
  if (!(min_range_m >= 0.0) || !(min_range_m < max_range_m))
    return Error{"observable.min_range_m must be >= 0 and below max_range_m, got " + std::to_string(min_range_m)};
  if (!(min_elevation_rad >= -std::numbers::pi / 2) || !(max_elevation_rad <= std::numbers::pi / 2) ||
      !(min_elevation_rad <= max_elevation_rad))
    return Error{"observable: the elevations must satisfy -pi/2 <= min_elevation_rad <= max_elevation_rad <= pi/2"};
  if (!(collision_box_m.minCoeff() > 0.0) || !collision_box_m.allFinite())
    return Error{"observable.collision_box_m must be finite and > 0 on every axis"};
  if (!(viewpoint_spacing_m >= 0.05) || !std::isfinite(viewpoint_spacing_m))
    return Error{"observable.viewpoint_spacing_m must be finite and >= 0.05, got " +
                 std::to_string(viewpoint_spacing_m)};
  return {};
}

Result<ObservableResult> observablePoints(const World& world, const geometry::PointCloud& surface,
                                          const ObservableConfig& config) {
  if (auto st = config.validate(); !st) return st.error();
  const Eigen::AlignedBox3d& box = world.scene().bounds_world;
  const double s = config.viewpoint_spacing_m;
  const Eigen::Vector3d extent = box.sizes();
  const Eigen::Vector3i dims((extent / s).array().floor().cast<int>().cwiseMax(1).matrix());
  if (static_cast<std::int64_t>(dims.x()) * dims.y() * dims.z() > 4'000'000)
    return Error{"observable.viewpoint_spacing_m too small for the exploration box (over 4e6 viewpoints)"};
  // Cell centres of a grid that exactly tiles the box.
  const Eigen::Vector3d step = extent.cwiseQuotient(dims.cast<double>());
  const Eigen::Vector3d half = 0.5 * config.collision_box_m;

  std::vector<char> free_vp(static_cast<std::size_t>(dims.prod()), 0);
  auto vpIndex = [&](int x, int y, int z) { return (static_cast<std::size_t>(z) * dims.y() + y) * dims.x() + x; };
  auto vpPos = [&](int x, int y, int z) {
    return Eigen::Vector3d(box.min() + step.cwiseProduct(Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5)));
  };
  for (int z = 0; z < dims.z(); ++z)
    for (int y = 0; y < dims.y(); ++y)
      for (int x = 0; x < dims.x(); ++x) {
        const Eigen::Vector3d p = vpPos(x, y, z);
        // The vehicle may turn, so a position is usable when some heading is free (0 or 45 deg).
        bool ok = false;
        for (const double yaw : {0.0, std::numbers::pi / 4}) {
          if (!world.boxCollides(geometry::poseFromXyzRpy(p.x(), p.y(), p.z(), 0, 0, yaw), half)) ok = true;
          if (ok) break;
        }
        free_vp[vpIndex(x, y, z)] = ok ? 1 : 0;
      }

  // Only positions the vehicle can reach from its start count (a seabed sheet across the box leaves
  // free positions under it, from where the seabed would be seen from below): breadth first from the
  // free position nearest the start, to the six neighbours whose centres a clear straight line joins.
  std::vector<Eigen::Vector3i> queue;
  {
    const Eigen::Vector3d start = world.scene().T_world_start.translation();
    double best = std::numeric_limits<double>::infinity();
    for (int z = 0; z < dims.z(); ++z)
      for (int y = 0; y < dims.y(); ++y)
        for (int x = 0; x < dims.x(); ++x)
          if (free_vp[vpIndex(x, y, z)] != 0 && (vpPos(x, y, z) - start).norm() < best) {
            best = (vpPos(x, y, z) - start).norm();
            queue.assign(1, Eigen::Vector3i(x, y, z));
          }
  }
  constexpr char kReached = 2;
  for (const Eigen::Vector3i& c : queue) free_vp[vpIndex(c.x(), c.y(), c.z())] = kReached;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const Eigen::Vector3i c = queue[head];
    for (int axis = 0; axis < 3; ++axis)
      for (const int d : {-1, 1}) {
        Eigen::Vector3i n = c;
        n[axis] += d;
        if (n[axis] < 0 || n[axis] >= dims[axis]) continue;
        char& state = free_vp[vpIndex(n.x(), n.y(), n.z())];
        if (state != 1 || world.segmentBlocked(vpPos(c.x(), c.y(), c.z()), vpPos(n.x(), n.y(), n.z()), 0.0)) continue;
        state = kReached;
        queue.push_back(n);
      }
  }
  for (char& state : free_vp) state = state == kReached ? 1 : 0;

  // Cell offsets sorted by length: nearest viewpoints are tried first, so a visible point usually
  // stops after a few rays.
  const Eigen::Vector3i reach =
      (Eigen::Vector3d::Constant(config.max_range_m).cwiseQuotient(step).array().ceil().cast<int>() + 1)
          .matrix()
          .cwiseMin(dims);
  std::vector<std::pair<double, Eigen::Vector3i>> offsets;
  for (int z = -reach.z(); z <= reach.z(); ++z)
    for (int y = -reach.y(); y <= reach.y(); ++y)
      for (int x = -reach.x(); x <= reach.x(); ++x) {
        const double d = step.cwiseProduct(Eigen::Vector3d(x, y, z)).norm();
        if (d <= config.max_range_m + step.norm()) offsets.emplace_back(d, Eigen::Vector3i(x, y, z));
      }
  std::sort(offsets.begin(), offsets.end(), [](const auto& a, const auto& b) { return a.first < b.first; });

  ObservableResult result;
  result.n_viewpoints = queue.size();  // the reachable positions
  const double eps = 1e-6;
  const Eigen::AlignedBox3d inside(box.min() - Eigen::Vector3d::Constant(eps),
                                   box.max() + Eigen::Vector3d::Constant(eps));
  for (std::size_t i = 0; i < surface.size(); ++i) {
    const Eigen::Vector3d& p = surface.points[i];
    if (!inside.contains(p)) continue;
    const Eigen::Vector3d f = (p - box.min()).cwiseQuotient(step) - Eigen::Vector3d::Constant(0.5);
    const Eigen::Vector3i base = f.array().round().cast<int>().matrix();
    bool seen = false;
    for (const auto& [d, off] : offsets) {
      const Eigen::Vector3i c = base + off;
      if ((c.array() < 0).any() || (c.array() >= dims.array()).any()) continue;
      if (free_vp[vpIndex(c.x(), c.y(), c.z())] == 0) continue;
      const Eigen::Vector3d vp = vpPos(c.x(), c.y(), c.z());
      const Eigen::Vector3d ray = p - vp;
      const double range = ray.norm();
      if (range > config.max_range_m || range < config.min_range_m) continue;
      const double elevation = std::asin(ray.z() / range);
      if (!(elevation >= config.min_elevation_rad && elevation <= config.max_elevation_rad)) continue;  // NaN: out
      if (!world.segmentBlocked(vp, p)) {
        seen = true;
        break;
      }
    }
    if (seen) {
      result.points.points.push_back(p);
      if (surface.hasNormals()) result.points.normals.push_back(surface.normals[i]);
    }
  }
  return result;
}

}  // namespace vog::sim
