// Dead reckoning against simulator ground truth: the vehicle model
// drives a lawnmower survey through the pilings scene; the navigation sensor models are sampled at
// their configured rates; every sample goes to the wire through the codec encoders (PD0 ensemble
// with bottom track in instrument coordinates, IMU CAN frames, Digiquartz reply line), comes back
// through the stream decoders, and feeds nav::DeadReckoning. The errors against the truth must stay
// within the drift the sensor noise model predicts.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "test_support.hpp"
#include "vog/core/bytes.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/depth/digiquartz.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/vehicle/sim_wire.hpp"
#include "vog/nav/dead_reckoning.hpp"
#include "vog/sim/nav_model.hpp"
#include "vog/sim/paths.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/vehicle.hpp"
#include "vog/sim/world.hpp"

namespace vog::nav {
namespace {

constexpr std::int64_t kStepNs = 10'000'000;            // simulator step = IMU period at 100 Hz
constexpr std::int64_t kCheckpointNs = 10'000'000'000;  // every 10 s of simulated time
constexpr std::int64_t kMaxDurationNs = 600'000'000'000;
constexpr double kSigmas = 4.0;  // k of the k-sigma bounds

// Wire resolutions (they add to the sensor noise): PD0 velocities are i16 mm/s (RDI PD0 bottom
// track), IMU attitude i16 1e-4 rad (drivers/imu/README.md); rounding to a step q is uniform
// noise of variance q^2 / 12.
constexpr double kPd0VelocityStep_mps = 1e-3;
constexpr double kImuAttitudeStep_rad = 1e-4;
double roundingVariance(double step) { return step * step / 12.0; }

struct Checkpoint {
  std::int64_t stamp_ns = 0;
  Eigen::Vector2d error_xy_m = Eigen::Vector2d::Zero();  // dead reckoning minus truth
  double predicted_sigma_m = 0.0;                        // sqrt(E|e|^2) of the 2-D error from the noise model
  double sampling_error_m = 0.0;                         // deterministic error of integrating 5 Hz samples (see below)
  double z_error_m = 0.0;
  double roll_rad = 0.0;  // the truth has no roll or pitch (sim/vehicle.hpp)
  double pitch_rad = 0.0;
  double yaw_error_rad = 0.0;
  double yaw_sigma_rad = 0.0;  // predicted 1-sigma of the IMU heading error at this time
  NavSolution solution;
};

struct SimRun {
  std::vector<Checkpoint> checkpoints;
  std::uint64_t dvl_sent = 0;
  std::uint64_t imu_sent = 0;
  std::uint64_t depth_sent = 0;
  std::uint64_t frames_dropped = 0;  // by any of the three stream decoders
  int waypoints_skipped = 0;
  bool path_completed = false;  // every waypoint reached before the time limit
  double distance_m = 0.0;
  NavSolution after_dvl_stop;  // 2 s after the last DVL ensemble, IMU and depth still fed
};

// The simulated devices' bytes through the real decoders into dead reckoning. Stamps are the
// simulated receive times (what the transports stamp with). Lifecycle: one per run; every feed
// must yield exactly one decoded message, which must be accepted.
class WireFeed {
 public:
  WireFeed(DeadReckoning& dr, vehicle::SimWireConfig config) : dr_(dr), config_(std::move(config)) {}

  void imu(const sim::ImuSample& s) {
    auto msg = vehicle::toImuSample(s, static_cast<std::uint32_t>(imu_sequence_++ & 0xFFU), config_);
    ASSERT_TRUE(msg.ok()) << msg.error().message;
    auto frames = imu::encodeImuCan(*msg);
    ASSERT_TRUE(frames.ok()) << frames.error().message;
    imu_decoder_.feed(imu::canFramesToBytes(*frames));
    auto decoded = imu_decoder_.next();
    ASSERT_TRUE(decoded.has_value()) << imu_decoder_.stats().last_error;
    ASSERT_FALSE(imu_decoder_.next().has_value());
    decoded->stamp_ns = s.stamp_ns;
    const Status st = dr_.addImu(*decoded);
    ASSERT_TRUE(st.ok()) << st.error().message;
  }

