// The sonar driver's range extraction (drivers/sonar) run on simulated intensity frames must
// recover the simulated ranges: the two sides agree on the frame layout and on what a return is.

#include "vog/sim/sonar_model.hpp"
#include "vog/sonar/range_extraction.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace vog::sim {
namespace {

TEST(SonarExtraction, RecoversSimulatedRangesOnThePilingsScene) {
  auto scene = loadScene(vog::test::sourceDir() / "config" / "scenes" / "pilings.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto world = World::create(*scene);
  ASSERT_TRUE(world.ok()) << world.error().message;
  SonarModelConfig cfg;
  auto model = SonarModel::create(**world, cfg, 21);
  ASSERT_TRUE(model.ok());
  sonar::RangeExtractionConfig ex;
  ex.min_range_m = cfg.fan.min_range_m;
  ex.max_range_m = cfg.fan.max_range_m;

  int hits = 0, misses = 0, bad = 0;
  double worst = 0.0;
  // Turn in place at a few spots: pilings near and far, seabed, open water.
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(-5, 0, -1.5), Eigen::Vector3d(0, -1, -3.0), Eigen::Vector3d(4.5, 3, -0.8)}) {
    for (int k = 0; k < 24; ++k) {
      const geometry::Pose3 T = geometry::poseFromXyzRpy(p.x(), p.y(), p.z(), 0, 0, k * M_PI / 12);
      const SonarPing ping = model->ping(T, k, true);
      auto scan = sonar::extractRanges(ping.frame, ex);
      ASSERT_TRUE(scan.ok()) << scan.error().message;
      const double ds = ping.frame.sampleLength_m();
      for (std::size_t b = 0; b < 96; ++b) {
        const float truth = ping.scan.range_m[b];
        const float got = scan->range_m[b];
        if (!std::isfinite(truth)) {
          ++misses;
          if (std::isfinite(got)) ++bad;
          continue;
        }
        ++hits;
        if (!std::isfinite(got)) {
          ++bad;
          continue;
        }
        const double err = std::abs(static_cast<double>(got) - static_cast<double>(truth));
        worst = std::max(worst, err);
        // The leading edge lands in the sample that contains the range or the next one.
        if (err > 1.0 * ds + 1e-6) ++bad;
      }
    }
  }
  EXPECT_GT(hits, 1000);
  EXPECT_GT(misses, 500);
  EXPECT_EQ(bad, 0) << "worst error " << worst << " m";
}

}  // namespace
}  // namespace vog::sim
