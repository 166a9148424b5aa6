#include "vog/nav/dead_reckoning.hpp"

#include <iomanip>
#include <sstream>

#include <algorithm>
#include <cmath>

namespace vog::nav {
namespace {

constexpr double kNsPerS = 1e9;

double seconds(std::int64_t dt_ns) { return static_cast<double>(dt_ns) / kNsPerS; }

std::string fmt(double v) {
  std::ostringstream os;
  os << std::setprecision(3) << v;
  return os.str();
}

Eigen::Matrix3d rotationFromRpy(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// RDI ship coordinates: x starboard, y forward, z up; as vehicle (forward, left, up) vectors.
Eigen::Matrix3d vehicleFromShip() {
  Eigen::Matrix3d m;
  m << 0, 1, 0,  //
      -1, 0, 0,  //
      0, 0, 1;
  return m;
}

}  // namespace

Eigen::Matrix3d worldFromNedAttitude(double roll_rad, double pitch_rad, double heading_rad) {
  // R_ned_frd = Rz(heading) Ry(pitch) Rx(roll) (aerospace Z-Y-X convention of NED attitude);
  // R_enu_flu = A R_ned_frd B with A = ENU <- NED (swap x/y, negate z) and B = FRD <- FLU.
  Eigen::Matrix3d A;
  A << 0, 1, 0,  //
      1, 0, 0,   //
      0, 0, -1;
  const Eigen::Matrix3d B = Eigen::Vector3d(1, -1, -1).asDiagonal();
  return A * rotationFromRpy(roll_rad, pitch_rad, heading_rad) * B;
}

Status DeadReckoningConfig::validate(const std::string& prefix) const {
  auto positive = [&](double v, const char* key) -> Status {
    if (!(std::isfinite(v) && v > 0.0)) return Error{prefix + "." + key + " must be > 0, got " + fmt(v)};
    return Status::success();
  };
  auto nonNegative = [&](double v, const char* key) -> Status {
    if (!(std::isfinite(v) && v >= 0.0)) return Error{prefix + "." + key + " must be >= 0, got " + fmt(v)};
    return Status::success();
  };
  for (const auto& [v, key] :
       {std::pair{dvl_mount_roll_rad, "dvl_mount_roll_rad"}, std::pair{dvl_mount_pitch_rad, "dvl_mount_pitch_rad"},
        std::pair{dvl_mount_yaw_rad, "dvl_mount_yaw_rad"}}) {
    if (!std::isfinite(v) || std::abs(v) > 2 * M_PI) {
      return Error{prefix + "." + key + " must be finite and within [-2 pi, 2 pi], got " + fmt(v)};
    }
  }
  for (const auto& [v, key] :
       {std::pair{imu_max_gap_s, "imu_max_gap_s"}, std::pair{imu_timeout_s, "imu_timeout_s"},
        std::pair{dvl_timeout_s, "dvl_timeout_s"}, std::pair{depth_timeout_s, "depth_timeout_s"},
        std::pair{max_error_velocity_mps, "max_error_velocity_mps"}, std::pair{max_speed_mps, "max_speed_mps"}}) {
    Status s = positive(v, key);
    if (!s.ok()) return s;
  }
  Status s = nonNegative(dvl_velocity_sigma_mps, "dvl_velocity_sigma_mps");
  if (!s.ok()) return s;
  s = nonNegative(heading_drift_rad2_per_s, "heading_drift_rad2_per_s");
  if (!s.ok()) return s;
  return nonNegative(heading_sigma_rad, "heading_sigma_rad");
}

DeadReckoning::DeadReckoning(DeadReckoningConfig config)
    : config_(config),
      R_vehicle_dvl_(rotationFromRpy(config.dvl_mount_roll_rad, config.dvl_mount_pitch_rad, config.dvl_mount_yaw_rad)) {
}

Status DeadReckoning::reject(std::uint64_t& counter, std::string reason) {
  ++counter;
  last_rejection_ = reason;
  return Error{std::move(reason)};
}

Status DeadReckoning::addImu(const imu::ImuSample& sample) {
  if (sample.stamp_ns <= last_imu_ns_) {
    return reject(imu_rejected_, "imu sample at " + std::to_string(sample.stamp_ns) +
                                     " ns is not after the previous (" + std::to_string(last_imu_ns_) + " ns)");
  }
  if (sample.status != 0) {
    std::ostringstream status;
    status << "0x" << std::hex << std::setw(8) << std::setfill('0') << sample.status;
    return reject(imu_rejected_, "imu status " + status.str() + " reports a fault");
  }
  if (!sample.attitude) return reject(imu_rejected_, "imu sample carries no attitude");
  const imu::ImuAttitude& a = *sample.attitude;
  if (!std::isfinite(a.roll_rad) || !std::isfinite(a.pitch_rad) || !std::isfinite(a.yaw_rad) ||
      std::abs(a.pitch_rad) >= M_PI / 2) {
    return reject(imu_rejected_, "imu attitude not finite or pitch outside (-90, 90) deg: roll " + fmt(a.roll_rad) +
                                     " pitch " + fmt(a.pitch_rad) + " yaw " + fmt(a.yaw_rad) + " rad");
  }
  last_imu_ns_ = sample.stamp_ns;
  attitudes_.push_back(
      Attitude{sample.stamp_ns, Eigen::Quaterniond(worldFromNedAttitude(a.roll_rad, a.pitch_rad, a.yaw_rad))});
  // Keep about one second (plus two samples) for aligning late DVL stamps.
  while (attitudes_.size() > 2 &&
         attitudes_.back().stamp_ns - attitudes_[1].stamp_ns > static_cast<std::int64_t>(kNsPerS)) {
    attitudes_.pop_front();
  }
  return Status::success();
}

Status DeadReckoning::addDepth(const depth::DepthSample& sample) {
  if (sample.stamp_ns <= last_depth_ns_) {
    return reject(depth_rejected_, "depth sample at " + std::to_string(sample.stamp_ns) +
                                       " ns is not after the previous (" + std::to_string(last_depth_ns_) + " ns)");
  }
  // -10 m admits a sensor above the surface at launch; 11000 m is the deepest ocean.
  if (!std::isfinite(sample.depth_m) || sample.depth_m < -10.0 || sample.depth_m > 11000.0) {
    return reject(depth_rejected_, "depth " + fmt(sample.depth_m) + " m outside [-10, 11000]");
  }
  last_depth_ns_ = sample.stamp_ns;
  depth_m_ = sample.depth_m;
  return Status::success();
}

Status DeadReckoning::addDvl(const dvl::DvlEnsemble& ensemble) {
  if (!ensemble.bottom_track)
    return reject(dvl_rejected_,
                  "dvl ensemble " + std::to_string(ensemble.variable.ensemble_number) + " has no bottom track");
  const dvl::DvlBottomTrack& bt = *ensemble.bottom_track;
  dvl::BottomVelocity v;
  v.stamp_ns = ensemble.stamp_ns;
  v.frame = ensemble.fixed.coordinate_frame;
  if (v.frame == dvl::CoordinateFrame::kBeam) {
    // The beam -> instrument transform needs the head geometry; dvl::bottomVelocity() does it.
    return reject(dvl_rejected_, "dvl ensemble " + std::to_string(ensemble.variable.ensemble_number) +
                                     " is in beam coordinates; convert with dvl::bottomVelocity()");
  }
  for (int i = 0; i < 3; ++i) {
    if (!bt.velocity_valid[static_cast<std::size_t>(i)]) {
      return reject(dvl_rejected_, "dvl ensemble " + std::to_string(ensemble.variable.ensemble_number) +
                                       ": bottom-track velocity component " + std::to_string(i + 1) + " is bad");
    }
    // PD0 bottom track is the bottom's motion relative to the instrument: negate for the vehicle's.
    v.velocity_mps[static_cast<std::size_t>(i)] = -bt.velocity_mps[static_cast<std::size_t>(i)];
    v.beam_valid[static_cast<std::size_t>(i)] = true;
  }
  // A 3-beam solution has no error velocity (marked bad); it is still a valid velocity.
  v.beam_valid[3] = bt.velocity_valid[3];
  v.error_velocity_mps = bt.velocity_valid[3] ? bt.velocity_mps[3] : 0.0;
  v.valid = true;
  return addDvl(v);
}

Result<Eigen::Quaterniond> DeadReckoning::attitudeAt(std::int64_t stamp_ns) const {
  const auto max_gap_ns = static_cast<std::int64_t>(config_.imu_max_gap_s * kNsPerS);
  if (attitudes_.empty()) return Error{"no imu attitude yet"};
  // First attitude at or after the stamp.
  auto after = std::lower_bound(attitudes_.begin(), attitudes_.end(), stamp_ns,
                                [](const Attitude& a, std::int64_t t) { return a.stamp_ns < t; });
  if (after != attitudes_.end() && after->stamp_ns == stamp_ns) return after->q_world_vehicle;
  if (after == attitudes_.end()) {
    const Attitude& last = attitudes_.back();
    if (stamp_ns - last.stamp_ns <= max_gap_ns) return last.q_world_vehicle;  // hold the newest
    return Error{"newest imu attitude is " + fmt(seconds(stamp_ns - last.stamp_ns)) + " s older than the dvl stamp"};
  }
  if (after == attitudes_.begin()) {
    if (after->stamp_ns - stamp_ns <= max_gap_ns) return after->q_world_vehicle;
    return Error{"dvl stamp is " + fmt(seconds(after->stamp_ns - stamp_ns)) + " s before the oldest imu attitude"};
  }
  const Attitude& before = *(after - 1);
  if (after->stamp_ns - before.stamp_ns > max_gap_ns) {
    return Error{"imu gap of " + fmt(seconds(after->stamp_ns - before.stamp_ns)) + " s around the dvl stamp"};
  }
  const double f =
      static_cast<double>(stamp_ns - before.stamp_ns) / static_cast<double>(after->stamp_ns - before.stamp_ns);
  return before.q_world_vehicle.slerp(f, after->q_world_vehicle);
}

Status DeadReckoning::addDvl(const dvl::BottomVelocity& velocity) {
  if (!velocity.valid) return reject(dvl_rejected_, "dvl bottom velocity marked invalid");
  if (velocity.stamp_ns <= last_dvl_ns_) {
    return reject(dvl_rejected_, "dvl sample at " + std::to_string(velocity.stamp_ns) +
                                     " ns is not after the previous (" + std::to_string(last_dvl_ns_) + " ns)");
  }
  if (velocity.frame == dvl::CoordinateFrame::kBeam) return reject(dvl_rejected_, "dvl velocity in beam coordinates");
  const Eigen::Vector3d v(velocity.velocity_mps[0], velocity.velocity_mps[1], velocity.velocity_mps[2]);
  if (!v.allFinite() || !std::isfinite(velocity.error_velocity_mps)) {
    return reject(dvl_rejected_, "dvl velocity not finite");
  }
  if (v.norm() > config_.max_speed_mps) {
    return reject(dvl_rejected_,
                  "dvl speed " + fmt(v.norm()) + " m/s above nav.max_speed_mps " + fmt(config_.max_speed_mps));
  }
  if (std::abs(velocity.error_velocity_mps) > config_.max_error_velocity_mps) {
    return reject(dvl_rejected_, "dvl error velocity " + fmt(velocity.error_velocity_mps) +
                                     " m/s above nav.max_error_velocity_mps " + fmt(config_.max_error_velocity_mps));
  }
  Eigen::Vector3d v_world;
  if (velocity.frame == dvl::CoordinateFrame::kEarth) {
    v_world = v;  // RDI earth coordinates: east, north, up = world axes
  } else {
    Result<Eigen::Quaterniond> q = attitudeAt(velocity.stamp_ns);
    if (!q.ok()) return reject(dvl_rejected_, "dvl sample not rotated: " + q.error().message);
    const Eigen::Matrix3d R_vehicle_frame =
        velocity.frame == dvl::CoordinateFrame::kShip ? vehicleFromShip() : R_vehicle_dvl_;
    v_world = q->toRotationMatrix() * R_vehicle_frame * v;
  }
  if (last_dvl_ns_ >= 0) {
    // Trapezoidal integration between consecutive accepted samples.
    const double dt_s = seconds(velocity.stamp_ns - last_dvl_ns_);
    const Eigen::Vector2d xy_before = xy_m_;
    xy_m_ += 0.5 * dt_s * (v_world_mps_.head<2>() + v_world.head<2>());
    path_s0_s_ += dt_s;
    path_s1_ += 0.5 * dt_s * (xy_before + xy_m_);
    path_s2_ += 0.5 * dt_s * (xy_before.squaredNorm() + xy_m_.squaredNorm());
    // White velocity noise and white heading noise of each sample, integrated over dt (random walk).
    const double speed = v_world.head<2>().norm();
    variance_m2_ += dt_s * dt_s *
                    (config_.dvl_velocity_sigma_mps * config_.dvl_velocity_sigma_mps +
                     0.5 * speed * speed * config_.heading_sigma_rad * config_.heading_sigma_rad);
  }
  v_world_mps_ = v_world;
  last_dvl_ns_ = velocity.stamp_ns;
  ++dvl_used_;
  return Status::success();
}

void DeadReckoning::resetPosition(double x_m, double y_m) {
  xy_m_ = Eigen::Vector2d(x_m, y_m);
  variance_m2_ = 0.0;
  path_s0_s_ = 0.0;
  path_s1_ = Eigen::Vector2d::Zero();
  path_s2_ = 0.0;
}

NavSolution DeadReckoning::solution(std::int64_t now_ns) const {
  NavSolution s;
  s.stamp_ns = now_ns;
  s.dvl_used = dvl_used_;
  s.dvl_rejected = dvl_rejected_;
  s.imu_rejected = imu_rejected_;
  s.depth_rejected = depth_rejected_;
  std::string reason;
  auto add = [&reason](const std::string& r) { reason += (reason.empty() ? "" : "; ") + r; };
  auto check = [&](std::int64_t last_ns, double timeout_s, const char* name) {
    if (last_ns < 0) {
      add(std::string("no ") + name + " data yet");
    } else if (seconds(now_ns - last_ns) > timeout_s) {
      add(std::string(name) + " stale (" + fmt(seconds(now_ns - last_ns)) + " s)");
    }
  };
  check(last_imu_ns_, config_.imu_timeout_s, "imu");
  check(last_dvl_ns_, config_.dvl_timeout_s, "dvl");
  check(last_depth_ns_, config_.depth_timeout_s, "depth");
  if (!reason.empty() && !last_rejection_.empty()) add("last rejected: " + last_rejection_);
  s.initialized = last_imu_ns_ >= 0 && last_dvl_ns_ >= 0 && last_depth_ns_ >= 0;
  s.degraded = !reason.empty();
  s.reason = reason;
  s.T_world_vehicle = geometry::Pose3::Identity();
  if (!attitudes_.empty())
    s.T_world_vehicle.linear() = attitudes_.back().q_world_vehicle.normalized().toRotationMatrix();
  s.T_world_vehicle.translation() = Eigen::Vector3d(xy_m_.x(), xy_m_.y(), -depth_m_);  // z up, depth down
  s.velocity_world_mps = v_world_mps_;
  // Per axis: half of the drift term (it spreads over both axes).
  const double drift_m2 = 0.5 * config_.heading_drift_rad2_per_s *
                          std::max(0.0, xy_m_.squaredNorm() * path_s0_s_ - 2.0 * xy_m_.dot(path_s1_) + path_s2_);
  s.position_sigma_m = std::sqrt(variance_m2_ + drift_m2);
  return s;
}

Result<geometry::Pose3> DeadReckoning::poseAt(std::int64_t stamp_ns) const {
  if (last_dvl_ns_ < 0) return Error{"no dvl data yet"};
  if (last_depth_ns_ < 0) return Error{"no depth data yet"};
  const double dvl_age_s = seconds(stamp_ns - last_dvl_ns_);
  if (std::abs(dvl_age_s) > config_.dvl_timeout_s) {
    return Error{"newest dvl sample is " + fmt(dvl_age_s) + " s from the stamp (nav.dvl_timeout_s " +
                 fmt(config_.dvl_timeout_s) + ")"};
  }
  const double depth_age_s = seconds(stamp_ns - last_depth_ns_);
  if (std::abs(depth_age_s) > config_.depth_timeout_s) {
    return Error{"newest depth sample is " + fmt(depth_age_s) + " s from the stamp (nav.depth_timeout_s " +
                 fmt(config_.depth_timeout_s) + ")"};
  }
  Result<Eigen::Quaterniond> q = attitudeAt(stamp_ns);
  if (!q.ok()) return Error{"attitude: " + q.error().message};
  const Eigen::Vector2d xy = xy_m_ + dvl_age_s * v_world_mps_.head<2>();
  geometry::Pose3 T = geometry::Pose3::Identity();
  T.linear() = q->normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(xy.x(), xy.y(), -depth_m_);
  return T;
}

}  // namespace vog::nav
