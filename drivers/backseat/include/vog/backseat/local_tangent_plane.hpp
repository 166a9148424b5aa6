#pragma once
// Latitude/longitude <-> a local world frame (x east, y north, metres) for the backseat sentences,
// which carry positions as ddmm.mmmm (PROTOCOLS.md, HAUV backseat).
//
// A local tangent plane at an origin: north = (lat - lat0) * M(lat0), east = (lon - lon0) * N(lat0)
// cos(lat0), with M and N the WGS84 meridional and prime-vertical radii of curvature at the origin
// (the flat-earth approximation; over the few hundred metres of a harbour survey its error is far
// below the 1e-6' = 2 mm resolution of the sentences). The two directions are exact inverses.

#include "vog/core/result.hpp"

#include <Eigen/Core>

namespace vog::backseat {

struct GeoPoint {
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
};

// Immutable after create().
class LocalTangentPlane {
 public:
  // Errors when the origin is not finite, |lat| > 80 deg (the approximation degrades near the
  // poles) or |lon| > 180 deg.
  static Result<LocalTangentPlane> create(GeoPoint origin);

  GeoPoint toGeo(const Eigen::Vector2d& xy_world_m) const;
  Eigen::Vector2d toLocal(const GeoPoint& point) const;
  const GeoPoint& origin() const { return origin_; }
  double metresPerDegreeLatitude() const { return m_per_deg_lat_; }
  double metresPerDegreeLongitude() const { return m_per_deg_lon_; }

 private:
  LocalTangentPlane(GeoPoint origin, double m_per_deg_lat, double m_per_deg_lon)
      : origin_(origin), m_per_deg_lat_(m_per_deg_lat), m_per_deg_lon_(m_per_deg_lon) {}
  GeoPoint origin_;
  double m_per_deg_lat_;
  double m_per_deg_lon_;
};

}  // namespace vog::backseat
