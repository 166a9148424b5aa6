#include "vog/geometry/sonar.hpp"

namespace vog::geometry {

Status SonarFan::validate() const {
  if (n_beams < 1 || n_beams > 4096) return Error{"sonar.n_beams must be in [1, 4096], got " + std::to_string(n_beams)};
  if (!(fov_rad > 0.0 && fov_rad < std::numbers::pi))
    return Error{"sonar.fov must be in (0, 180) deg, got " + std::to_string(rad2deg(fov_rad))};
  if (!(spread_rad >= 0.0 && spread_rad < std::numbers::pi / 2))
    return Error{"sonar.spread must be in [0, 90) deg, got " + std::to_string(rad2deg(spread_rad))};
  if (!(min_range_m >= 0.0)) return Error{"sonar.min_range_m must be >= 0, got " + std::to_string(min_range_m)};
  if (!(max_range_m > min_range_m) || !std::isfinite(max_range_m))
    return Error{"sonar.max_range_m must be finite and > min_range_m, got " + std::to_string(max_range_m)};
  if (!isValidPose(T_vehicle_sensor)) return Error{"sonar.T_vehicle_sensor is not a valid rigid transform"};
  return {};
}

double SonarFan::beamAzimuth(int i) const {
  return -0.5 * fov_rad + fov_rad * (static_cast<double>(i) + 0.5) / static_cast<double>(n_beams);
}

Eigen::Vector3d SonarFan::beamDirection(int i) const {
  const double a = beamAzimuth(i);
  return {std::cos(a), std::sin(a), 0.0};
}

}  // namespace vog::geometry
