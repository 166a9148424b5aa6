#include "vog/backseat/local_tangent_plane.hpp"

#include <cmath>
#include <numbers>
#include <string>

namespace vog::backseat {

Result<LocalTangentPlane> LocalTangentPlane::create(GeoPoint origin) {
  if (!std::isfinite(origin.latitude_deg) || std::abs(origin.latitude_deg) > 80.0)
    return Error{"origin latitude_deg must be within [-80, 80], got " + std::to_string(origin.latitude_deg)};
  if (!std::isfinite(origin.longitude_deg) || std::abs(origin.longitude_deg) > 180.0)
    return Error{"origin longitude_deg must be within [-180, 180], got " + std::to_string(origin.longitude_deg)};
  // WGS84 (NIMA TR8350.2): a = 6378137 m, e^2 = 6.69437999014e-3.
  constexpr double a = 6378137.0;
  constexpr double e2 = 6.69437999014e-3;
  const double phi = origin.latitude_deg * std::numbers::pi / 180.0;
  const double w = 1.0 - e2 * std::sin(phi) * std::sin(phi);
  const double m_radius = a * (1.0 - e2) / (w * std::sqrt(w));  // meridional
  const double n_radius = a / std::sqrt(w);                     // prime vertical
  const double rad = std::numbers::pi / 180.0;
  return LocalTangentPlane(origin, m_radius * rad, n_radius * std::cos(phi) * rad);
}

GeoPoint LocalTangentPlane::toGeo(const Eigen::Vector2d& xy_world_m) const {
  return GeoPoint{origin_.latitude_deg + xy_world_m.y() / m_per_deg_lat_,
                  origin_.longitude_deg + xy_world_m.x() / m_per_deg_lon_};
}

Eigen::Vector2d LocalTangentPlane::toLocal(const GeoPoint& point) const {
  return Eigen::Vector2d((point.longitude_deg - origin_.longitude_deg) * m_per_deg_lon_,
                         (point.latitude_deg - origin_.latitude_deg) * m_per_deg_lat_);
}

}  // namespace vog::backseat
