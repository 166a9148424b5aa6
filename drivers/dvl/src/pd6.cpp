#include "vog/dvl/pd6.hpp"

#include "vog/codec/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace vog::dvl {
namespace {

using codec::BadKind;
using Result6 = codec::DecodeResult<Pd6Sentence>;
constexpr int kBadValue = -32768;

std::optional<Pd6Sentence> parseLine(std::string_view line, std::string& why) {
  auto fail = [&why](std::string message) {
    why = std::move(message);
    return std::optional<Pd6Sentence>{};
  };
  const auto fields = codec::splitFields(line);
  const std::string_view name = fields[0];
  auto num = [&](std::size_t i) { return codec::parseDouble(fields[i]); };
  if (name == ":SA") {
    if (fields.size() != 4) return fail("SA needs 3 fields");
    const auto p = num(1), r = num(2), h = num(3);
    if (!p || !r || !h) return fail("SA field not a number");
    return Pd6Attitude{*p, *r, *h};
  }
  if (name == ":TS") {
    if (fields.size() != 7 || fields[1].size() != 14) return fail("TS needs 6 fields and a 14-digit time");
    int t[7];
    for (int i = 0; i < 7; ++i) {
      const auto d = codec::parseInt(fields[1].substr(static_cast<std::size_t>(2 * i), 2));
      if (!d || *d < 0) return fail("TS time not digits");
      t[i] = static_cast<int>(*d);
    }
    const auto s = num(2), temp = num(3), depth = num(4), c = num(5);
    const auto bit = codec::parseInt(fields[6]);
    if (!s || !temp || !depth || !c || !bit) return fail("TS field not a number");
    Pd6TimeAndScaling ts;
    ts.clock = DvlClock{t[0] < 80 ? 2000 + t[0] : 1900 + t[0], t[1], t[2], t[3], t[4], t[5], t[6]};
    ts.salinity_ppt = *s;
    ts.temperature_c = *temp;
    ts.transducer_depth_m = *depth;
    ts.sound_speed_mps = *c;
    ts.bit_result = static_cast<int>(*bit);
    return ts;
  }
  if (name.size() == 3 && (name[1] == 'B' || name[1] == 'W') && (name[2] == 'I' || name[2] == 'S' || name[2] == 'E')) {
    Pd6Velocity vel;
    vel.bottom = name[1] == 'B';
    vel.frame = name[2] == 'I' ? CoordinateFrame::kInstrument
                               : (name[2] == 'S' ? CoordinateFrame::kShip : CoordinateFrame::kEarth);
    vel.has_error_velocity = name[2] == 'I';
    const std::size_t n_values = vel.has_error_velocity ? 4 : 3;
    if (fields.size() != n_values + 2)
      return fail(std::string(name.substr(1)) + " needs " + std::to_string(n_values + 1) + " fields");
    for (std::size_t i = 0; i < n_values; ++i) {
      const auto v = codec::parseInt(fields[1 + i]);
      if (!v || *v < kBadValue || *v > 32767)
        return fail(std::string(name.substr(1)) + " velocity not an integer in mm/s");
      const bool ok = *v != kBadValue;
      if (i < 3) {
        vel.component_valid[i] = ok;
        vel.velocity_mps[i] = ok ? static_cast<double>(*v) * 0.001 : 0.0;
      } else {
        vel.error_velocity_mps = ok ? static_cast<double>(*v) * 0.001 : 0.0;
      }
    }
    const std::string_view status = fields[n_values + 1];
    if (status != "A" && status != "V") return fail("status must be A or V");
    vel.valid = status == "A";
    return vel;
  }
  if (name == ":BD" || name == ":WD") {
    if (fields.size() != 6) return fail("BD needs 5 fields");
    Pd6Distance d;
    d.bottom = name[1] == 'B';
    const auto e = num(1), n = num(2), u = num(3), r = num(4), t = num(5);
    if (!e || !n || !u || !r || !t) return fail("BD field not a number");
    d.east_m = *e;
    d.north_m = *n;
    d.up_m = *u;
    d.range_to_bottom_m = *r;
    d.time_since_good_s = *t;
    return d;
  }
  why = "unknown sentence " + codec::quoted(name);
  return std::nullopt;
}

}  // namespace

