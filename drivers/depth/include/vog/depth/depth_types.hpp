#pragma once
// Depth sensor domain types and the pressure -> depth conversion settings.

#include "vog/core/result.hpp"

#include <cstdint>

namespace vog::depth {

struct DepthSample {
  std::int64_t stamp_ns = 0;          // host receive time (set by the driver)
  double absolute_pressure_pa = 0.0;  // as measured by the sensor
  double sea_pressure_pa = 0.0;       // absolute minus atmospheric
  double depth_m = 0.0;               // positive down, UNESCO 1983
};

// Settings of the conversion from the sensor reading to depth.
struct DepthConversionConfig {
  int units_code = 1;                         // Digiquartz UN code of the readings (1 = psi, factory default)
  double latitude_deg = 42.0;                 // gravity varies with latitude (UNESCO 1983 Eq. 25)
  double atmospheric_pressure_pa = 101325.0;  // subtracted from absolute readings
  bool reading_is_absolute = true;            // false for gauge sensors (atmosphere already removed)

  // Names the first bad key and value, or is ok.
  Status validate() const;
};

}  // namespace vog::depth
