#include "vog/depth/digiquartz.hpp"

#include "vog/codec/text.hpp"
#include "vog/depth/unesco.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>

namespace vog::depth {
namespace {

using codec::BadKind;
using ResultDq = codec::DecodeResult<DigiquartzMessage>;

bool isDigit(char c) { return c >= '0' && c <= '9'; }

// "*ddss" at the front of `s`.
bool parseAddress(std::string_view s, int& destination, int& source) {
  if (s.size() < 5 || s[0] != '*') return false;
  for (std::size_t i = 1; i < 5; ++i) {
    if (!isDigit(s[i])) return false;
  }
  destination = (s[1] - '0') * 10 + (s[2] - '0');
  source = (s[3] - '0') * 10 + (s[4] - '0');
  return true;
}

bool isCommandWord(std::string_view s) {
  if (s.empty()) return false;
  for (const char c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c))) return false;
  }
  return true;
}

}  // namespace

Result<PressureUnit> pressureUnitFromCode(int code) {
  if (code < 0 || code > 8) return Error{"Digiquartz units code " + std::to_string(code) + " unknown (0..8)"};
  return static_cast<PressureUnit>(code);
}

Result<double> pascalsPerUnit(PressureUnit unit) {
  switch (unit) {
    case PressureUnit::kPsi: return 6894.757293168;
    case PressureUnit::kHpa: return 100.0;
    case PressureUnit::kBar: return 1.0e5;
    case PressureUnit::kKpa: return 1.0e3;
    case PressureUnit::kMpa: return 1.0e6;
    case PressureUnit::kInHg: return 3386.389;
    case PressureUnit::kMmHg: return 133.322387415;
    case PressureUnit::kMetersOfWater: return 9806.65;
    case PressureUnit::kUserDefined: break;
  }
  return Error{"Digiquartz user-defined units (UN=0) have no known conversion to pascals"};
}

Status DepthConversionConfig::validate() const {
  if (units_code < 1 || units_code > 8) {
    return Error{"depth.units_code: " + std::to_string(units_code) + " is not a known Digiquartz unit (1..8)"};
  }
  if (!std::isfinite(latitude_deg) || latitude_deg < -90.0 || latitude_deg > 90.0) {
    return Error{"depth.latitude_deg: " + std::to_string(latitude_deg) + " outside [-90, 90]"};
  }
  if (!std::isfinite(atmospheric_pressure_pa) || atmospheric_pressure_pa < 0.0 || atmospheric_pressure_pa > 2.0e5) {
    return Error{"depth.atmospheric_pressure_pa: " + std::to_string(atmospheric_pressure_pa) + " outside [0, 200000]"};
  }
  return {};
}

codec::DecodeResult<DigiquartzMessage> DigiquartzCodec::decode(std::span<const std::uint8_t> b) const {
  if (b.empty()) return ResultDq::needMore();
  if (b[0] != '*')
    return ResultDq::bad(BadKind::kNoSync, codec::findByte(b, '*', 1), "Digiquartz: no '*' message start");
  const std::size_t lf = codec::findByte(b, '\n');
  if (lf == b.size()) {
    if (b.size() > config_.max_line_bytes)
      return ResultDq::bad(BadKind::kMalformed, 1, "Digiquartz: line longer than limit");
    return ResultDq::needMore();
  }
  const std::size_t consumed = lf + 1;
  std::string_view line = codec::asText(b.first(lf));
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  auto malformed = [&](const std::string& why) {
    return ResultDq::bad(BadKind::kMalformed, consumed, "Digiquartz: " + why + " in " + codec::quoted(line));
  };

  DigiquartzMessage msg;
  if (!parseAddress(line, msg.destination, msg.source)) return malformed("bad address");
  std::string_view body = line.substr(5);
  // "*0100EW*0100UN=2": write enable, then the command it applies to, on one line.
  if (body.substr(0, 2) == "EW" && body.size() > 2) {
    int d2 = 0;
    int s2 = 0;
    if (!parseAddress(body.substr(2), d2, s2) || d2 != msg.destination || s2 != msg.source) {
      return malformed("EW not followed by a command to the same address");
    }
    msg.write_enabled = true;
    body = body.substr(7);
  }
  if (body.find('*') != std::string_view::npos) {
    // Two messages run together: the first was truncated. Restart at the second '*'.
    return ResultDq::bad(BadKind::kMalformed, line.find('*', 1),
                         "Digiquartz: truncated message " + codec::quoted(line));
  }
  msg.body = std::string(body);
  const std::size_t eq = body.find('=');
  if (msg.destination == 0) {  // from a unit to the host
    if (eq == std::string_view::npos) {
      const auto v = codec::parseDouble(body);
      if (!v) return malformed("reply is not a number");
      msg.kind = DigiquartzMessage::Kind::kPressure;
      msg.value = *v;
    } else {
      if (!isCommandWord(body.substr(0, eq))) return malformed("bad parameter name");
      msg.kind = DigiquartzMessage::Kind::kParameter;
      msg.value = codec::parseDouble(body.substr(eq + 1)).value_or(0.0);
    }
  } else {  // from the host to a unit
    if (!isCommandWord(body.substr(0, eq))) return malformed("bad command word");
    msg.kind = DigiquartzMessage::Kind::kCommand;
    if (eq != std::string_view::npos) {
      const auto v = codec::parseDouble(body.substr(eq + 1));
      if (!v) return malformed("command value is not a number");
      msg.value = *v;
    }
  }
  return ResultDq::decoded(std::move(msg), consumed);
}

namespace {
std::string address(int destination, int source) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "*%02d%02d", ((destination % 100) + 100) % 100, ((source % 100) + 100) % 100);
  return buf;
}
}  // namespace

std::string encodeCommand(int destination, int source, const std::string& command) {
  return address(destination, source) + command + "\r\n";
}

std::string encodePressureReply(int destination, int source, double value, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals < 0 ? 0 : (decimals > 9 ? 9 : decimals), value);
  return address(destination, source) + buf + "\r\n";
}

std::string encodeParameterReply(int destination, int source, const std::string& name, const std::string& value) {
  return address(destination, source) + name + "=" + value + "\r\n";
}

Result<DepthSample> toDepthSample(const DigiquartzMessage& message, const DepthConversionConfig& config,
                                  std::int64_t stamp_ns) {
  if (auto st = config.validate(); !st.ok()) return st.error();
  if (message.kind != DigiquartzMessage::Kind::kPressure) {
    return Error{"Digiquartz message " + codec::quoted(message.body) + " is not a pressure reading"};
  }
  if (!std::isfinite(message.value)) return Error{"Digiquartz pressure is not finite"};
  const auto unit = pressureUnitFromCode(config.units_code);
  if (!unit.ok()) return unit.error();
  const auto pa_per_unit = pascalsPerUnit(*unit);
  if (!pa_per_unit.ok()) return pa_per_unit.error();
  DepthSample sample;
  sample.stamp_ns = stamp_ns;
  const double reading_pa = message.value * *pa_per_unit;
  sample.absolute_pressure_pa = config.reading_is_absolute ? reading_pa : reading_pa + config.atmospheric_pressure_pa;
  sample.sea_pressure_pa = sample.absolute_pressure_pa - config.atmospheric_pressure_pa;
  sample.depth_m = unescoDepth_m(sample.sea_pressure_pa * 1e-4, config.latitude_deg);  // Pa -> dbar
  return sample;
}

}  // namespace vog::depth
