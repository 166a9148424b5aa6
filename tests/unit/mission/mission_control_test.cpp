// The mission lifecycle: every allowed transition, every refusal named, events that race
// with operator commands ignored.
#include "vog/mission/mission_control.hpp"

#include <gtest/gtest.h>

namespace vog::mission {
namespace {

const Box kBox{Eigen::Vector3d(-5, -5, -4), Eigen::Vector3d(5, 5, 0)};

TEST(MissionControl, FullLifecycle) {
  MissionControl m(kBox);
  EXPECT_EQ(m.state(), MissionState::kIdle);
  EXPECT_FALSE(m.active());
  EXPECT_EQ(m.command(MissionCommandKind::kStart).value(), MissionState::kExploring);
  EXPECT_TRUE(m.active());
  EXPECT_EQ(m.command(MissionCommandKind::kPause).value(), MissionState::kPaused);
  EXPECT_FALSE(m.active());
  EXPECT_EQ(m.command(MissionCommandKind::kResume).value(), MissionState::kExploring);
  EXPECT_EQ(m.event(MissionEvent::kExplorationDone), MissionState::kReturning);
  EXPECT_EQ(m.command(MissionCommandKind::kPause).value(), MissionState::kPaused);
  EXPECT_EQ(m.command(MissionCommandKind::kResume).value(), MissionState::kReturning);  // back to where it was
  EXPECT_EQ(m.event(MissionEvent::kArrivedHome), MissionState::kComplete);
  // A new exploration on the same map.
  EXPECT_EQ(m.command(MissionCommandKind::kStart).value(), MissionState::kExploring);
}

TEST(MissionControl, ArrivingNearHomeEndsTheMissionInItsOwnState) {
  MissionControl m(kBox, MissionState::kExploring);
  EXPECT_EQ(m.event(MissionEvent::kArrivedNearHome), MissionState::kExploring);  // not returning: ignored
  EXPECT_EQ(m.event(MissionEvent::kExplorationDone), MissionState::kReturning);
  EXPECT_EQ(m.event(MissionEvent::kArrivedNearHome), MissionState::kNearHome);
  EXPECT_FALSE(m.active());
  EXPECT_TRUE(m.ended());
  EXPECT_FALSE(m.command(MissionCommandKind::kAbort).ok());  // an end, like complete
  EXPECT_FALSE(m.command(MissionCommandKind::kPause).ok());
  EXPECT_EQ(m.command(MissionCommandKind::kStart).value(), MissionState::kExploring);  // a new exploration
}

TEST(MissionControl, RefusalsNameTheCommandAndState) {
  MissionControl no_box;
  auto r = no_box.command(MissionCommandKind::kStart);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "start refused while idle: no exploration box is set");
  EXPECT_EQ(no_box.command(MissionCommandKind::kSetBox, kBox).value(), MissionState::kIdle);
  EXPECT_EQ(no_box.command(MissionCommandKind::kStart).value(), MissionState::kExploring);

  MissionControl m(kBox, MissionState::kExploring);
  EXPECT_EQ(m.command(MissionCommandKind::kStart).error().message, "start refused while exploring");
  EXPECT_EQ(m.command(MissionCommandKind::kResume).error().message, "resume refused while exploring");
  EXPECT_EQ(m.command(MissionCommandKind::kSetBox, kBox).error().message,
            "set box refused while exploring: abort first, or set it once the mission has ended");
  // Paused, the exploration still holds its box: a new one would be explored by nobody.
  EXPECT_EQ(m.command(MissionCommandKind::kPause).value(), MissionState::kPaused);
  EXPECT_EQ(m.command(MissionCommandKind::kSetBox, kBox).error().message,
            "set box refused while paused: abort first, or set it once the mission has ended");
  EXPECT_EQ(m.command(MissionCommandKind::kResume).value(), MissionState::kExploring);
  EXPECT_FALSE(m.command(MissionCommandKind::kSetBox).ok());  // no box given
  EXPECT_EQ(m.command(MissionCommandKind::kAbort).value(), MissionState::kAborted);
  EXPECT_EQ(m.reason(), "aborted by the operator");
  EXPECT_EQ(m.command(MissionCommandKind::kAbort).error().message, "abort refused while aborted");
  EXPECT_EQ(m.command(MissionCommandKind::kPause).error().message, "pause refused while aborted");
  EXPECT_EQ(m.command(MissionCommandKind::kReturnHome).error().message, "return home refused while aborted");
  EXPECT_EQ(m.state(), MissionState::kAborted);  // refusals change nothing
}

TEST(MissionControl, ReturnHomeFromExploringOrPaused) {
  MissionControl a(kBox, MissionState::kExploring);
  EXPECT_EQ(a.command(MissionCommandKind::kReturnHome).value(), MissionState::kReturning);
  MissionControl b(kBox, MissionState::kPaused);
  EXPECT_EQ(b.command(MissionCommandKind::kReturnHome).value(), MissionState::kReturning);
  MissionControl c(kBox, MissionState::kIdle);
  EXPECT_FALSE(c.command(MissionCommandKind::kReturnHome).ok());
}

TEST(MissionControl, EventsThatRaceWithCommandsAreIgnored) {
  MissionControl m(kBox, MissionState::kExploring);
  ASSERT_TRUE(m.command(MissionCommandKind::kPause).ok());
  EXPECT_EQ(m.event(MissionEvent::kExplorationDone), MissionState::kPaused);
  EXPECT_EQ(m.event(MissionEvent::kNoPath), MissionState::kPaused);
  EXPECT_EQ(m.event(MissionEvent::kArrivedHome), MissionState::kPaused);
  ASSERT_TRUE(m.command(MissionCommandKind::kResume).ok());
  EXPECT_EQ(m.event(MissionEvent::kArrivedHome), MissionState::kExploring);  // not returning: ignored
  EXPECT_EQ(m.event(MissionEvent::kNoPath), MissionState::kAborted);
  EXPECT_EQ(m.reason(), "no collision-free path");
}

TEST(MissionControl, BoxContainment) {
  EXPECT_TRUE(kBox.contains(Eigen::Vector3d(0, 0, -1)));
  EXPECT_TRUE(kBox.contains(Eigen::Vector3d(5, -5, 0)));
  EXPECT_FALSE(kBox.contains(Eigen::Vector3d(0, 0, 0.1)));
}

}  // namespace
}  // namespace vog::mission
