#include "vog/sim/sonar_model.hpp"

#include "vog/sim/rng.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace vog::sim {

Status SonarModelConfig::validate() const {
  if (auto st = fan.validate(); !st) return st;
  if (sub_rays_per_beam < 1 || sub_rays_per_beam > 64)
    return Error{"sonar.sub_rays_per_beam must be in [1, 64], got " + std::to_string(sub_rays_per_beam)};
  if (!(range_noise_sigma_m >= 0.0) || !std::isfinite(range_noise_sigma_m))
    return Error{"sonar.range_noise_sigma_m must be finite and >= 0, got " + std::to_string(range_noise_sigma_m)};
  if (frame_samples < 8 || frame_samples > 8192)
    return Error{"sonar.frame_samples must be in [8, 8192], got " + std::to_string(frame_samples)};
  if (!(noise_floor >= 0.0 && noise_floor < 255.0))
    return Error{"sonar.noise_floor must be in [0, 255), got " + std::to_string(noise_floor)};
  if (!(echo_peak > noise_floor && echo_peak <= 255.0))
    return Error{"sonar.echo_peak must be in (noise_floor, 255], got " + std::to_string(echo_peak)};
  if (!(pulse_length_m > 0.0) || !std::isfinite(pulse_length_m))
    return Error{"sonar.pulse_length_m must be finite and > 0, got " + std::to_string(pulse_length_m)};
  if (!(echo_decay_m > 0.0) || !std::isfinite(echo_decay_m))
    return Error{"sonar.echo_decay_m must be finite and > 0, got " + std::to_string(echo_decay_m)};
  return {};
}

Result<SonarModel> SonarModel::create(const World& world, const SonarModelConfig& config, std::uint64_t seed) {
  if (auto st = config.validate(); !st) return st.error();
  return SonarModel(world, config, seed);
}

