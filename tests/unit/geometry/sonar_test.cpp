#include "vog/geometry/sonar.hpp"

#include <gtest/gtest.h>

namespace vog::geometry {
namespace {

TEST(SonarFan, DefaultsAreTheThesisSonar) {
  const SonarFan fan;
  EXPECT_TRUE(fan.validate().ok());
  EXPECT_EQ(fan.n_beams, 96);
  EXPECT_NEAR(rad2deg(fan.fov_rad), 29.0, 1e-12);
}

TEST(SonarFan, BeamsSpanTheFieldOfViewSymmetrically) {
  const SonarFan fan;
  EXPECT_NEAR(fan.beamAzimuth(0), -fan.beamAzimuth(fan.n_beams - 1), 1e-12);
  EXPECT_NEAR(fan.beamAzimuth(fan.n_beams - 1) - fan.beamAzimuth(0), fan.fov_rad * 95.0 / 96.0, 1e-12);
  for (int i = 0; i < fan.n_beams; ++i) EXPECT_NEAR(fan.beamDirection(i).norm(), 1.0, 1e-12);
}

TEST(SonarFan, MountedRolledTheFanIsVertical) {
  const SonarFan fan;
  // In the vehicle frame every beam lies in the x-z plane.
  for (int i = 0; i < fan.n_beams; ++i) {
    const Eigen::Vector3d d = fan.T_vehicle_sensor.linear() * fan.beamDirection(i);
    EXPECT_NEAR(d.y(), 0.0, 1e-12);
  }
}

TEST(SonarFan, ValidateNamesTheBadField) {
  SonarFan fan;
  fan.n_beams = 0;
  auto s = fan.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("n_beams"), std::string::npos);
  fan = SonarFan{};
  fan.max_range_m = fan.min_range_m;
  s = fan.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("max_range_m"), std::string::npos);
}

}  // namespace
}  // namespace vog::geometry
