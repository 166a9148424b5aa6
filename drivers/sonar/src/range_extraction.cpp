#include "vog/sonar/range_extraction.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace vog::sonar {

Status RangeExtractionConfig::validate() const {
  if (!(noise_floor_percentile >= 0.0 && noise_floor_percentile <= 1.0)) {
    return Error{"range_extraction.noise_floor_percentile: " + std::to_string(noise_floor_percentile) +
                 " outside [0, 1]"};
  }
  if (!(threshold_above_noise > 0.0 && threshold_above_noise < 255.0)) {
    return Error{"range_extraction.threshold_above_noise: " + std::to_string(threshold_above_noise) +
                 " outside (0, 255)"};
  }
  if (min_run_samples < 1) {
    return Error{"range_extraction.min_run_samples: " + std::to_string(min_run_samples) + " must be >= 1"};
  }
  if (!(min_range_m >= 0.0) || !(max_range_m > min_range_m)) {
    return Error{"range_extraction.min_range_m/max_range_m: " + std::to_string(min_range_m) + " / " +
                 std::to_string(max_range_m) + " must satisfy 0 <= min < max"};
  }
  return {};
}

Result<geometry::RangeScan> extractRanges(const SonarFrame& frame, const RangeExtractionConfig& config) {
  if (auto st = config.validate(); !st.ok()) return st.error();
  const int n_beams = frame.n_beams;
  const int n_samples = frame.n_samples;
  if (n_beams < 1 || n_samples < 1 ||
      frame.samples.size() != static_cast<std::size_t>(n_beams) * static_cast<std::size_t>(n_samples)) {
    return Error{"sonar frame " + std::to_string(frame.frame_index) + ": " + std::to_string(frame.samples.size()) +
                 " samples for " + std::to_string(n_beams) + " beams x " + std::to_string(n_samples)};
  }
  if (!(frame.window_length_m > 0.0) || !std::isfinite(frame.window_length_m) || !std::isfinite(frame.window_start_m)) {
    return Error{"sonar frame " + std::to_string(frame.frame_index) + ": window length " +
                 std::to_string(frame.window_length_m) + " m not positive and finite"};
  }
  const std::size_t beams = static_cast<std::size_t>(n_beams);
  const std::uint8_t* data = frame.samples.data();

  // Noise floor: a percentile of all intensities of the frame, from a 256-bin histogram (most of
  // a frame is water column, so the median is background noise; thesis 4.1).
  std::array<std::array<std::uint32_t, 256>, 4> partial{};  // 4 tables break store-load chains
  const std::size_t total = frame.samples.size();
  std::size_t i = 0;
  for (; i + 4 <= total; i += 4) {
    ++partial[0][data[i]];
    ++partial[1][data[i + 1]];
    ++partial[2][data[i + 2]];
    ++partial[3][data[i + 3]];
  }
  for (; i < total; ++i) ++partial[0][data[i]];
  std::array<std::uint32_t, 256> histogram{};
  for (std::size_t v = 0; v < 256; ++v) histogram[v] = partial[0][v] + partial[1][v] + partial[2][v] + partial[3][v];
  const auto target =
      static_cast<std::uint64_t>(config.noise_floor_percentile * static_cast<double>(frame.samples.size() - 1));
  std::uint64_t cumulative = 0;
  int floor = 255;
  for (int v = 0; v < 256; ++v) {
    cumulative += histogram[static_cast<std::size_t>(v)];
    if (cumulative > target) {
      floor = v;
      break;
    }
  }
  const auto threshold = static_cast<int>(std::ceil(floor + config.threshold_above_noise));

  // Samples inside the range gate.
  const double sample_len = frame.sampleLength_m();
  const int first_sample =
      std::max(0, static_cast<int>(std::ceil((config.min_range_m - frame.window_start_m) / sample_len - 0.5)));
  const double last_f = std::floor((config.max_range_m - frame.window_start_m) / sample_len - 0.5);
  const int last_sample = last_f >= n_samples - 1 ? n_samples - 1 : static_cast<int>(last_f);

  geometry::RangeScan scan;
  scan.stamp_ns = frame.stamp_ns;
  scan.range_m.assign(beams, geometry::RangeScan::kNoReturn);
  // Per beam: length of the current run above threshold (saturating) and whether a return was
  // found. Each row is processed in branch-free passes the compiler vectorises; the scalar pass
  // runs only on rows where some beam completes its first run.
  const int min_run = std::min(config.min_run_samples, 255);
  std::vector<std::uint8_t> run(beams, 0);
  std::vector<std::uint8_t> done(beams, 0);
  std::size_t remaining = beams;
  auto row = [&](int s) { return data + static_cast<std::size_t>(std::clamp(s, 0, n_samples - 1)) * beams; };
  const bool median = config.median_denoise;
  const int thr = std::clamp(threshold, 0, 256);
  for (int s = first_sample; s <= last_sample && remaining > 0; ++s) {
    const std::uint8_t* prev = row(s - 1);
    const std::uint8_t* cur = row(s);
    const std::uint8_t* next = row(s + 1);
    std::uint8_t any_new = 0;
    for (std::size_t b = 0; b < beams; ++b) {
      int v = cur[b];
      if (median) {
        const int lo = std::min<int>(prev[b], cur[b]);
        const int hi = std::max<int>(prev[b], cur[b]);
        v = std::max(lo, std::min<int>(hi, next[b]));  // median of three
      }
      const int r = v >= thr ? std::min(run[b] + 1, 255) : 0;
      run[b] = static_cast<std::uint8_t>(r);
      any_new |= static_cast<std::uint8_t>((r >= min_run) & (done[b] == 0));
    }
    if (!any_new) continue;
    for (std::size_t b = 0; b < beams; ++b) {
      if (done[b] == 0 && run[b] >= min_run) {
        scan.range_m[b] = static_cast<float>(frame.rangeOfSample_m(s - min_run + 1));
        done[b] = 1;
        --remaining;
      }
    }
  }
  return scan;
}

}  // namespace vog::sonar
