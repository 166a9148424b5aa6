#include "synthetic_scene.hpp"

#include <cmath>
#include <limits>
#include <numbers>

namespace vog::test {

double SyntheticScene::raycast(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& p : planes) {
    if (std::abs(d.z()) < 1e-12) continue;
    const double t = (p.z - o.z()) / d.z();
    if (t > 1e-9 && t < best) best = t;
  }
  for (const auto& c : cylinders) {
    const Eigen::Vector2d oc = o.head<2>() - c.centre_xy;
    const Eigen::Vector2d dxy = d.head<2>();
    const double a = dxy.squaredNorm();
    if (a < 1e-15) continue;
    const double b = 2.0 * oc.dot(dxy);
    const double cc = oc.squaredNorm() - c.radius * c.radius;
    const double disc = b * b - 4.0 * a * cc;
    if (disc < 0.0) continue;
    const double sq = std::sqrt(disc);
    for (double t : {(-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)}) {
      if (t <= 1e-9 || t >= best) continue;
      const double z = o.z() + t * d.z();
      if (z >= c.z_min && z <= c.z_max) {
        best = t;
        break;
      }
    }
  }
  return best;
}

geometry::RangeScan SyntheticScene::scan(const geometry::Pose3& T_world_vehicle, const geometry::SonarFan& fan,
                                         double sigma_m, std::mt19937_64& rng) const {
  geometry::RangeScan out;
  out.range_m.resize(static_cast<std::size_t>(fan.n_beams));
  const geometry::Pose3 T_world_sensor = T_world_vehicle * fan.T_vehicle_sensor;
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int i = 0; i < fan.n_beams; ++i) {
    const Eigen::Vector3d dir = T_world_sensor.linear() * fan.beamDirection(i);
    double r = raycast(T_world_sensor.translation(), dir);
    if (sigma_m > 0.0 && std::isfinite(r)) r += sigma_m * noise(rng);
    const bool valid = std::isfinite(r) && r <= fan.max_range_m && r >= fan.min_range_m;
    out.range_m[static_cast<std::size_t>(i)] = valid ? static_cast<float>(r) : geometry::RangeScan::kNoReturn;
  }
  return out;
}

SyntheticScene SyntheticScene::pier() {
  SyntheticScene s;
  s.planes.push_back({-4.0});
  const double xs[] = {-3.1, -1.0, 1.2, 3.0};
  const double ys[] = {-2.0, 0.3, 2.2};
  int i = 0;
  for (double x : xs) {
    for (double y : ys) {
      s.cylinders.push_back({Eigen::Vector2d(x + 0.15 * (i % 3), y), 0.2 + 0.05 * (i % 4), -4.0, 0.5});
      ++i;
    }
  }
  return s;
}

std::vector<geometry::Pose3> orbitTrajectory(int n_scans, double radius_m, double depth_m) {
  std::vector<geometry::Pose3> poses;
  poses.reserve(static_cast<std::size_t>(n_scans));
  const double speed = 0.25;   // m/s, thesis Table 4.2
  const double scan_dt = 0.2;  // 5 scans/s
  double angle = 0.0;
  double radius = radius_m;
  double depth = depth_m;
  for (int k = 0; k < n_scans; ++k) {
    const double x = radius * std::cos(angle);
    const double y = radius * std::sin(angle);
    const double yaw = angle + std::numbers::pi;  // facing the centre
    poses.push_back(geometry::poseFromXyzRpy(x, y, depth, 0.0, 0.0, yaw));
    const double prev = angle;
    angle += speed * scan_dt / radius;
    if (std::floor(angle / (2 * std::numbers::pi)) != std::floor(prev / (2 * std::numbers::pi))) {
      // Next lap: wider and deeper, so laps overlap partly (loop-closure-like revisits).
      radius = radius_m + 0.7 * std::fmod(std::floor(angle / (2 * std::numbers::pi)), 4.0);
      depth = depth_m - 0.4 * std::fmod(std::floor(angle / (2 * std::numbers::pi)), 3.0);
    }
  }
  return poses;
}

}  // namespace vog::test