codec::DecodeResult<Pd6Sentence> Pd6Codec::decode(std::span<const std::uint8_t> b) const {
  if (b.empty()) return Result6::needMore();
  if (b[0] != ':') return Result6::bad(BadKind::kNoSync, codec::findByte(b, ':', 1), "PD6: no ':' sentence start");
  const std::size_t lf = codec::findByte(b, '\n');
  if (lf == b.size()) {
    if (b.size() > config_.max_line_bytes) return Result6::bad(BadKind::kMalformed, 1, "PD6: line longer than limit");
    return Result6::needMore();
  }
  const std::size_t consumed = lf + 1;
  std::string_view line = codec::asText(b.first(lf));
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  // A ':' inside the line means we joined mid-line or two lines were merged: restart at it.
  const std::size_t second = line.find(':', 1);
  if (second != std::string_view::npos) {
    return Result6::bad(BadKind::kMalformed, second,
                        "PD6: truncated sentence " + codec::quoted(line.substr(0, second)));
  }
  std::string why;
  auto sentence = parseLine(line, why);
  if (!sentence) return Result6::bad(BadKind::kMalformed, consumed, "PD6: " + why + " in " + codec::quoted(line));
  return Result6::decoded(std::move(*sentence), consumed);
}

namespace {

int mmps(double v_mps, bool valid) {
  if (!valid || !std::isfinite(v_mps)) return kBadValue;
  return static_cast<int>(std::clamp(std::round(v_mps * 1000.0), -32767.0, 32767.0));
}

struct Encoder {
  std::string operator()(const Pd6Attitude& a) const {
    char buf[96];
    std::snprintf(buf, sizeof buf, ":SA,%+06.2f,%+06.2f,%06.2f\r\n", a.pitch_deg, a.roll_deg, a.heading_deg);
    return buf;
  }
  std::string operator()(const Pd6TimeAndScaling& t) const {
    char buf[128];
    std::snprintf(buf, sizeof buf, ":TS,%02d%02d%02d%02d%02d%02d%02d,%04.1f,%+05.1f,%06.1f,%06.1f,%03d\r\n",
                  ((t.clock.year % 100) + 100) % 100, t.clock.month % 100, t.clock.day % 100, t.clock.hour % 100,
                  t.clock.minute % 100, t.clock.second % 100, t.clock.hundredths % 100, t.salinity_ppt, t.temperature_c,
                  t.transducer_depth_m, t.sound_speed_mps, t.bit_result % 1000);
    return buf;
  }
  std::string operator()(const Pd6Velocity& v) const {
    const char kind = v.bottom ? 'B' : 'W';
    const char frame = v.frame == CoordinateFrame::kShip ? 'S' : (v.frame == CoordinateFrame::kEarth ? 'E' : 'I');
    char buf[96];
    if (frame == 'I') {
      std::snprintf(buf, sizeof buf, ":%cI,%+06d,%+06d,%+06d,%+06d,%c\r\n", kind,
                    mmps(v.velocity_mps[0], v.component_valid[0]), mmps(v.velocity_mps[1], v.component_valid[1]),
                    mmps(v.velocity_mps[2], v.component_valid[2]), mmps(v.error_velocity_mps, v.has_error_velocity),
                    v.valid ? 'A' : 'V');
    } else {
      std::snprintf(buf, sizeof buf, ":%c%c,%+06d,%+06d,%+06d,%c\r\n", kind, frame,
                    mmps(v.velocity_mps[0], v.component_valid[0]), mmps(v.velocity_mps[1], v.component_valid[1]),
                    mmps(v.velocity_mps[2], v.component_valid[2]), v.valid ? 'A' : 'V');
    }
    return buf;
  }
  std::string operator()(const Pd6Distance& d) const {
    char buf[128];
    std::snprintf(buf, sizeof buf, ":%cD,%+013.2f,%+013.2f,%+013.2f,%07.2f,%06.2f\r\n", d.bottom ? 'B' : 'W', d.east_m,
                  d.north_m, d.up_m, d.range_to_bottom_m, d.time_since_good_s);
    return buf;
  }
};

}  // namespace

std::string encodePd6(const Pd6Sentence& sentence) { return std::visit(Encoder{}, sentence); }

Result<BottomVelocity> bottomVelocity(const Pd6Velocity& s, std::int64_t stamp_ns) {
  if (!s.bottom) return Error{"PD6 water-mass velocity is not a bottom velocity"};
  if (!s.valid) return Error{"PD6 bottom velocity status V (invalid)"};
  for (std::size_t i = 0; i < 3; ++i) {
    if (!s.component_valid[i])
      return Error{std::string("PD6 bottom velocity component ") + "xyz"[i] + " is -32768 (bad)"};
  }
  BottomVelocity out;
  out.stamp_ns = stamp_ns;
  out.frame = s.frame;
  out.velocity_mps = s.velocity_mps;  // PD6 already reports the vehicle's motion
  out.error_velocity_mps = s.error_velocity_mps;
  out.valid = true;
  out.beam_valid = {true, true, true, true};
  return out;
}

}  // namespace vog::dvl
