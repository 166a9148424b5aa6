#include "vog/depth/unesco.hpp"

#include <cmath>
#include <numbers>

namespace vog::depth {

double unescoDepth_m(double p, double latitude_deg) {
  // Fofonoff & Millard (1983), UNESCO Tech. Pap. Mar. Sci. 44, DEPTH: gravity variation with
  // latitude (International Formula) and pressure, then the polynomial of the specific volume of
  // the standard ocean (0 deg C, 35 PSU) integrated over pressure. p in decibars.
  const double s = std::sin(latitude_deg * std::numbers::pi / 180.0);
  const double x = s * s;
  const double gravity = 9.780318 * (1.0 + (5.2788e-3 + 2.36e-5 * x) * x) + 1.092e-6 * p;
  const double depth = (((-1.82e-15 * p + 2.279e-10) * p - 2.2512e-5) * p + 9.72659) * p;
  return depth / gravity;
}

}  // namespace vog::depth
