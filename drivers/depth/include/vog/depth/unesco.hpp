#pragma once
// Seawater depth from pressure: Fofonoff & Millard, "Algorithms for computation of fundamental
// properties of seawater", UNESCO Technical Papers in Marine Science 44 (1983), DEPTH function.
// Check value (paper p. 28): 10000 dbar at 30 deg latitude -> 9712.653 m.

namespace vog::depth {

// Depth in metres for a sea pressure (absolute minus atmospheric) in decibars, latitude in degrees.
double unescoDepth_m(double sea_pressure_dbar, double latitude_deg);

}  // namespace vog::depth
