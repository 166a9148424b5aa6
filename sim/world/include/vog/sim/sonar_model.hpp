#pragma once
// Profiling-sonar model (thesis 4.1, 4.4.1): the fan of geometry::SonarFan cast into the World.
//
// Beam model: each beam is sampled by `sub_rays_per_beam` rays spread evenly across its vertical
// spread (the -3 dB width of the concentrator lens, 1 deg), endpoints included. The beam's range is
// the MINIMUM over its sub-rays: the leading edge of the echo is the nearest surface inside the beam,
// and that edge is what a threshold-based range extraction reports. The thesis's own simulation used
// one ray per beam (4.4.1); the sub-rays model the 1 deg thickness it left out.
//
// Noise: the range gets N(0, range_noise_sigma_m); a return nearer than min_range_m or beyond
// max_range_m (after noise) is RangeScan::kNoReturn, as no echo lands inside the sonar's window.
//
// Intensity frame (DIDSON-like, sample-major, window [min_range, max_range]): every sample starts as
// Rayleigh speckle amplitude with mean `noise_floor`. Each sub-ray that hits returns the transmitted
// pulse: a rectangular envelope of `pulse_length_m` starting at its range (plus the beam's range
// noise), integrated over each sample's extent (so the leading edge lands in the right sample), then
// an exponential tail of `echo_decay_m` (reverberation inside the target). Its amplitude falls with
// incidence angle and carries a mild gamma speckle; overlapping echoes add and saturate at 255.
// Samples behind the first return are in acoustic shadow (background halved). A beam with no return
// is background only. A threshold on the leading edge (what drivers/sonar's range extraction does)
// therefore recovers the beam's range to within one sample.
//
// Lifecycle: construct with a World (borrowed, must outlive the model), a validated config and a
// seed; each ping() draws from the model's own random streams, so the sequence of pings is
// deterministic per seed.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"
#include "vog/sim/world.hpp"
#include "vog/sonar/sonar_frame.hpp"

#include <cstdint>
#include <random>

namespace vog::sim {

struct SonarModelConfig {
  geometry::SonarFan fan;  // thesis 4.1 / Table 4.2 defaults
  int sub_rays_per_beam = 5;
  double range_noise_sigma_m = 0.01;  // about half the DIDSON range resolution (thesis 4.1: < 2 cm)
  // Intensity frame.
  int frame_samples = 512;       // 10.5 m window -> 2.05 cm per sample
  double noise_floor = 12.0;     // mean background level (0-255)
  double echo_peak = 200.0;      // mean echo amplitude at normal incidence
  double pulse_length_m = 0.06;  // transmitted pulse length (about 3 samples)
  double echo_decay_m = 0.05;    // decay length of the echo's tail

  Status validate() const;
};

struct SonarPing {
  geometry::RangeScan scan;
  sonar::SonarFrame frame;  // empty (n_samples == 0) unless requested
};

class SonarModel {
 public:
  static Result<SonarModel> create(const World& world, const SonarModelConfig& config, std::uint64_t seed);

  // One ping at the vehicle pose, stamped stamp_ns. `frame_index` labels the intensity frame.
  SonarPing ping(const geometry::Pose3& T_world_vehicle, std::int64_t stamp_ns, bool with_frame,
                 std::uint32_t frame_index = 0);

  const SonarModelConfig& config() const { return config_; }

  // Unit direction of sub-ray k of beam i in the sensor frame.
  Eigen::Vector3d subRayDirection(int beam, int k) const;

 private:
  SonarModel(const World& world, const SonarModelConfig& config, std::uint64_t seed);

  const World* world_;
  SonarModelConfig config_;
  std::vector<Eigen::Vector3d> sub_ray_dirs_sensor_;  // beam-major
  std::mt19937_64 range_rng_;
  std::mt19937_64 frame_rng_;
};

}  // namespace vog::sim
