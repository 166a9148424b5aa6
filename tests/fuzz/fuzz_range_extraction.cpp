// Range extraction on arbitrary intensities: one finite positive range or kNoReturn per beam.
#include "fuzz_check.hpp"
#include "vog/sonar/range_extraction.hpp"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  vog::sonar::SonarFrame f;
  f.n_beams = 1 + data[0] % 16;
  f.n_samples = static_cast<int>((size - 2) / static_cast<std::size_t>(f.n_beams));
  f.window_start_m = data[1] % 4;
  f.window_length_m = 10.0;
  f.samples.assign(data + 2, data + 2 + static_cast<std::size_t>(f.n_beams) * static_cast<std::size_t>(f.n_samples));
  const auto scan = vog::sonar::extractRanges(f, vog::sonar::RangeExtractionConfig{});
  if (f.n_samples == 0) {
    VOG_FUZZ_CHECK(!scan.ok());
    return 0;
  }
  VOG_FUZZ_CHECK(scan.ok());
  VOG_FUZZ_CHECK(scan->range_m.size() == static_cast<std::size_t>(f.n_beams));
  for (const float r : scan->range_m)
    VOG_FUZZ_CHECK(r == vog::geometry::RangeScan::kNoReturn || (std::isfinite(r) && r > 0.0f));
  return 0;
}
