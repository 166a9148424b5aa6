#pragma once
// Profiling-sonar geometry shared by the simulator, the sonar driver, the map and the planner.
// A fan of beams spread over an azimuth field of view in the sensor's x-y plane (x forward), each beam
// `spread_rad` thick out of that plane. Mounted rolled 90 deg on the vehicle, the fan is vertical
// (thesis 4.1: DIDSON with a concentrator lens, 96 beams over 29 deg, 1 deg vertical).

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"

#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

namespace vog::geometry {

constexpr double deg2rad(double deg) { return deg * std::numbers::pi / 180.0; }
constexpr double rad2deg(double rad) { return rad * 180.0 / std::numbers::pi; }

struct SonarFan {
  int n_beams = 96;                  // thesis 4.1
  double fov_rad = deg2rad(29.0);    // thesis 4.1
  double spread_rad = deg2rad(1.0);  // thesis 4.1, concentrator lens
  double min_range_m = 0.5;
  double max_range_m = 11.0;                                              // thesis Table 4.2 (sensor d_max)
  Pose3 T_vehicle_sensor = poseFromXyzRpy(0, 0, 0, deg2rad(90.0), 0, 0);  // fan vertical

  // Names the first bad field, or is ok.
  Status validate() const;

  // Azimuth of beam i in the sensor frame, beams evenly spaced, beam 0 at -fov/2 side.
  double beamAzimuth(int i) const;
  // Unit direction of beam i in the sensor frame.
  Eigen::Vector3d beamDirection(int i) const;
};

// One sonar ping reduced to one range per beam. A beam with no return inside the window is
// `kNoReturn` (+inf): free space up to the maximum range. NaN is never valid.
struct RangeScan {
  static constexpr float kNoReturn = std::numeric_limits<float>::infinity();
  std::int64_t stamp_ns = 0;
  std::vector<float> range_m;
};

}  // namespace vog::geometry
