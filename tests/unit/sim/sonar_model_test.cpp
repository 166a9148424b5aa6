#include "vog/sim/sonar_model.hpp"

#include "test_support.hpp"
#include "world_from_text.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace vog::sim {
namespace {

// Objects up to the sonar's range away: a scene 40 m wide.
std::unique_ptr<World> wideWorldFrom(const std::string& objects) {
  return worldFrom(objects, "{min: [-20, -20, -20], max: [20, 20, 20]}");
}

SonarModel makeModel(const World& w, double sigma, std::uint64_t seed = 1) {
  SonarModelConfig cfg;
  cfg.range_noise_sigma_m = sigma;
  auto m = SonarModel::create(w, cfg, seed);
  EXPECT_TRUE(m.ok()) << m.error().message;
  return std::move(m).value();
}

TEST(SonarModel, WallAheadGivesTheAnalyticRangePerBeam) {
  // Wall facing the vehicle at x = 4 (normal along x). The fan is vertical, so beam i at azimuth a
  // meets it at 4 / cos(a) on its centre sub-ray, the nearest of the beam's sub-rays.
  const auto w = wideWorldFrom("  - {type: plane, pose: {xyz: [4, 0, 0], rpy_deg: [0, 90, 0]}, size: [20, 20]}\n");
  SonarModel m = makeModel(*w, 0.0);
  const SonarPing p = m.ping(geometry::Pose3::Identity(), 123, false);
  EXPECT_EQ(p.scan.stamp_ns, 123);
  ASSERT_EQ(p.scan.range_m.size(), 96u);
  for (int i = 0; i < 96; ++i) {
    const double a = m.config().fan.beamAzimuth(i);
    EXPECT_NEAR(static_cast<double>(p.scan.range_m[static_cast<std::size_t>(i)]), 4.0 / std::cos(a), 1e-4) << i;
  }
  // The fan is vertical: beam 0 and beam 95 leave at -14.35 / +14.35 deg of elevation.
  const Eigen::Vector3d d0 = m.config().fan.T_vehicle_sensor.linear() * m.subRayDirection(0, 2);
  EXPECT_NEAR(std::asin(std::abs(d0.z())), m.config().fan.fov_rad * 95.0 / 192.0, 1e-9);
  EXPECT_NEAR(d0.y(), 0.0, 1e-12);
}

TEST(SonarModel, BeamRangeIsTheMinimumOverItsSubRays) {
  // A wall turned 40 deg about the vertical: the sub-rays of a beam (spread across the 1 deg beam
  // thickness, which is horizontal once mounted) meet it at different ranges.
  const auto w = wideWorldFrom("  - {type: plane, pose: {xyz: [5, 0, 0], rpy_deg: [0, 90, 40]}, size: [30, 30]}\n");
  SonarModel m = makeModel(*w, 0.0);
  const geometry::Pose3 T = geometry::poseFromXyzRpy(0.3, -0.2, 0.1, 0, 0, 0.2);
  const SonarPing p = m.ping(T, 0, false);
  const geometry::Pose3 T_ws = T * m.config().fan.T_vehicle_sensor;
  const geometry::Pose3 T_wall = geometry::poseFromXyzRpy(5, 0, 0, 0, geometry::deg2rad(90), geometry::deg2rad(40));
  const Eigen::Vector3d n = T_wall.linear().col(2);
  int spread_beams = 0;
  for (int i = 0; i < 96; ++i) {
    double lo = 1e9, hi = 0;
    for (int k = 0; k < 5; ++k) {
      const Eigen::Vector3d d = T_ws.linear() * m.subRayDirection(i, k);
      const double t = n.dot(T_wall.translation() - T_ws.translation()) / n.dot(d);
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
    EXPECT_NEAR(static_cast<double>(p.scan.range_m[static_cast<std::size_t>(i)]), lo, 1e-4) << i;
    if (hi - lo > 1e-3) ++spread_beams;
  }
  EXPECT_EQ(spread_beams, 96);  // the choice matters on every beam here
}

TEST(SonarModel, NoReturnBeyondMaxRangeAndNoiseHasTheConfiguredSigma) {
  const auto far = wideWorldFrom("  - {type: plane, pose: {xyz: [11.5, 0, 0], rpy_deg: [0, 90, 0]}, size: [20, 20]}\n");
  SonarModel mf = makeModel(*far, 0.0);
  for (const float r : mf.ping(geometry::Pose3::Identity(), 0, false).scan.range_m)
    EXPECT_EQ(r, geometry::RangeScan::kNoReturn);

  const auto w = wideWorldFrom("  - {type: plane, pose: {xyz: [4, 0, 0], rpy_deg: [0, 90, 0]}, size: [20, 20]}\n");
  SonarModel m = makeModel(*w, 0.01, 42);
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int k = 0; k < 200; ++k) {
    const SonarPing p = m.ping(geometry::Pose3::Identity(), k, false);
    for (int i = 0; i < 96; ++i) {
      const double e = static_cast<double>(p.scan.range_m[static_cast<std::size_t>(i)]) -
                       4.0 / std::cos(m.config().fan.beamAzimuth(i));
      sum += e;
      sum2 += e * e;
      ++n;
    }
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.0005);  // 5 standard errors of the mean (0.01 / sqrt(19200))
  EXPECT_NEAR(sd, 0.01, 0.0005);
}

TEST(SonarModel, DeterministicPerSeed) {
  const auto w = wideWorldFrom(
      "  - {type: cylinder, pose: {xyz: [3, 0, 0]}, radius: 0.5, length: 4}\n"
      "  - {type: plane, pose: {xyz: [0, 0, -3]}, size: [30, 30]}\n");
  SonarModel a = makeModel(*w, 0.01, 5), b = makeModel(*w, 0.01, 5), c = makeModel(*w, 0.01, 6);
  const geometry::Pose3 T = geometry::poseFromXyzRpy(0, 0, 0, 0, 0, 0.1);
  for (int k = 0; k < 3; ++k) {
    const SonarPing pa = a.ping(T, k, true), pb = b.ping(T, k, true), pc = c.ping(T, k, true);
    EXPECT_EQ(pa.scan.range_m, pb.scan.range_m);
    EXPECT_EQ(pa.frame.samples, pb.frame.samples);
    EXPECT_NE(pa.scan.range_m, pc.scan.range_m);
    EXPECT_NE(pa.frame.samples, pc.frame.samples);
  }
}

TEST(SonarModel, FrameLayoutPutsTheEchoAtTheRangeSample) {
  // The top beams pass over the piling's top into open water: no return.
  const auto w = wideWorldFrom(
      "  - {type: cylinder, pose: {xyz: [3, 0, -1.5]}, radius: 0.5, length: 2}\n"
      "  - {type: plane, pose: {xyz: [0, 0, -4]}, size: [30, 30]}\n");
  SonarModel m = makeModel(*w, 0.01, 3);
  const geometry::Pose3 T = geometry::poseFromXyzRpy(0, 0, 0, 0, 0, 0.05);
  const SonarPing p = m.ping(T, 77, true, 9);
  const sonar::SonarFrame& f = p.frame;
  EXPECT_EQ(f.stamp_ns, 77);
  EXPECT_EQ(f.frame_index, 9u);
  ASSERT_EQ(f.n_beams, 96);
  ASSERT_EQ(f.n_samples, m.config().frame_samples);
  ASSERT_EQ(f.samples.size(), 96u * static_cast<std::size_t>(f.n_samples));
  EXPECT_DOUBLE_EQ(f.window_start_m, m.config().fan.min_range_m);
  EXPECT_DOUBLE_EQ(f.window_start_m + f.window_length_m, m.config().fan.max_range_m);
  const double ds = f.sampleLength_m();
  int with_return = 0, without = 0;
  for (int b = 0; b < 96; ++b) {
    const double r = static_cast<double>(p.scan.range_m[static_cast<std::size_t>(b)]);
    if (!std::isfinite(r)) {
      ++without;
      for (int s = 0; s < f.n_samples; ++s) {
        EXPECT_LT(f.at(b, s), 70) << b << " " << s;
      }
      continue;
    }
    ++with_return;
    for (int s = 0; s < f.n_samples; ++s) {
      const double c = f.rangeOfSample_m(s);
      if (c < r - 0.5 * ds) {
        EXPECT_LT(f.at(b, s), 70) << "echo before the range, beam " << b;
      }
      // Samples fully inside the first echo's pulse are bright.
      if (c >= r + 0.5 * ds && c <= r + m.config().pulse_length_m - 0.5 * ds) {
        EXPECT_GT(f.at(b, s), 60) << "beam " << b;
      }
    }
  }
  EXPECT_GT(with_return, 15);
  EXPECT_GT(without, 0);
}

TEST(SonarModel, BadConfigIsRejected) {
  const auto w = wideWorldFrom("  []\n");
  SonarModelConfig cfg;
  cfg.sub_rays_per_beam = 0;
  auto m = SonarModel::create(*w, cfg, 1);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("sonar.sub_rays_per_beam"), std::string::npos);
  cfg = SonarModelConfig{};
  cfg.fan.max_range_m = 0.1;
  EXPECT_FALSE(SonarModel::create(*w, cfg, 1).ok());
  cfg = SonarModelConfig{};
  cfg.range_noise_sigma_m = -1;
  EXPECT_FALSE(SonarModel::create(*w, cfg, 1).ok());
}

}  // namespace
}  // namespace vog::sim
