#include "vog/sim/paths.hpp"

#include "vog/geometry/sonar.hpp"
#include "vog/yaml/config_reader.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <numbers>

namespace vog::sim {

Status PathConfig::validate() const {
  if (!(margin_m >= 0.0) || !std::isfinite(margin_m))
    return Error{"path.margin_m must be finite and >= 0, got " + std::to_string(margin_m)};
  if (!(lane_spacing_m > 0.0) || !std::isfinite(lane_spacing_m))
    return Error{"path.lane_spacing_m must be finite and > 0, got " + std::to_string(lane_spacing_m)};
  if (!(orbit_radius_m >= 0.0) || !std::isfinite(orbit_radius_m))
    return Error{"path.orbit_radius_m must be finite and >= 0, got " + std::to_string(orbit_radius_m)};
  if (std::isinf(z_m)) return Error{"path.z_m must be finite (or unset), got " + std::to_string(z_m)};
  if (orbit_points < 4 || orbit_points > 3600)
    return Error{"path.orbit_points must be in [4, 3600], got " + std::to_string(orbit_points)};
  return {};
}

namespace {
Waypoint startWaypoint(const Scene& scene) {
  return {scene.T_world_start.translation(), geometry::yawOf(scene.T_world_start.linear())};
}

Result<double> pathZ(const Scene& scene, const PathConfig& config) {
  if (std::isnan(config.z_m)) return scene.T_world_start.translation().z();
  if (config.z_m < scene.bounds_world.min().z() || config.z_m > scene.bounds_world.max().z())
    return Error{"path.z_m " + std::to_string(config.z_m) + " is outside the exploration box"};
  return config.z_m;
}
}  // namespace

Result<std::vector<Waypoint>> lawnmowerPath(const Scene& scene, const PathConfig& config) {
  if (auto st = config.validate(); !st) return st.error();
  const Eigen::Vector3d lo = scene.bounds_world.min() + Eigen::Vector3d(config.margin_m, config.margin_m, 0);
  const Eigen::Vector3d hi = scene.bounds_world.max() - Eigen::Vector3d(config.margin_m, config.margin_m, 0);
  if (!(hi.x() > lo.x()) || !(hi.y() > lo.y()))
    return Error{"path.margin_m " + std::to_string(config.margin_m) + " leaves no room inside the exploration box"};
  const auto z_r = pathZ(scene, config);
  if (!z_r) return z_r.error();
  const double z = *z_r;
  std::vector<Waypoint> wps{startWaypoint(scene)};
  const int lanes = 1 + static_cast<int>(std::floor((hi.y() - lo.y()) / config.lane_spacing_m));
  for (int k = 0; k < lanes; ++k) {
    const double y = lo.y() + k * config.lane_spacing_m;
    const bool forward = k % 2 == 0;
    const double yaw = forward ? 0.0 : std::numbers::pi;
    const double x0 = forward ? lo.x() : hi.x();
    const double x1 = forward ? hi.x() : lo.x();
    wps.push_back({Eigen::Vector3d(x0, y, z), yaw});
    wps.push_back({Eigen::Vector3d(x1, y, z), yaw});
  }
  return wps;
}

Result<std::vector<Waypoint>> orbitPath(const Scene& scene, const PathConfig& config) {
  if (auto st = config.validate(); !st) return st.error();
  const Eigen::Vector3d centre = scene.bounds_world.center();
  const Eigen::Vector3d half = 0.5 * scene.bounds_world.sizes();
  const double max_radius = std::min(half.x(), half.y()) - config.margin_m;
  const double radius = config.orbit_radius_m > 0.0 ? config.orbit_radius_m : max_radius;
  if (!(radius > 0.0) || radius > max_radius + 1e-9)
    return Error{"path.orbit_radius_m " + std::to_string(radius) + " does not fit the exploration box (max " +
                 std::to_string(max_radius) + ")"};
  const Eigen::Vector3d start = scene.T_world_start.translation();
  const auto z_r = pathZ(scene, config);
  if (!z_r) return z_r.error();
  const double z = *z_r;
  const double a0 = std::atan2(start.y() - centre.y(), start.x() - centre.x());
  std::vector<Waypoint> wps{startWaypoint(scene)};
  for (int k = 0; k <= config.orbit_points; ++k) {
    const double a = a0 + 2.0 * std::numbers::pi * k / config.orbit_points;
    const Eigen::Vector3d p(centre.x() + radius * std::cos(a), centre.y() + radius * std::sin(a), z);
    wps.push_back({p, geometry::wrapAngle(a + std::numbers::pi)});
  }
  return wps;
}

Result<std::vector<Waypoint>> loadWaypointFile(const std::filesystem::path& file) {
  const std::string src = file.string();
  auto text = yaml::readText(file, "waypoint file");
  if (!text) return text.error();
  auto document = yaml::parseDocument(text.value(), src);
  if (!document) return document.error();
  const YAML::Node root = document.value();
  auto at = [&](const YAML::Node& n) { return yaml::location(src, n) + ": "; };
  if (!root.IsMap() || !root["waypoints"] || root.size() != 1)
    return Error{at(root) + "waypoints: the file must be a mapping with the single key 'waypoints'"};
  const YAML::Node list = root["waypoints"];
  if (!list.IsSequence() || list.size() == 0) return Error{at(list) + "waypoints: must be a non-empty list"};
  std::vector<Waypoint> wps;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node w = list[i];
    const std::string key = "waypoints[" + std::to_string(i) + "]";
    if (!w.IsMap()) return Error{at(w) + key + ": must be a mapping {xyz: [x, y, z], yaw_deg: d}"};
    for (const auto& kv : w) {
      const std::string k = kv.first.Scalar();
      if (k != "xyz" && k != "yaw_deg")
        return Error{at(kv.first) + key + "." + k + ": unknown key (allowed: xyz, yaw_deg)"};
    }
    const YAML::Node xyz = w["xyz"];
    if (!xyz || !xyz.IsSequence() || xyz.size() != 3) return Error{at(w) + key + ".xyz: must be a list of 3 numbers"};
    Waypoint wp;
    try {
      for (std::size_t j = 0; j < 3; ++j) wp.xyz_world[static_cast<int>(j)] = xyz[j].as<double>();
      wp.yaw_rad = w["yaw_deg"] ? geometry::deg2rad(w["yaw_deg"].as<double>()) : 0.0;
    } catch (const YAML::Exception&) {
      return Error{at(w) + key + ": xyz and yaw_deg must be numbers"};
    }
    if (!wp.xyz_world.allFinite() || !std::isfinite(wp.yaw_rad)) return Error{at(w) + key + ": values must be finite"};
    wps.push_back(wp);
  }
  return wps;
}

}  // namespace vog::sim
