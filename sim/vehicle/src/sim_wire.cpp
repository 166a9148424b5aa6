#include "vog/vehicle/sim_wire.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>

#include <Eigen/Geometry>

#include "vog/depth/digiquartz.hpp"
#include "vog/depth/unesco.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/geometry/pose.hpp"

namespace vog::vehicle {
namespace {

std::string shortest(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

Eigen::Matrix3d rotationFromRpy(double roll, double pitch, double yaw) {
  return geometry::poseFromXyzRpy(0.0, 0.0, 0.0, roll, pitch, yaw).linear();
}

// Unix nanoseconds (UTC) to the PD0 real-time clock fields (RDI PD0 variable leader, bytes 5-11
// and the Y2K clock at bytes 58-65), civil date from the proleptic Gregorian calendar.
dvl::DvlClock clockFromUnixNs(std::int64_t unix_ns) {
  using namespace std::chrono;
  const sys_time<nanoseconds> t{nanoseconds{unix_ns}};
  const sys_days day = floor<days>(t);
  const year_month_day ymd{day};
  const hh_mm_ss<nanoseconds> hms{t - day};
  dvl::DvlClock c;
  c.year = static_cast<int>(ymd.year());
  c.month = static_cast<int>(static_cast<unsigned>(ymd.month()));
  c.day = static_cast<int>(static_cast<unsigned>(ymd.day()));
  c.hour = static_cast<int>(hms.hours().count());
  c.minute = static_cast<int>(hms.minutes().count());
  c.second = static_cast<int>(hms.seconds().count());
  c.hundredths = static_cast<int>(duration_cast<milliseconds>(hms.subseconds()).count() / 10);
  return c;
}

}  // namespace

Status SimWireConfig::validate() const {
  for (const auto& [v, key] :
       {std::pair{dvl_mount_roll_rad, "dvl_mount_roll_rad"}, std::pair{dvl_mount_pitch_rad, "dvl_mount_pitch_rad"},
        std::pair{dvl_mount_yaw_rad, "dvl_mount_yaw_rad"}}) {
    if (!std::isfinite(v) || std::abs(v) > 2 * std::numbers::pi) {
      return Error{std::string("sim_wire.") + key + " must be finite and within [-2 pi, 2 pi], got " + shortest(v)};
    }
  }
  // The PD0 fixed leader stores the beam angle in one byte; Janus heads are 15-45 deg.
  if (dvl_beam_angle_deg < 1 || dvl_beam_angle_deg > 89) {
    return Error{"sim_wire.dvl_beam_angle_deg must be in [1, 89], got " + std::to_string(dvl_beam_angle_deg)};
  }
  // u16 m/s on the wire (PD0 variable leader bytes 15-16).
  if (!(dvl_sound_speed_mps >= 1400.0 && dvl_sound_speed_mps <= 1600.0)) {
    return Error{"sim_wire.dvl_sound_speed_mps must be in [1400, 1600], got " + shortest(dvl_sound_speed_mps)};
  }
  if (epoch_unix_ns < 0) return Error{"sim_wire.epoch_unix_ns must be >= 0, got " + std::to_string(epoch_unix_ns)};
  if (Status s = depth.validate(); !s.ok()) return Error{"sim_wire." + s.error().message};
  if (depth_decimals < 0 || depth_decimals > 9) {
    return Error{"sim_wire.depth_decimals must be in [0, 9], got " + std::to_string(depth_decimals)};
  }
  // u16 microseconds on the wire (drivers/imu/README.md, frame 3).
  if (!(imu_dt_s >= 1e-6 && imu_dt_s <= 0.065535)) {
    return Error{"sim_wire.imu_dt_s must be in [1e-6, 0.065535], got " + shortest(imu_dt_s)};
  }
  return Status::success();
}

Eigen::Vector3d nedRollPitchHeading(const Eigen::Matrix3d& R_world_vehicle) {
  // nav::worldFromNedAttitude: R_enu_flu = A R_ned_frd B with A = ENU <- NED (swap x/y, negate
  // z) and B = FRD <- FLU; both are their own inverses, so R_ned_frd = A R_enu_flu B.
  Eigen::Matrix3d A;
  A << 0, 1, 0,  //
      1, 0, 0,   //
      0, 0, -1;
  const Eigen::Matrix3d B = Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Eigen::Matrix3d R = A * R_world_vehicle * B;
  // Z-Y-X: R = Rz(heading) Ry(pitch) Rx(roll).
  const double pitch = -std::asin(std::clamp(R(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double heading = std::atan2(R(1, 0), R(0, 0));
  return {roll, pitch, heading};
}

Result<double> seaPressureForDepth_dbar(double depth_m, double latitude_deg) {
  // unescoDepth_m is strictly increasing in pressure over the ocean's range (about 0.99 m per
  // dbar, Fofonoff & Millard 1983), so bisection over [-20, 12000] dbar converges.
  if (!std::isfinite(depth_m) || depth_m < -10.0 || depth_m > 11000.0) {
    return Error{"depth " + shortest(depth_m) + " m outside [-10, 11000]"};
  }
  double lo = -20.0, hi = 12000.0;
  for (int i = 0; i < 200 && hi - lo > 1e-10; ++i) {
    const double mid = 0.5 * (lo + hi);
    (depth::unescoDepth_m(mid, latitude_deg) < depth_m ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

Result<dvl::DvlEnsemble> toPd0Ensemble(const sim::DvlSample& sample, std::uint32_t ensemble_number,
                                       const SimWireConfig& config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  if (sample.bottom_lock && (!sample.velocity_vehicle_mps.allFinite() || !std::isfinite(sample.altitude_m))) {
    return Error{"dvl sample at " + std::to_string(sample.stamp_ns) + " ns has a non-finite velocity or altitude"};
  }
  dvl::DvlEnsemble e;
  e.stamp_ns = sample.stamp_ns;
  e.fixed.n_beams = 4;
  e.fixed.pings_per_ensemble = 1;
  e.fixed.coordinate_frame = dvl::CoordinateFrame::kInstrument;
  e.fixed.coordinate_transform =
      static_cast<std::uint8_t>(static_cast<unsigned>(dvl::CoordinateFrame::kInstrument) << 3);
  e.fixed.beam_angle_deg = config.dvl_beam_angle_deg;
  e.variable.ensemble_number = ensemble_number;
  e.variable.clock = clockFromUnixNs(config.epoch_unix_ns + sample.stamp_ns);
  e.variable.sound_speed_mps = config.dvl_sound_speed_mps;
  e.data_type_ids = {dvl::pd0::kFixedLeaderId, dvl::pd0::kVariableLeaderId, dvl::pd0::kBottomTrackId};

  dvl::DvlBottomTrack bt;
  bt.pings_per_ensemble = 1;
  if (sample.bottom_lock) {
    const Eigen::Matrix3d R_vehicle_dvl =
        rotationFromRpy(config.dvl_mount_roll_rad, config.dvl_mount_pitch_rad, config.dvl_mount_yaw_rad);
    // Instrument-frame vehicle velocity; PD0 reports the bottom's motion, hence the minus.
    const Eigen::Vector3d v_bottom_dvl = -(R_vehicle_dvl.transpose() * sample.velocity_vehicle_mps);
    for (std::size_t i = 0; i < 3; ++i) {
      bt.velocity_mps[i] = v_bottom_dvl[static_cast<Eigen::Index>(i)];
      bt.velocity_valid[i] = true;
    }
    // The four beams agree exactly in the model: zero error velocity.
    bt.velocity_mps[3] = 0.0;
    bt.velocity_valid[3] = true;
    // Vertical range per beam over the flat bottom the model assumes below the vehicle.
    bt.range_m.fill(sample.altitude_m);
    bt.correlation.fill(250);
    bt.amplitude.fill(120);
    bt.percent_good.fill(100);
  } else {
    bt.velocity_valid.fill(false);  // -32768 on the wire: no bottom within range
  }
  e.bottom_track = bt;
  return e;
}

Result<imu::ImuSample> toImuSample(const sim::ImuSample& sample, std::uint32_t sequence, const SimWireConfig& config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  if (!sample.rpy_rad.allFinite() || !sample.angular_rate_vehicle_radps.allFinite()) {
    return Error{"imu sample at " + std::to_string(sample.stamp_ns) + " ns has a non-finite attitude or rate"};
  }
  const Eigen::Matrix3d R_world_vehicle = rotationFromRpy(sample.rpy_rad.x(), sample.rpy_rad.y(), sample.rpy_rad.z());
  const Eigen::Vector3d ned = nedRollPitchHeading(R_world_vehicle);
  // Value-initialised (zeroed first): GCC's -Wmaybe-uninitialized otherwise flags the move of the
  // disengaged optional<Eigen::Vector3d> delta_angle_rad under -O2 with sanitizers.
  imu::ImuSample s{};
  s.stamp_ns = sample.stamp_ns;
  s.sequence = sequence;
  s.status = 0;
  s.attitude = imu::ImuAttitude{ned.x(), ned.y(), ned.z()};
  // Forward-left-up rates to the IMU's forward-starboard-down body axes.
  const Eigen::Vector3d& w = sample.angular_rate_vehicle_radps;
  s.angular_rate_radps = Eigen::Vector3d(w.x(), -w.y(), -w.z());
  s.delta_velocity_mps = Eigen::Vector3d::Zero();
  s.dt_s = config.imu_dt_s;
  return s;
}

Result<double> toDigiquartzReading(const sim::DepthSample& sample, const SimWireConfig& config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  auto dbar = seaPressureForDepth_dbar(sample.depth_m, config.depth.latitude_deg);
  if (!dbar.ok()) return Error{"depth sample at " + std::to_string(sample.stamp_ns) + " ns: " + dbar.error().message};
  const auto unit = depth::pressureUnitFromCode(config.depth.units_code);
  if (!unit.ok()) return unit.error();
  const auto pa_per_unit = depth::pascalsPerUnit(*unit);
  if (!pa_per_unit.ok()) return pa_per_unit.error();
  // The inverse of depth::toDepthSample(): sea pressure plus the atmosphere for absolute sensors.
  const double sea_pa = *dbar * 1e4;
  const double reading_pa = config.depth.reading_is_absolute ? sea_pa + config.depth.atmospheric_pressure_pa : sea_pa;
  return reading_pa / *pa_per_unit;
}

}  // namespace vog::vehicle
