// Resume equivalence: a MappingPipeline persisted through MissionStore, "crashed" after N
// submaps (objects dropped, together with the active submap's scans), reopened, restored and fed the
// scans from the first one after the last closed submap ends bit-identical to a pipeline that never
// stopped: same graph estimates, VogMap poses, submap records and loop closures. The restored pipeline
// right after the crash equals the crashed one; a second reopen of the finished mission restores the
// final state; MappingPipeline::restore refuses inconsistent state.
#include "../slam/pipeline_fixture.hpp"
#include "journal_fixture.hpp"
#include "test_support.hpp"
#include "vog/mission/mission_store.hpp"
#include "vog/slam/mapping_pipeline.hpp"

#include <gtest/gtest.h>

namespace vog::mission {
namespace {

using slam::MappingPipeline;
using slam::MappingPipelineConfig;
using testing::bitEqual;

// The drifting orbit of the slam pipeline test, about three laps (loop closures start on the second).
constexpr int kScans = 1100;
constexpr int kStride = 2;
constexpr double kCovXy = 0.0003;
constexpr double kYawBias = geometry::deg2rad(0.02);
constexpr std::size_t kLostScans = 17;  // scans of the active submap fed before the crash

MappingPipelineConfig pipelineConfig() {
  MappingPipelineConfig c;
  c.builder.grid.resolution_m = 0.1;
  c.builder.max_scans = 40;
  c.builder.odometry_cov_x_m2_per_s = kCovXy;
  c.builder.odometry_cov_y_m2_per_s = kCovXy;
  c.builder.odometry_cov_yaw_rad2_per_s = 1e-5;
  c.loop_closer.mode = slam::LoopClosureMode::kDegenerate;
  c.loop_closer.p2p.max_correspondence_distance_m = 0.5;
  c.loop_closer.point_to_plane.max_correspondence_distance_m = 0.5;
  // The normals check makes the registrations depend on which way the restored clouds' normals point.
  c.loop_closer.point_to_plane.max_normal_angle_rad = geometry::deg2rad(45.0);
  return c;
}

const slam::testing::Run& sharedRun() {
  static const slam::testing::Run run = slam::testing::makeRun(kScans, kStride, kCovXy, kYawBias, 42);
  return run;
}

void expectSamePipelines(const MappingPipeline& a, const MappingPipeline& b) {
  ASSERT_EQ(a.graph().nodeIds(), b.graph().nodeIds());
  ASSERT_EQ(a.graph().numFactors(), b.graph().numFactors());
  for (slam::NodeId id : a.graph().nodeIds()) {
    EXPECT_TRUE(bitEqual(a.graph().estimate(id).value(), b.graph().estimate(id).value())) << "node " << id;
  }
  const auto ea = a.map().entries();
  const auto eb = b.map().entries();
  ASSERT_EQ(ea.size(), eb.size());
  for (std::size_t k = 0; k < ea.size(); ++k) {
    EXPECT_EQ(ea[k].id, eb[k].id);
    EXPECT_TRUE(bitEqual(ea[k].T_world_submap.matrix(), eb[k].T_world_submap.matrix())) << "map entry " << k;
    EXPECT_TRUE(bitEqual(ea[k].T_submap_world.matrix(), eb[k].T_submap_world.matrix())) << "map entry " << k;
  }
  ASSERT_EQ(a.submaps().size(), b.submaps().size());
  for (std::size_t k = 0; k < a.submaps().size(); ++k) {
    const slam::SubmapRecord& ra = a.submaps()[k];
    const slam::SubmapRecord& rb = b.submaps()[k];
    EXPECT_EQ(ra.index, rb.index);
    EXPECT_EQ(ra.first_stamp_ns, rb.first_stamp_ns);
    EXPECT_EQ(ra.last_stamp_ns, rb.last_stamp_ns);
    EXPECT_EQ(ra.n_scans, rb.n_scans);
    EXPECT_EQ(ra.reason, rb.reason);
    EXPECT_TRUE(bitEqual(ra.T_world_base_odom.matrix(), rb.T_world_base_odom.matrix())) << "submap " << k;
    EXPECT_TRUE(bitEqual(ra.T_world_base.matrix(), rb.T_world_base.matrix())) << "submap " << k;
  }
  ASSERT_EQ(a.closures().size(), b.closures().size());
  for (std::size_t k = 0; k < a.closures().size(); ++k) {
    const slam::LoopClosure& ca = a.closures()[k];
    const slam::LoopClosure& cb = b.closures()[k];
    EXPECT_EQ(ca.from, cb.from);
    EXPECT_EQ(ca.to, cb.to);
    EXPECT_TRUE(bitEqual(ca.T_from_to.matrix(), cb.T_from_to.matrix())) << "closure " << k;
    EXPECT_TRUE(bitEqual(ca.factor.V_u, cb.factor.V_u)) << "closure " << k;
    EXPECT_TRUE(bitEqual(ca.factor.measurement, cb.factor.measurement)) << "closure " << k;
    EXPECT_TRUE(bitEqual(ca.factor.covariance, cb.factor.covariance)) << "closure " << k;
  }
}

TEST(MissionResume, RestoredPipelineContinuesBitIdenticallyToAnUninterruptedOne) {
  const auto& run = sharedRun();
  const MappingPipelineConfig config = pipelineConfig();

  // The reference: never stopped.
  auto reference = MappingPipeline::create(config);
  ASSERT_TRUE(reference.ok());
  for (const auto& in : run.inputs) ASSERT_TRUE(reference.value()->feed(in).ok());
  ASSERT_TRUE(reference.value()->finish().ok());
  // Crash two submaps after the first loop closure, so that closures are persisted before the crash
  // and found after the resume.
  ASSERT_FALSE(reference.value()->closures().empty()) << "the run must close loops";
  const auto crash_after_submaps = static_cast<std::size_t>(reference.value()->closures().front().to + 2);
  ASSERT_GT(reference.value()->closures().back().to, static_cast<std::int64_t>(crash_after_submaps))
      << "the run must close loops after the crash point too";

  test::TempDir dir;
  const auto mission = dir.path() / "mission";
  std::size_t resume_scan = 0;  // the first scan of the submap that was active at the crash
  std::size_t closures_before_crash = 0;
  std::unique_ptr<MappingPipeline> crashed_copy;
  {
    auto store = MissionStore::open(mission, config.builder.grid);
    ASSERT_TRUE(store.ok()) << store.error().message;
    ASSERT_TRUE(store.value()->onState({0, MissionState::kExploring}).ok());
    auto pipeline = MappingPipeline::create(config);
    ASSERT_TRUE(pipeline.ok());
    std::size_t k = 0;
    for (; k < run.inputs.size(); ++k) {
      auto u = pipeline.value()->feed(run.inputs[k]);
      ASSERT_TRUE(u.ok()) << u.error().message;
      ASSERT_TRUE(store.value()->onUpdate(*pipeline.value(), u.value()).ok());
      if (k % 10 == 0) {
        const Eigen::Vector3d t = run.inputs[k].T_world_vehicle_odom.translation();
        ASSERT_TRUE(store.value()->onWaypoint({run.inputs[k].scan.stamp_ns, t.x(), t.y(), t.z(), 0.25}).ok());
      }
      if (pipeline.value()->submaps().size() == crash_after_submaps) break;
    }
    ASSERT_LT(k + kLostScans, run.inputs.size());
    resume_scan = k;  // the scan that closed the last submap started the active one
    for (std::size_t j = 1; j <= kLostScans; ++j) ASSERT_TRUE(pipeline.value()->feed(run.inputs[k + j]).ok());
    closures_before_crash = pipeline.value()->closures().size();
    // What restore() must reproduce: the crashed pipeline's closed part. (Its active submap is lost.)
    crashed_copy = std::move(pipeline.value());
  }  // crash: the store and the pipeline are gone without any shutdown step
  ASSERT_GT(closures_before_crash, 0U) << "the crash should come after some loop closures";

  MissionResume resume;
  auto store = MissionStore::open(mission, config.builder.grid, &resume);
  ASSERT_TRUE(store.ok()) << store.error().message;
  ASSERT_EQ(resume.pipeline.submaps.size(), crash_after_submaps);
  ASSERT_TRUE(resume.state.has_value());
  EXPECT_EQ(resume.state->state, MissionState::kExploring);
  ASSERT_TRUE(resume.waypoint.has_value());
  auto restored = MappingPipeline::restore(config, resume.pipeline);
  ASSERT_TRUE(restored.ok()) << restored.error().message;
  expectSamePipelines(*crashed_copy, *restored.value());
  crashed_copy.reset();

  // The resumed run: from the first scan after the last closed submap to the end, still persisted.
  for (std::size_t k = resume_scan; k < run.inputs.size(); ++k) {
    auto u = restored.value()->feed(run.inputs[k]);
    ASSERT_TRUE(u.ok()) << u.error().message;
    ASSERT_TRUE(store.value()->onUpdate(*restored.value(), u.value()).ok());
  }
  auto last = restored.value()->finish();
  ASSERT_TRUE(last.ok());
  ASSERT_TRUE(store.value()->onUpdate(*restored.value(), last.value()).ok());
  EXPECT_GT(restored.value()->closures().size(), closures_before_crash) << "closures after the resume too";
  expectSamePipelines(*reference.value(), *restored.value());

  // The finished mission reopens into the final state.
  store.value().reset();
  MissionResume final_state;
  ASSERT_TRUE(MissionStore::open(mission, config.builder.grid, &final_state).ok());
  auto again = MappingPipeline::restore(config, final_state.pipeline);
  ASSERT_TRUE(again.ok()) << again.error().message;
  expectSamePipelines(*reference.value(), *again.value());
}

TEST(MissionResume, RestoreRefusesInconsistentState) {
  const auto& run = sharedRun();
  const MappingPipelineConfig config = pipelineConfig();
  test::TempDir dir;
  auto store = MissionStore::open(dir.path() / "m", config.builder.grid);
  ASSERT_TRUE(store.ok());
  auto pipeline = MappingPipeline::create(config);
  ASSERT_TRUE(pipeline.ok());
  for (std::size_t k = 0; k < 130; ++k) {
    auto u = pipeline.value()->feed(run.inputs[k]);
    ASSERT_TRUE(u.ok());
    ASSERT_TRUE(store.value()->onUpdate(*pipeline.value(), u.value()).ok());
  }
  store.value().reset();
  MissionResume resume;
  ASSERT_TRUE(MissionStore::open(dir.path() / "m", config.builder.grid, &resume).ok());
  ASSERT_GE(resume.pipeline.submaps.size(), 3U);
  ASSERT_TRUE(MappingPipeline::restore(config, resume.pipeline).ok());

  auto expectError = [&](slam::PipelineState state, const std::string& needle) {
    auto r = MappingPipeline::restore(config, state);
    ASSERT_FALSE(r.ok()) << needle;
    EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
  };
  {
    auto s = resume.pipeline;
    s.submaps.erase(s.submaps.begin() + 1);
    s.estimates.erase(s.estimates.begin() + 1);
    expectError(s, "has index 2");
  }
  {
    auto s = resume.pipeline;
    s.estimates.pop_back();
    expectError(s, "estimates");
  }
  {
    auto s = resume.pipeline;
    s.estimates[1](0) = std::numeric_limits<double>::quiet_NaN();
    expectError(s, "not finite");
  }
  {
    auto s = resume.pipeline;
    slam::LoopClosure lc;
    lc.from = 0;
    lc.to = 7;
    s.closures.push_back(lc);
    expectError(s, "unknown submap");
  }
  {
    auto s = resume.pipeline;
    s.submaps[1].grid.reset();
    expectError(s, "no finalized grid");
  }
}

}  // namespace
}  // namespace vog::mission
