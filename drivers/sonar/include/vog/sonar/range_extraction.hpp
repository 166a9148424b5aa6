#pragma once
// Range extraction: one range (or none) per beam from an intensity frame (thesis 4.1, following
// Teixeira et al. 2016): denoise along range (a 3-sample median removes single-sample speckle),
// threshold above the frame's noise floor, take the first strong return per beam (a run of
// `min_run_samples` samples above threshold) beyond a minimum range.

#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"
#include "vog/sonar/sonar_frame.hpp"

namespace vog::sonar {

struct RangeExtractionConfig {
  bool median_denoise = true;           // 3-sample median along range before thresholding
  double noise_floor_percentile = 0.5;  // the frame's median intensity estimates the noise floor
  double threshold_above_noise = 40.0;  // intensity counts (0..255) above the floor
  int min_run_samples = 3;              // consecutive samples above threshold to count as a return
  double min_range_m = 0.5;             // returns nearer than this are ignored (ringing, bubbles)
  double max_range_m = 1e9;             // returns farther than this are ignored

  // Names the first bad key and value, or is ok.
  Status validate() const;
};

// One entry per beam, beam order as in the frame; geometry::RangeScan::kNoReturn where no return.
// The range is that of the first sample of the first run that exceeds the threshold. Error if the
// frame is inconsistent (samples size, non-positive window) or the config is invalid.
Result<geometry::RangeScan> extractRanges(const SonarFrame& frame, const RangeExtractionConfig& config);

}  // namespace vog::sonar
