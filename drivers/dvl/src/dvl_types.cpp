#include "vog/dvl/dvl_types.hpp"

#include <chrono>
#include <cmath>
#include <numbers>
#include <string>

namespace vog::dvl {

const char* toString(CoordinateFrame frame) {
  switch (frame) {
    case CoordinateFrame::kBeam: return "beam";
    case CoordinateFrame::kInstrument: return "instrument";
    case CoordinateFrame::kShip: return "ship";
    case CoordinateFrame::kEarth: return "earth";
  }
  return "unknown";
}

Result<std::int64_t> clockToUnixNs(const DvlClock& clock) {
  using namespace std::chrono;
  const year_month_day ymd{year{clock.year}, month{static_cast<unsigned>(clock.month)},
                           day{static_cast<unsigned>(clock.day)}};
  if (!ymd.ok() || clock.month < 1 || clock.day < 1) {
    return Error{"invalid DVL clock date " + std::to_string(clock.year) + "-" + std::to_string(clock.month) + "-" +
                 std::to_string(clock.day)};
  }
  if (clock.hour < 0 || clock.hour > 23 || clock.minute < 0 || clock.minute > 59 || clock.second < 0 ||
      clock.second > 60 || clock.hundredths < 0 || clock.hundredths > 99) {
    return Error{"invalid DVL clock time " + std::to_string(clock.hour) + ":" + std::to_string(clock.minute) + ":" +
                 std::to_string(clock.second) + "." + std::to_string(clock.hundredths)};
  }
  const auto days = sys_days{ymd}.time_since_epoch();
  const auto total = duration_cast<nanoseconds>(days) + hours{clock.hour} + minutes{clock.minute} +
                     seconds{clock.second} + milliseconds{10 * clock.hundredths};
  return static_cast<std::int64_t>(total.count());
}

Result<BottomVelocity> bottomVelocity(const DvlEnsemble& ensemble) {
  if (!ensemble.bottom_track)
    return Error{"ensemble " + std::to_string(ensemble.variable.ensemble_number) + " has no bottom track"};
  const DvlBottomTrack& bt = *ensemble.bottom_track;
  BottomVelocity out;
  out.stamp_ns = ensemble.stamp_ns;
  out.beam_valid = bt.velocity_valid;
  const CoordinateFrame frame = ensemble.fixed.coordinate_frame;
  if (frame == CoordinateFrame::kBeam) {
    for (int i = 0; i < 4; ++i) {
      if (!bt.velocity_valid[static_cast<std::size_t>(i)]) {
        return Error{"bottom track beam " + std::to_string(i + 1) + " invalid in beam coordinates"};
      }
    }
    if (ensemble.fixed.beam_angle_deg <= 0 || ensemble.fixed.beam_angle_deg >= 90) {
      return Error{"beam angle " + std::to_string(ensemble.fixed.beam_angle_deg) +
                   " deg unknown, cannot transform beams"};
    }
    // RDI "ADCP Coordinate Transformation" (P/N 951-6079), 4-beam Janus, convex transducer (c = +1).
    const double theta = ensemble.fixed.beam_angle_deg * std::numbers::pi / 180.0;
    const double a = 1.0 / (2.0 * std::sin(theta));
    const double b = 1.0 / (4.0 * std::cos(theta));
    const double d = a / std::numbers::sqrt2;
    const auto& v = bt.velocity_mps;
    const double x = a * (v[0] - v[1]);
    const double y = a * (v[3] - v[2]);
    const double z = b * (v[0] + v[1] + v[2] + v[3]);
    // Bottom motion -> vehicle motion: negate (PROTOCOLS.md, PD0 sign opposite to PD6).
    out.frame = CoordinateFrame::kInstrument;
    out.velocity_mps = {-x, -y, -z};
    out.error_velocity_mps = d * (v[0] + v[1] - v[2] - v[3]);
    out.valid = true;
    return out;
  }
  out.frame = frame;
  for (std::size_t i = 0; i < 3; ++i) {
    if (!bt.velocity_valid[i]) {
      return Error{std::string("bottom track ") + "xyz"[i] + " velocity invalid (" + toString(frame) + " frame)"};
    }
    out.velocity_mps[i] = -bt.velocity_mps[i];
  }
  out.error_velocity_mps = bt.velocity_valid[3] ? bt.velocity_mps[3] : 0.0;
  out.valid = true;
  return out;
}

}  // namespace vog::dvl