  void depth(const sim::DepthSample& s) {
    auto reading = vehicle::toDigiquartzReading(s, config_);
    ASSERT_TRUE(reading.ok()) << reading.error().message;
    const std::string line = depth::encodePressureReply(0, 1, *reading, config_.depth_decimals);
    depth_decoder_.feed(asBytes(line));
    auto decoded = depth_decoder_.next();
    ASSERT_TRUE(decoded.has_value()) << depth_decoder_.stats().last_error;
    auto sample = depth::toDepthSample(*decoded, config_.depth, s.stamp_ns);
    ASSERT_TRUE(sample.ok()) << sample.error().message;
    const Status st = dr_.addDepth(*sample);
    ASSERT_TRUE(st.ok()) << st.error().message;
  }

  void dvl(const sim::DvlSample& s) {
    auto ensemble = vehicle::toPd0Ensemble(s, ++dvl_ensemble_, config_);
    ASSERT_TRUE(ensemble.ok()) << ensemble.error().message;
    pd0_decoder_.feed(dvl::encodePd0(*ensemble));
    auto decoded = pd0_decoder_.next();
    ASSERT_TRUE(decoded.has_value()) << pd0_decoder_.stats().last_error;
    ASSERT_EQ(decoded->variable.ensemble_number, dvl_ensemble_);
    ASSERT_EQ(decoded->fixed.coordinate_frame, dvl::CoordinateFrame::kInstrument);
    decoded->stamp_ns = s.stamp_ns;
    const Status st = dr_.addDvl(*decoded);
    ASSERT_TRUE(st.ok()) << st.error().message;
  }

  std::uint64_t framesDropped() const {
    return imu_decoder_.stats().badFrames() + imu_decoder_.stats().garbage_bytes + depth_decoder_.stats().badFrames() +
           depth_decoder_.stats().garbage_bytes + pd0_decoder_.stats().badFrames() + pd0_decoder_.stats().garbage_bytes;
  }

 private:
  DeadReckoning& dr_;
  vehicle::SimWireConfig config_;
  std::uint32_t imu_sequence_ = 0;
  std::uint32_t dvl_ensemble_ = 0;
  codec::StreamDecoder<imu::ImuCanCodec> imu_decoder_;
  codec::StreamDecoder<depth::DigiquartzCodec> depth_decoder_;
  codec::StreamDecoder<dvl::Pd0Codec> pd0_decoder_;
};

// Predicted horizontal error of dead reckoning, from the NavSensorConfig (derivation):
//  The 2-D error e(T) is, to first order, the sum of three independent zero-mean parts and one
//  deterministic part.
//  1. DVL white noise: each sample's horizontal components carry N(0, s_v^2) (s_v = dvl_sigma_mps,
//     plus the PD0 mm/s rounding). The trapezoid rule weights a sample by dt (dt/2 at the ends),
//     so E|e|^2 <= 2 s_v^2 sum dt_i^2 (two axes).
//  2. IMU heading white noise s_h (imu_yaw_sigma_rad, plus the 1e-4 rad rounding): the velocity
//     v_i is rotated by an independent heading error, an error of |v_i| s_h across the track:
//     E|e|^2 = s_h^2 sum dt_i^2 |v_i|^2.
//  3. IMU heading drift b(t), a random walk of variance q t (q = imu_yaw_drift_rad2ps). The
//     increment w_j of b at t_j turns all later motion, i.e. the remaining displacement
//     p(T) - p(t_j), by w_j: e = sum_j w_j J (p(T) - p(t_j)), so
//     E|e|^2 = q * integral_0^T |p(T) - p(t)|^2 dt ("heading error times distance travelled",
//     with the distance still to go from where the error arose).
//  4. Sampling: the trapezoid rule over 5 Hz velocities differs from the 100 Hz truth where the
//     vehicle turns or stops at a waypoint. That error is deterministic; it is computed from the
//     true velocities and added to the bound (it is what a noise-free dead reckoning would show).
//  Bound: |e(T)| <= |sampling(T)| + k sqrt(E|e|^2) with k = 4. The 2-D error over sqrt(E|e|^2)
//  exceeds 4 with probability below 1e-4 (one axis carrying all variance) to exp(-16) (isotropic).
//  Roll and pitch rotate the horizontal velocity by second-order amounts only (level vehicle).
class DriftPredictor {
 public:
  explicit DriftPredictor(const sim::NavSensorConfig& c)
      : velocity_var_(c.dvl_sigma_mps * c.dvl_sigma_mps + roundingVariance(kPd0VelocityStep_mps)),
        heading_var_(c.imu_yaw_sigma_rad * c.imu_yaw_sigma_rad + roundingVariance(kImuAttitudeStep_rad)),
        drift_rate_(c.imu_yaw_drift_rad2ps) {}

