#pragma once
// One imaging-sonar frame (DIDSON / ARIS class): echo intensity per beam and range sample.
// Produced by the file readers (DDF, ARIS), the UDP live-frame transport and the simulator;
// consumed by range extraction, which turns it into a geometry::RangeScan.

#include <cstdint>
#include <vector>

namespace vog::sonar {

struct SonarFrame {
  std::int64_t stamp_ns = 0;
  std::uint32_t frame_index = 0;
  int n_beams = 0;
  int n_samples = 0;
  double window_start_m = 0.0;   // range of the near edge of sample 0
  double window_length_m = 0.0;  // range covered by all samples
  double sound_speed_mps = 1500.0;
  // Sample-major, as DIDSON and ARIS files store them: samples[s * n_beams + b].
  // Beam 0 is the beam at -fov/2 (geometry::SonarFan::beamAzimuth(0)).
  std::vector<std::uint8_t> samples;

  double sampleLength_m() const { return n_samples > 0 ? window_length_m / n_samples : 0.0; }
  // Range of the centre of sample s.
  double rangeOfSample_m(int s) const { return window_start_m + (s + 0.5) * sampleLength_m(); }
  std::uint8_t at(int beam, int sample) const {
    return samples[static_cast<std::size_t>(sample) * static_cast<std::size_t>(n_beams) +
                   static_cast<std::size_t>(beam)];
  }
};

}  // namespace vog::sonar