SonarModel::SonarModel(const World& world, const SonarModelConfig& config, std::uint64_t seed)
    : world_(&world),
      config_(config),
      range_rng_(makeRng(seed, RngStream::kSonarRange)),
      frame_rng_(makeRng(seed, RngStream::kSonarFrame)) {
  const int n = config_.sub_rays_per_beam;
  for (int b = 0; b < config_.fan.n_beams; ++b) {
    const double az = config_.fan.beamAzimuth(b);
    for (int k = 0; k < n; ++k) {
      // Endpoints included: the outer sub-rays sit on the -3 dB edges of the 1 deg beam.
      const double el = n == 1 ? 0.0 : config_.fan.spread_rad * (static_cast<double>(k) / (n - 1) - 0.5);
      sub_ray_dirs_sensor_.emplace_back(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    }
  }
}

Eigen::Vector3d SonarModel::subRayDirection(int beam, int k) const {
  return sub_ray_dirs_sensor_[static_cast<std::size_t>(beam * config_.sub_rays_per_beam + k)];
}

SonarPing SonarModel::ping(const geometry::Pose3& T_world_vehicle, std::int64_t stamp_ns, bool with_frame,
                           std::uint32_t frame_index) {
  const geometry::SonarFan& fan = config_.fan;
  const geometry::Pose3 T_world_sensor = T_world_vehicle * fan.T_vehicle_sensor;
  const Eigen::Vector3d origin = T_world_sensor.translation();
  const Eigen::Matrix3d R = T_world_sensor.linear();
  const int n_sub = config_.sub_rays_per_beam;
  const auto n_beams = static_cast<std::size_t>(fan.n_beams);

  SonarPing out;
  out.scan.stamp_ns = stamp_ns;
  out.scan.range_m.assign(n_beams, geometry::RangeScan::kNoReturn);

  // Per sub-ray true range and echo strength; kept only when a frame is rendered.
  std::vector<double> sub_range;
  std::vector<double> sub_strength;
  if (with_frame) {
    sub_range.assign(n_beams * static_cast<std::size_t>(n_sub), -1.0);
    sub_strength.assign(sub_range.size(), 0.0);
  }
  std::vector<double> beam_offset(n_beams, 0.0);
  std::normal_distribution<double> range_noise(0.0, 1.0);

  // The ray is cast a little beyond max range so that noise can carry a surface just outside
  // the window inside it, symmetric with noise carrying one out.
  const double cast_range = fan.max_range_m + 4.0 * config_.range_noise_sigma_m;
  for (std::size_t b = 0; b < n_beams; ++b) {
    double nearest = std::numeric_limits<double>::infinity();
    for (int k = 0; k < n_sub; ++k) {
      const Eigen::Vector3d dir =
          R * sub_ray_dirs_sensor_[b * static_cast<std::size_t>(n_sub) + static_cast<std::size_t>(k)];
      const auto hit = world_->castRay(origin, dir, cast_range);
      if (!hit) continue;
      nearest = std::min(nearest, hit->range_m);
      if (with_frame) {
        const std::size_t i = b * static_cast<std::size_t>(n_sub) + static_cast<std::size_t>(k);
        sub_range[i] = hit->range_m;
        // Lambertian-like backscatter: stronger at normal incidence.
        sub_strength[i] = std::abs(hit->normal_world.dot(dir));
      }
    }
    // One draw per beam whether or not it hits, so the noise sequence does not depend on the scene.
    const double offset = config_.range_noise_sigma_m * range_noise(range_rng_);
    beam_offset[b] = offset;
    if (!std::isfinite(nearest)) continue;
    const double r = nearest + offset;
    if (r >= fan.min_range_m && r <= fan.max_range_m) out.scan.range_m[b] = static_cast<float>(r);
  }
  if (!with_frame) return out;

  sonar::SonarFrame& f = out.frame;
  f.stamp_ns = stamp_ns;
  f.frame_index = frame_index;
  f.n_beams = fan.n_beams;
  f.n_samples = config_.frame_samples;
  f.window_start_m = fan.min_range_m;
  f.window_length_m = fan.max_range_m - fan.min_range_m;
  f.samples.assign(n_beams * static_cast<std::size_t>(f.n_samples), 0);
  const double ds = f.sampleLength_m();
  // Background: Rayleigh-distributed amplitude of fully developed speckle, mean noise_floor
  // (Rayleigh with sigma sqrt(2/pi) has mean 1; sample as sigma * sqrt(2 E), E ~ Exp(1)).
  std::exponential_distribution<double> exp1(1.0);
  const double rayleigh_sigma = std::sqrt(2.0 / std::numbers::pi);
  std::vector<double> column(static_cast<std::size_t>(f.n_samples));
  for (std::size_t b = 0; b < n_beams; ++b) {
    const double first = static_cast<double>(out.scan.range_m[b]);
    for (int s = 0; s < f.n_samples; ++s) {
      const double shadow = std::isfinite(first) && f.rangeOfSample_m(s) > first + config_.pulse_length_m ? 0.5 : 1.0;
      column[static_cast<std::size_t>(s)] =
          shadow * config_.noise_floor * rayleigh_sigma * std::sqrt(2.0 * exp1(frame_rng_));
    }
    if (std::isfinite(first)) {
      for (int k = 0; k < n_sub; ++k) {
        const std::size_t i = b * static_cast<std::size_t>(n_sub) + static_cast<std::size_t>(k);
        if (sub_range[i] < 0.0) continue;
        const double r = sub_range[i] + beam_offset[b];
        // Mild speckle on the echo itself (gamma with shape 16: mean 1, sd 0.25) keeps the peak
        // well above the floor, as the concentrator lens' strong returns do.
        std::gamma_distribution<double> echo_speckle(16.0, 1.0 / 16.0);
        const double amp =
            (config_.echo_peak - config_.noise_floor) * (0.7 + 0.3 * sub_strength[i]) * echo_speckle(frame_rng_);
        const double tail_end = r + config_.pulse_length_m + 6.0 * config_.echo_decay_m;
        const int s_lo = std::max(0, static_cast<int>(std::floor((r - f.window_start_m) / ds)));
        const int s_hi = std::min(f.n_samples - 1, static_cast<int>(std::ceil((tail_end - f.window_start_m) / ds)));
        for (int s = s_lo; s <= s_hi; ++s) {
          const double c = f.rangeOfSample_m(s);
          // Share of the sample [c - ds/2, c + ds/2] covered by the pulse [r, r + L].
          const double covered =
              std::clamp(std::min(c + 0.5 * ds, r + config_.pulse_length_m) - std::max(c - 0.5 * ds, r), 0.0, ds) / ds;
          const double tail =
              c > r + config_.pulse_length_m ? std::exp(-(c - r - config_.pulse_length_m) / config_.echo_decay_m) : 0.0;
          column[static_cast<std::size_t>(s)] += amp * std::max(covered, tail);
        }
      }
    }
    for (int s = 0; s < f.n_samples; ++s) {
      const double v = std::clamp(column[static_cast<std::size_t>(s)], 0.0, 255.0);
      f.samples[static_cast<std::size_t>(s) * n_beams + b] = static_cast<std::uint8_t>(std::lround(v));
    }
  }
  return out;
}

}  // namespace vog::sim