  // One DVL instant of the truth.
  void add(std::int64_t stamp_ns, const Eigen::Vector2d& p_true, const Eigen::Vector2d& v_true) {
    if (!samples_.empty()) {
      const Sample& prev = samples_.back();
      const double dt = static_cast<double>(stamp_ns - prev.stamp_ns) * 1e-9;
      white_var_ += dt * dt * (2.0 * velocity_var_ + heading_var_ * v_true.squaredNorm());
      trapezoid_m_ += 0.5 * dt * (prev.v + v_true);
    }
    samples_.push_back({stamp_ns, p_true, v_true});
  }

  // sqrt(E|e|^2) at the newest sample.
  double sigma() const {
    const Sample& last = samples_.back();
    double drift = 0.0;
    for (std::size_t j = 1; j < samples_.size(); ++j) {
      const double dt = static_cast<double>(samples_[j].stamp_ns - samples_[j - 1].stamp_ns) * 1e-9;
      drift += dt * (last.p - samples_[j - 1].p).squaredNorm();
    }
    return std::sqrt(white_var_ + drift_rate_ * drift);
  }

  // Trapezoid of the true 5 Hz velocities minus the true displacement.
  double samplingError() const { return (trapezoid_m_ - (samples_.back().p - samples_.front().p)).norm(); }

 private:
  struct Sample {
    std::int64_t stamp_ns;
    Eigen::Vector2d p;
    Eigen::Vector2d v;
  };
  double velocity_var_;
  double heading_var_;
  double drift_rate_;
  double white_var_ = 0.0;
  Eigen::Vector2d trapezoid_m_ = Eigen::Vector2d::Zero();
  std::vector<Sample> samples_;
};

const sim::World& pilingsWorld() {
  static const std::unique_ptr<sim::World> world = [] {
    auto scene = sim::loadScene(test::sourceDir() / "config" / "scenes" / "pilings.yaml");
    EXPECT_TRUE(scene.ok()) << scene.error().message;
    auto w = sim::World::create(*scene);
    EXPECT_TRUE(w.ok()) << w.error().message;
    return std::move(w).value();
  }();
  return *world;
}

// The dead-reckoning configuration a deployment would use for these sensors: the noise figures
// of the sensor specification (here the simulator's), the default DVL mount.
DeadReckoningConfig deadReckoningConfigFor(const sim::NavSensorConfig& sensors) {
  DeadReckoningConfig c;
  c.dvl_velocity_sigma_mps = sensors.dvl_sigma_mps;
  c.heading_sigma_rad = sensors.imu_yaw_sigma_rad;
  c.heading_drift_rad2_per_s = sensors.imu_yaw_drift_rad2ps;
  return c;
}

void runSurvey(std::uint64_t seed, SimRun& out) {
  const sim::World& world = pilingsWorld();
  const sim::Scene& scene = world.scene();
  auto waypoints = sim::lawnmowerPath(scene, sim::PathConfig{});
  ASSERT_TRUE(waypoints.ok()) << waypoints.error().message;
  const Eigen::Vector3d start = scene.T_world_start.translation();
  auto vehicle =
      sim::VehicleModel::create(world, sim::VehicleConfig{}, start, geometry::yawOf(scene.T_world_start.linear()), 0);
  ASSERT_TRUE(vehicle.ok()) << vehicle.error().message;
  ASSERT_TRUE(vehicle->setWaypoints(*waypoints).ok());
  const sim::NavSensorConfig sensors;
  auto nav = sim::NavSensorModel::create(world, sensors, seed);
  ASSERT_TRUE(nav.ok()) << nav.error().message;

  DeadReckoning dr(deadReckoningConfigFor(sensors));
  ASSERT_TRUE(deadReckoningConfigFor(sensors).validate().ok());
  dr.resetPosition(start.x(), start.y());  // a surface fix at the start
  WireFeed feed(dr, vehicle::SimWireConfig{});
  DriftPredictor predictor(sensors);

  const auto period = [](double hz) { return static_cast<std::int64_t>(std::llround(1e9 / hz)); };
  const std::int64_t imu_ns = period(sensors.imu_rate_hz), dvl_ns = period(sensors.dvl_rate_hz);
  const std::int64_t depth_ns = period(sensors.depth_rate_hz);
  std::int64_t next_imu = 0, next_dvl = 0, next_depth = 0, next_checkpoint = kCheckpointNs;

  bool surveying = true;
  std::int64_t stop_ns = 0;
  while (true) {
    const sim::VehicleState& s = vehicle->state();
    if (s.stamp_ns >= next_imu) {
      ASSERT_NO_FATAL_FAILURE(feed.imu(nav->imu(s)));
      ++out.imu_sent;
      next_imu += imu_ns;
    }
    if (s.stamp_ns >= next_depth) {
      ASSERT_NO_FATAL_FAILURE(feed.depth(nav->depth(s)));
      ++out.depth_sent;
      next_depth += depth_ns;
    }
    // The path is done (or the time is up): one last DVL ensemble and checkpoint, then no DVL.
    const bool path_done = vehicle->waypointsLeft() == 0 || s.stamp_ns >= kMaxDurationNs;
    if (surveying && s.stamp_ns >= next_dvl) {
      const sim::DvlSample d = nav->dvl(s);
      ASSERT_TRUE(d.bottom_lock) << "no bottom within " << sensors.dvl_max_altitude_m << " m at t = " << s.stamp_ns;
      ASSERT_NO_FATAL_FAILURE(feed.dvl(d));
      ++out.dvl_sent;
      next_dvl += dvl_ns;
      predictor.add(s.stamp_ns, s.xyz_world.head<2>(), s.velocity_world_mps.head<2>());
      if (s.stamp_ns >= next_checkpoint || path_done) {
        Checkpoint c;
        c.stamp_ns = s.stamp_ns;
        c.solution = dr.solution(s.stamp_ns);
        const geometry::Pose3& T = c.solution.T_world_vehicle;
        c.error_xy_m = T.translation().head<2>() - s.xyz_world.head<2>();
        c.predicted_sigma_m = predictor.sigma();
        c.sampling_error_m = predictor.samplingError();
        c.z_error_m = T.translation().z() - s.xyz_world.z();
        const Eigen::Vector3d rpy = geometry::rpyFromRotation(T.linear());
        c.roll_rad = rpy.x();
        c.pitch_rad = rpy.y();
        c.yaw_error_rad = geometry::wrapAngle(rpy.z() - s.yaw_rad);
        const double t_s = static_cast<double>(s.stamp_ns) * 1e-9;
        c.yaw_sigma_rad = std::sqrt(sensors.imu_yaw_sigma_rad * sensors.imu_yaw_sigma_rad +
                                    roundingVariance(kImuAttitudeStep_rad) + sensors.imu_yaw_drift_rad2ps * t_s);
        out.checkpoints.push_back(c);
        next_checkpoint += kCheckpointNs;
      }
      if (path_done) {
        // Survey over: stop feeding the DVL, keep the IMU and depth sensor going for 2 s.
        surveying = false;
        stop_ns = s.stamp_ns;
        out.path_completed = vehicle->waypointsLeft() == 0;
      }
    }
    if (!surveying && s.stamp_ns >= stop_ns + 2'000'000'000) {
      out.after_dvl_stop = dr.solution(s.stamp_ns);
      break;
    }
    const Eigen::Vector3d before = s.xyz_world;
    const sim::StepResult r = vehicle->step(kStepNs);
    out.distance_m += (vehicle->state().xyz_world - before).norm();
    if (r.status == sim::MotionStatus::kBlocked) {
      vehicle->skipWaypoint();
      ++out.waypoints_skipped;
    }
  }
  out.frames_dropped = feed.framesDropped();
}

TEST(DeadReckoningSimTest, LawnmowerSurveyStaysWithinTheDriftTheNoiseModelPredicts) {
  SimRun run;
  ASSERT_NO_FATAL_FAILURE(runSurvey(7, run));
  const sim::NavSensorConfig sensors;
  // A survey of a few minutes through the real wire formats, nothing lost on the way.
  ASSERT_GE(run.checkpoints.size(), 15u);
  EXPECT_GT(run.distance_m, 40.0);
  EXPECT_EQ(run.frames_dropped, 0u);
  EXPECT_EQ(run.waypoints_skipped, 0);
  EXPECT_TRUE(run.path_completed);

  const double depth_sigma_m = sensors.depth_noise_fraction * sensors.depth_full_scale_m;
  const double attitude_sigma_rad = std::sqrt(sensors.imu_roll_pitch_sigma_rad * sensors.imu_roll_pitch_sigma_rad +
                                              roundingVariance(kImuAttitudeStep_rad));
  for (const Checkpoint& c : run.checkpoints) {
    SCOPED_TRACE("t = " + std::to_string(static_cast<double>(c.stamp_ns) * 1e-9) + " s");
    EXPECT_TRUE(c.solution.initialized);
    EXPECT_FALSE(c.solution.degraded) << c.solution.reason;
    EXPECT_EQ(c.solution.dvl_rejected + c.solution.imu_rejected + c.solution.depth_rejected, 0u);
    EXPECT_TRUE(geometry::isValidPose(c.solution.T_world_vehicle));
    // Depth is measured absolutely: the error is the depth noise (the 1e-4 psi reading step is
    // 0.07 mm, negligible).
    EXPECT_LE(std::abs(c.z_error_m), kSigmas * depth_sigma_m);
    EXPECT_LE(std::abs(c.roll_rad), kSigmas * attitude_sigma_rad);
    EXPECT_LE(std::abs(c.pitch_rad), kSigmas * attitude_sigma_rad);
    EXPECT_LE(std::abs(c.yaw_error_rad), kSigmas * c.yaw_sigma_rad);
    EXPECT_LE(c.error_xy_m.norm(), c.sampling_error_m + kSigmas * c.predicted_sigma_m)
        << "error (" << c.error_xy_m.transpose() << ") m, predicted sigma " << c.predicted_sigma_m
        << " m, sampling error " << c.sampling_error_m << " m";
  }

  const Checkpoint& last = run.checkpoints.back();
  RecordProperty("survey_s", std::to_string(static_cast<double>(last.stamp_ns) * 1e-9));
  RecordProperty("distance_m", std::to_string(run.distance_m));
  RecordProperty("final_error_m", std::to_string(last.error_xy_m.norm()));
  RecordProperty("predicted_sigma_m", std::to_string(last.predicted_sigma_m));
  RecordProperty("sampling_error_m", std::to_string(last.sampling_error_m));
  RecordProperty("solution_sigma_m", std::to_string(last.solution.position_sigma_m));
  // The sampling part stays small next to the noise part, or the bound would mostly test it.
  EXPECT_LT(last.sampling_error_m, last.predicted_sigma_m);
  // The solution's own sigma (per axis) models the same three noise sources as the prediction (its
  // heading-drift term from the path moments, the white terms per DVL sample), so it agrees with the
  // predicted per-axis drift within a factor 1.5 (measured: 0.997); and it is of the order of the (random) observed
  // error: within 100x.
  const double per_axis_predicted = last.predicted_sigma_m / std::sqrt(2.0);
  const double per_axis_observed = last.error_xy_m.norm() / std::sqrt(2.0);
  EXPECT_GT(last.solution.position_sigma_m, per_axis_predicted / 1.5);
  EXPECT_LT(last.solution.position_sigma_m, per_axis_predicted * 1.5);
  EXPECT_GT(last.solution.position_sigma_m, per_axis_observed / 100.0);
  EXPECT_LT(last.solution.position_sigma_m, per_axis_observed * 100.0);
  EXPECT_EQ(last.solution.dvl_used, static_cast<std::uint64_t>(last.stamp_ns / 200'000'000 + 1));

  // No DVL for 2 s (the IMU and the depth sensor still report): degraded, and the reason names the
  // DVL and nothing else.
  EXPECT_TRUE(run.after_dvl_stop.degraded);
  EXPECT_NE(run.after_dvl_stop.reason.find("dvl"), std::string::npos) << run.after_dvl_stop.reason;
  EXPECT_EQ(run.after_dvl_stop.reason.find("imu"), std::string::npos) << run.after_dvl_stop.reason;
  EXPECT_EQ(run.after_dvl_stop.reason.find("depth"), std::string::npos) << run.after_dvl_stop.reason;
  EXPECT_EQ(run.after_dvl_stop.dvl_used, run.dvl_sent);
}

TEST(DeadReckoningSimTest, ASeedGivesIdenticalRunsAndAnotherSeedDiffers) {
  SimRun a, b, c;
  ASSERT_NO_FATAL_FAILURE(runSurvey(11, a));
  ASSERT_NO_FATAL_FAILURE(runSurvey(11, b));
  ASSERT_NO_FATAL_FAILURE(runSurvey(12, c));
  ASSERT_EQ(a.checkpoints.size(), b.checkpoints.size());
  for (std::size_t i = 0; i < a.checkpoints.size(); ++i) {
    const NavSolution& x = a.checkpoints[i].solution;
    const NavSolution& y = b.checkpoints[i].solution;
    EXPECT_EQ(x.T_world_vehicle.matrix(), y.T_world_vehicle.matrix()) << "checkpoint " << i;
    EXPECT_EQ(x.position_sigma_m, y.position_sigma_m);
    EXPECT_EQ(x.velocity_world_mps, y.velocity_world_mps);
  }
  EXPECT_EQ(a.after_dvl_stop.T_world_vehicle.matrix(), b.after_dvl_stop.T_world_vehicle.matrix());
  // The noise comes from the seed: another seed moves the solution.
  ASSERT_FALSE(c.checkpoints.empty());
  EXPECT_NE(a.checkpoints.back().solution.T_world_vehicle.translation(),
            c.checkpoints.back().solution.T_world_vehicle.translation());
}

TEST(DeadReckoningSimTest, PredictedDriftIsCalibratedOverSeeds) {
  // The k-sigma bound alone would also pass with a prediction far too large. Over independent
  // seeds, the mean of |e|^2 / (E|e|^2 + sampling^2) at the end of the survey estimates 1 when the
  // noise model is right (the sampling error is deterministic, the noise zero-mean). With 16 seeds
  // its standard error is about 0.25 (|e|^2 / E|e|^2 is about chi^2_2 / 2, variance 1).
  constexpr int kSeeds = 16;
  double sum = 0.0;
  for (int i = 0; i < kSeeds; ++i) {
    SimRun run;
    ASSERT_NO_FATAL_FAILURE(runSurvey(static_cast<std::uint64_t>(100 + i), run));
    ASSERT_FALSE(run.checkpoints.empty());
    const Checkpoint& c = run.checkpoints.back();
    sum += c.error_xy_m.squaredNorm() /
           (c.predicted_sigma_m * c.predicted_sigma_m + c.sampling_error_m * c.sampling_error_m);
  }
  const double mean = sum / kSeeds;
  RecordProperty("mean_error_ratio", std::to_string(mean));
  EXPECT_GT(mean, 0.4);
  EXPECT_LT(mean, 2.0);
}

}  // namespace
}  // namespace vog::nav
