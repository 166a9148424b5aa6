#include "vog/sonar/aris_command.hpp"

#include "aris_protobuf.hpp"
#include "vog/sonar/aris_commands.pb.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <utility>

namespace vog::sonar {
namespace {

using detail::parsed;

constexpr std::size_t kLengthPrefixBytes = 4;

constexpr std::array<std::string_view, kArisCommandRefusalCount> kCommandRefusalNames = {
    "length_out_of_bounds",
    "undecodable",
    "unsupported_type",
    "payload_missing",
    "field_missing",
    "date_time_invalid",
    "receiver_address_invalid",
    "receiver_port_invalid",
    "interpacket_delay_out_of_range",
    "frame_rate_out_of_range",
    "samples_per_beam_out_of_range",
    "sample_start_delay_out_of_range",
    "sample_period_out_of_range",
    "cycle_period_out_of_range",
    "pulse_width_out_of_range",
    "ping_mode_unknown",
    "receiver_gain_out_of_range",
    "focus_range_out_of_range"};

constexpr std::array<std::string_view, 12> kMonths = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                                      "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};

// Our bound (the SDK gives none): at 10 ms per packet a frame of 100 packets already takes 1 s.
constexpr std::uint32_t kInterpacketDelayMaxUs = 10000;

// ARIS Integration SDK, common/platform-dotnet/SoundMetrics.Aris.Core, SystemConfiguration (per
// model: ping modes, window start/end, sample start delay, sample period, cycle period, pulse width
// limits and multiplier per frequency, cumulative pulse per second).
constexpr std::array<ArisModelLimits, 3> kModels = {{
    {"ARIS 1800", {1, 3}, 0.7, 25.0, 1.3, 50.0, 930, 36000, 4, 20, 1802, 80000, {6, 24, 1.5}, {6, 40, 1.0}, 300},
    {"ARIS 3000", {6, 9}, 0.7, 12.0, 1.3, 20.0, 930, 18000, 4, 12, 1802, 40000, {6, 16, 2.0}, {6, 24, 1.5}, 240},
    {"ARIS 1200", {1, 1}, 0.7, 40.0, 1.3, 100.0, 930, 60000, 4, 40, 1802, 150000, {8, 60, 1.0}, {8, 80, 1.0}, 400},
}};

// A value for an error detail: integers exactly (a uint32 field is never rounded), others in %g.
std::string num(double v) {
  char buf[32];
  if (std::isfinite(v) && v == std::trunc(v) && std::fabs(v) < 1e15) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  } else {
    std::snprintf(buf, sizeof buf, "%g", v);
  }
  return buf;
}

// Text from the wire for an error detail: at most 32 bytes, anything unprintable as '?'.
std::string printable(std::string_view text) {
  std::string out(text.substr(0, 32));
  for (char& ch : out) {
    if (ch < 0x20 || ch > 0x7E) ch = '?';
  }
  return out;
}

std::string range(double lo, double hi) {
  std::string out = "[";  // appended, not `"[" + ...`: GCC 12 warns falsely (-Wrestrict) on that
  out += num(lo);
  out += ", ";
  out += num(hi);
  out += ']';
  return out;
}

bool within(double v, double lo, double hi) { return v >= lo && v <= hi; }  // false for NaN

bool isModelPingMode(const ArisModelLimits& m, std::uint32_t mode) {
  return std::find(m.ping_modes.begin(), m.ping_modes.end(), mode) != m.ping_modes.end();
}

std::string modelPingModes(const ArisModelLimits& m) {
  return m.ping_modes[0] == m.ping_modes[1] ? std::to_string(m.ping_modes[0])
                                            : std::to_string(m.ping_modes[0]) + ", " + std::to_string(m.ping_modes[1]);
}

// Days in `month` (1-12) of `year` (proleptic Gregorian).
int daysInMonth(int year, int month) {
  constexpr std::array<int, 12> kDays = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
  return month == 2 && leap ? 29 : kDays[static_cast<std::size_t>(month - 1)];
}

// The whole of `text` as a decimal number of exactly `digits` digits (no sign).
std::optional<int> fixedNumber(std::string_view text, std::size_t digits) {
  if (text.size() != digits || digits > 4) return std::nullopt;
  int v = 0;
  for (const char ch : text) {
    if (ch < '0' || ch > '9') return std::nullopt;
    v = v * 10 + (ch - '0');
  }
  return v;
}

// "YYYY-Mon-DD HH:MM:SS", a real calendar date.
bool isArisDateTime(std::string_view t) {
  if (t.size() != 20 || t[4] != '-' || t[8] != '-' || t[11] != ' ' || t[14] != ':' || t[17] != ':') return false;
  const auto year = fixedNumber(t.substr(0, 4), 4);
  const auto month = std::find(kMonths.begin(), kMonths.end(), t.substr(5, 3));
  const auto day = fixedNumber(t.substr(9, 2), 2);
  const auto hour = fixedNumber(t.substr(12, 2), 2);
  const auto minute = fixedNumber(t.substr(15, 2), 2);
  const auto second = fixedNumber(t.substr(18, 2), 2);
  if (!year || month == kMonths.end() || !day || !hour || !minute || !second) return false;
  const int m = static_cast<int>(month - kMonths.begin()) + 1;
  return *day >= 1 && *day <= daysInMonth(*year, m) && *hour <= 23 && *minute <= 59 && *second <= 59;
}

// Dotted IPv4: four decimal parts 0-255, no leading zero.
bool isIpv4(std::string_view ip) {
  for (int part = 0; part < 4; ++part) {
    const std::size_t dot = ip.find('.');
    const std::string_view digits = ip.substr(0, dot);
    if (digits.empty() || (digits.size() > 1 && digits[0] == '0')) return false;
    const auto v = fixedNumber(digits, digits.size());
    if (!v || *v > 255) return false;
    if ((dot == std::string_view::npos) != (part == 3)) return false;  // exactly three dots
    if (dot != std::string_view::npos) ip.remove_prefix(dot + 1);
  }
  return true;
}

// The wire names of ArisCommand's alternatives, in their order.
constexpr std::array<std::string_view, std::variant_size_v<ArisCommand>> kCommandNames = {"SET_DATETIME",
                                                                                          "SET_FRAMESTREAM_RECEIVER",
                                                                                          "SET_FRAMESTREAM_SETTINGS",
                                                                                          "SET_ACOUSTICS",
                                                                                          "SET_SALINITY",
                                                                                          "SET_FOCUS",
                                                                                          "PING"};

void fill(aris::Command& msg, const ArisSetDateTime& c) {
  msg.set_type(aris::Command::SET_DATETIME);
  msg.mutable_datetime()->set_datetime(c.date_time);
}

void fill(aris::Command& msg, const ArisSetFrameStreamReceiver& c) {
  msg.set_type(aris::Command::SET_FRAMESTREAM_RECEIVER);
  auto* p = msg.mutable_framestreamreceiver();
  p->set_port(c.port);
  p->set_ip(c.ip);
}

void fill(aris::Command& msg, const ArisSetFrameStreamSettings& c) {
  msg.set_type(aris::Command::SET_FRAMESTREAM_SETTINGS);
  auto* p = msg.mutable_framestreamsettings();
  p->mutable_interpacketdelay()->set_enable(c.interpacket_delay_enable);
  p->mutable_interpacketdelay()->set_delayperiod(c.interpacket_delay_us);
  p->set_packetlossmitigation(
      static_cast<aris::Command::SetFrameStreamSettings::PacketLossMitigation>(c.packet_loss_mitigation));
}

void fill(aris::Command& msg, const ArisAcousticSettings& c) {
  msg.set_type(aris::Command::SET_ACOUSTICS);
  auto* p = msg.mutable_settings();
  p->set_cookie(c.cookie);
  p->set_framerate(c.frame_rate_hz);
  p->set_samplesperbeam(c.samples_per_beam);
  p->set_samplestartdelay(c.sample_start_delay_us);
  p->set_cycleperiod(c.cycle_period_us);
  p->set_sampleperiod(c.sample_period_us);
  p->set_pulsewidth(c.pulse_width_us);
  p->set_pingmode(c.ping_mode);
  p->set_enabletransmit(c.enable_transmit);
  p->set_frequency(static_cast<aris::Command::SetAcousticSettings::Frequency>(c.frequency));
  p->set_enable150volts(c.enable_150_volts);
  p->set_receivergain(c.receiver_gain_db);
}

void fill(aris::Command& msg, const ArisSetSalinity& c) {
  msg.set_type(aris::Command::SET_SALINITY);
  msg.mutable_salinity()->set_salinity(static_cast<aris::Command::SetSalinity::Salinity>(c.salinity));
}

void fill(aris::Command& msg, const ArisSetFocus& c) {
  msg.set_type(aris::Command::SET_FOCUS);
  msg.mutable_focusposition()->set_focusrange(c.focus_range_m);
}

void fill(aris::Command& msg, const ArisPing&) {
  msg.set_type(aris::Command::PING);
  msg.mutable_ping();
}

// The command a decoded message holds, or the name of the first field missing from its payload.
using FromWire = std::variant<ArisCommand, std::string_view>;

FromWire fromWire(const aris::Command::SetDateTime& p) {
  if (!p.has_datetime()) return std::string_view("dateTime");
  return ArisSetDateTime{p.datetime()};
}

FromWire fromWire(const aris::Command::SetFrameStreamReceiver& p) {
  if (!p.has_port()) return std::string_view("port");
  if (!p.has_ip()) return std::string_view("ip");
  return ArisSetFrameStreamReceiver{p.ip(), p.port()};
}

FromWire fromWire(const aris::Command::SetFrameStreamSettings& p) {
  if (!p.has_packetlossmitigation()) return std::string_view("packetLossMitigation");
  if (!p.has_interpacketdelay()) return std::string_view("interpacketDelay");
  if (!p.interpacketdelay().has_enable()) return std::string_view("interpacketDelay.enable");
  if (!p.interpacketdelay().has_delayperiod()) return std::string_view("interpacketDelay.delayPeriod");
  return ArisSetFrameStreamSettings{static_cast<ArisPacketLossMitigation>(p.packetlossmitigation()),
                                    p.interpacketdelay().enable(), p.interpacketdelay().delayperiod()};
}

FromWire fromWire(const aris::Command::SetAcousticSettings& p) {
  // In field-number order, so the first missing one is reported.
  const std::array<std::pair<bool, std::string_view>, 12> fields = {{{p.has_cookie(), "cookie"},
                                                                     {p.has_framerate(), "frameRate"},
                                                                     {p.has_samplesperbeam(), "samplesPerBeam"},
                                                                     {p.has_samplestartdelay(), "sampleStartDelay"},
                                                                     {p.has_cycleperiod(), "cyclePeriod"},
                                                                     {p.has_sampleperiod(), "samplePeriod"},
                                                                     {p.has_pulsewidth(), "pulseWidth"},
                                                                     {p.has_pingmode(), "pingMode"},
                                                                     {p.has_enabletransmit(), "enableTransmit"},
                                                                     {p.has_frequency(), "frequency"},
                                                                     {p.has_enable150volts(), "enable150Volts"},
                                                                     {p.has_receivergain(), "receiverGain"}}};
  for (const auto& [present, name] : fields) {
    if (!present) return name;
  }
  return ArisAcousticSettings{.cookie = p.cookie(),
                              .frame_rate_hz = p.framerate(),
                              .samples_per_beam = p.samplesperbeam(),
                              .sample_start_delay_us = p.samplestartdelay(),
                              .cycle_period_us = p.cycleperiod(),
                              .sample_period_us = p.sampleperiod(),
                              .pulse_width_us = p.pulsewidth(),
                              .ping_mode = p.pingmode(),
                              .enable_transmit = p.enabletransmit(),
                              .frequency = static_cast<ArisFrequency>(p.frequency()),
                              .enable_150_volts = p.enable150volts(),
                              .receiver_gain_db = p.receivergain()};
}

FromWire fromWire(const aris::Command::SetSalinity& p) {
  if (!p.has_salinity()) return std::string_view("salinity");
  return ArisSetSalinity{static_cast<ArisSalinity>(p.salinity())};
}

FromWire fromWire(const aris::Command::SetFocusPosition& p) {
  if (!p.has_focusrange()) return std::string_view("focusRange");
  return ArisSetFocus{p.focusrange()};
}

std::optional<ArisCommandCheck> check(const ArisSetDateTime& c, const ArisModelLimits&) {
  if (!isArisDateTime(c.date_time)) {
    return ArisCommandCheck{ArisCommandRefusal::kDateTimeInvalid,
                            "dateTime \"" + printable(c.date_time) + "\", not YYYY-Mon-DD HH:MM:SS"};
  }
  return std::nullopt;
}

std::optional<ArisCommandCheck> check(const ArisSetFrameStreamReceiver& c, const ArisModelLimits&) {
  if (!isIpv4(c.ip)) {
    return ArisCommandCheck{ArisCommandRefusal::kReceiverAddressInvalid,
                            "ip \"" + printable(c.ip) + "\", not a dotted IPv4 address"};
  }
  if (c.port < 1 || c.port > 65535) {
    return ArisCommandCheck{ArisCommandRefusal::kReceiverPortInvalid,
                            "port " + std::to_string(c.port) + ", must be in [1, 65535]"};
  }
  return std::nullopt;
}

std::optional<ArisCommandCheck> check(const ArisSetFrameStreamSettings& c, const ArisModelLimits&) {
  if (c.interpacket_delay_us > kInterpacketDelayMaxUs) {
    return ArisCommandCheck{ArisCommandRefusal::kInterpacketDelayOutOfRange,
                            "interpacketDelay.delayPeriod " + std::to_string(c.interpacket_delay_us) +
                                " us, must be at most " + std::to_string(kInterpacketDelayMaxUs)};
  }
  return std::nullopt;
}

std::optional<ArisCommandCheck> check(const ArisAcousticSettings& c, const ArisModelLimits& m) {
  using R = ArisCommandRefusal;
  const auto out = [&](R reason, std::string_view field, double value, double lo, double hi, std::string_view unit) {
    return ArisCommandCheck{reason, std::string(field) + " " + num(value) + std::string(unit) + ", the " +
                                        std::string(m.name) + " takes " + range(lo, hi)};
  };
  if (!isModelPingMode(m, c.ping_mode)) {
    return ArisCommandCheck{R::kPingModeUnknown, "pingMode " + std::to_string(c.ping_mode) + ", the " +
                                                     std::string(m.name) + " has " + modelPingModes(m)};
  }
  if (!within(static_cast<double>(c.frame_rate_hz), kArisFrameRateMinHz, kArisFrameRateMaxHz)) {
    return out(R::kFrameRateOutOfRange, "frameRate", static_cast<double>(c.frame_rate_hz), kArisFrameRateMinHz,
               kArisFrameRateMaxHz, " /s");
  }
  if (!within(c.samples_per_beam, kArisSamplesPerBeamMin, kArisSamplesPerBeamMax)) {
    return out(R::kSamplesPerBeamOutOfRange, "samplesPerBeam", c.samples_per_beam, kArisSamplesPerBeamMin,
               kArisSamplesPerBeamMax, "");
  }
  if (!within(c.sample_start_delay_us, m.sample_start_delay_min_us, m.sample_start_delay_max_us)) {
    return out(R::kSampleStartDelayOutOfRange, "sampleStartDelay", c.sample_start_delay_us, m.sample_start_delay_min_us,
               m.sample_start_delay_max_us, " us");
  }
  if (!within(c.sample_period_us, m.sample_period_min_us, m.sample_period_max_us)) {
    return out(R::kSamplePeriodOutOfRange, "samplePeriod", c.sample_period_us, m.sample_period_min_us,
               m.sample_period_max_us, " us");
  }
  if (!within(c.cycle_period_us, m.cycle_period_min_us, m.cycle_period_max_us)) {
    return out(R::kCyclePeriodOutOfRange, "cyclePeriod", c.cycle_period_us, m.cycle_period_min_us,
               m.cycle_period_max_us, " us");
  }
  // A ping's cycle must hold its sampling: the delay, then every sample.
  const std::uint64_t sampling_us =
      c.sample_start_delay_us + static_cast<std::uint64_t>(c.samples_per_beam) * c.sample_period_us;
  if (c.cycle_period_us < sampling_us) {
    return ArisCommandCheck{R::kCyclePeriodOutOfRange, "cyclePeriod " + std::to_string(c.cycle_period_us) +
                                                           " us, shorter than the " + std::to_string(sampling_us) +
                                                           " us of sampleStartDelay + samplesPerBeam x samplePeriod"};
  }
  const auto& pw = c.frequency == ArisFrequency::kLow ? m.pulse_low : m.pulse_high;
  if (!within(c.pulse_width_us, pw.min_us, pw.max_us)) {
    return out(R::kPulseWidthOutOfRange,
               c.frequency == ArisFrequency::kLow ? "pulseWidth (low frequency)" : "pulseWidth (high frequency)",
               c.pulse_width_us, pw.min_us, pw.max_us, " us");
  }
  if (!within(static_cast<double>(c.receiver_gain_db), 0.0, kArisReceiverGainMaxDb)) {
    return out(R::kReceiverGainOutOfRange, "receiverGain", static_cast<double>(c.receiver_gain_db), 0.0,
               kArisReceiverGainMaxDb, " dB");
  }
  return std::nullopt;
}

std::optional<ArisCommandCheck> check(const ArisSetSalinity&, const ArisModelLimits&) {
  return std::nullopt;  // the decoder keeps only the enum's values
}

std::optional<ArisCommandCheck> check(const ArisSetFocus& c, const ArisModelLimits& m) {
  if (!within(static_cast<double>(c.focus_range_m), 0.0, m.window_end_max_m)) {
    return ArisCommandCheck{ArisCommandRefusal::kFocusRangeOutOfRange,
                            "focusRange " + num(static_cast<double>(c.focus_range_m)) + " m, the " +
                                std::string(m.name) + " focuses in " + range(0.0, m.window_end_max_m) + " m"};
  }
  return std::nullopt;
}

std::optional<ArisCommandCheck> check(const ArisPing&, const ArisModelLimits&) { return std::nullopt; }

}  // namespace

// ---- Commands ----

std::string_view arisCommandName(const ArisCommand& command) { return kCommandNames[command.index()]; }

std::vector<std::uint8_t> encodeArisCommand(const ArisCommand& command) {
  aris::Command msg;
  std::visit([&](const auto& c) { fill(msg, c); }, command);
  std::vector<std::uint8_t> out = detail::serialized(msg, kLengthPrefixBytes);
  const std::size_t n = out.size() - kLengthPrefixBytes;
  assert(n <= UINT32_MAX);  // a command is tens of bytes; only a string of gigabytes could break this
  for (std::size_t i = 0; i < kLengthPrefixBytes; ++i) {
    out[i] = static_cast<std::uint8_t>(n >> (8 * (kLengthPrefixBytes - 1 - i)));
  }
  return out;
}

std::string arisDateTimeText(std::int64_t unix_time_s) {
  // Civil date from days since 1970-01-01 (H. Hinnant, "chrono-Compatible Low-Level Date Algorithms",
  // days_from_civil's inverse).
  const std::int64_t days = unix_time_s >= 0 ? unix_time_s / 86400 : (unix_time_s - 86399) / 86400;
  const std::int64_t secs = unix_time_s - days * 86400;
  const std::int64_t z = days + 719468;
  const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const std::int64_t doe = z - era * 146097;
  const std::int64_t yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const std::int64_t doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const std::int64_t mp = (5 * doy + 2) / 153;
  const std::int64_t day = doy - (153 * mp + 2) / 5 + 1;
  const std::int64_t month = mp < 10 ? mp + 3 : mp - 9;
  const std::int64_t year = yoe + era * 400 + (month <= 2 ? 1 : 0);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04lld-%s-%02d %02d:%02d:%02d", static_cast<long long>(year),
                kMonths[static_cast<std::size_t>(month - 1)].data(), static_cast<int>(day),
                static_cast<int>(secs / 3600), static_cast<int>(secs / 60 % 60), static_cast<int>(secs % 60));
  return buf;
}

// ---- Sonar side ----

std::string_view arisCommandRefusalName(ArisCommandRefusal reason) {
  return kCommandRefusalNames[static_cast<std::size_t>(reason)];
}

bool arisCommandRefusalClosesStream(ArisCommandRefusal reason) {
  return reason == ArisCommandRefusal::kLengthOutOfBounds;
}

std::uint64_t ArisCommandDecoderStats::refusedTotal() const {
  return std::accumulate(refused.begin(), refused.end(), std::uint64_t{0});
}

Status ArisCommandDecoderConfig::validate() const {
  if (max_message_bytes < 16 || max_message_bytes > (std::size_t{16} << 20)) {
    return Error{"max_message_bytes: " + std::to_string(max_message_bytes) + ", must be in [16, 16777216]"};
  }
  return {};
}

ArisCommandDecoder::ArisCommandDecoder(ArisCommandDecoderConfig config) : config_(config) {
  assert(config_.validate().ok());
}

ArisDecodedCommand ArisCommandDecoder::refuse(ArisCommandRefusal reason, std::string detail) {
  ++stats_.refused[static_cast<std::size_t>(reason)];
  ArisDecodedCommand r;
  r.refusal = reason;
  r.refusal_detail = std::move(detail);
  return r;
}

ArisDecodedCommand ArisCommandDecoder::decodeMessage(std::span<const std::uint8_t> message) {
  ++stats_.messages;
  aris::Command msg;
  if (!parsed(msg, message)) {
    return refuse(ArisCommandRefusal::kUndecodable, "message of " + std::to_string(message.size()) +
                                                        " bytes is not an aris.Command (or its type is missing)");
  }
  const auto missing = [&](const char* payload) {
    return refuse(ArisCommandRefusal::kPayloadMissing,
                  aris::Command::CommandType_Name(msg.type()) + " without its " + payload + " payload");
  };
  FromWire decoded = std::string_view();
  switch (msg.type()) {
    case aris::Command::SET_DATETIME:
      if (!msg.has_datetime()) return missing("dateTime");
      decoded = fromWire(msg.datetime());
      break;
    case aris::Command::SET_FRAMESTREAM_RECEIVER:
      if (!msg.has_framestreamreceiver()) return missing("frameStreamReceiver");
      decoded = fromWire(msg.framestreamreceiver());
      break;
    case aris::Command::SET_FRAMESTREAM_SETTINGS:
      if (!msg.has_framestreamsettings()) return missing("frameStreamSettings");
      decoded = fromWire(msg.framestreamsettings());
      break;
    case aris::Command::SET_ACOUSTICS:
      if (!msg.has_settings()) return missing("settings");
      decoded = fromWire(msg.settings());
      break;
    case aris::Command::SET_SALINITY:
      if (!msg.has_salinity()) return missing("salinity");
      decoded = fromWire(msg.salinity());
      break;
    case aris::Command::SET_FOCUS:
      if (!msg.has_focusposition()) return missing("focusPosition");
      decoded = fromWire(msg.focusposition());
      break;
    case aris::Command::PING:
      // The keep-alive carries nothing; a sonar takes it with or without its empty payload.
      decoded = ArisCommand{ArisPing{}};
      break;
    default:
      return refuse(ArisCommandRefusal::kUnsupportedType,
                    "command type " + aris::Command::CommandType_Name(msg.type()) + " is not carried out");
  }
  if (const auto* field = std::get_if<std::string_view>(&decoded)) {
    return refuse(ArisCommandRefusal::kFieldMissing,
                  aris::Command::CommandType_Name(msg.type()) + " without its field " + std::string(*field));
  }
  ++stats_.commands;
  ArisDecodedCommand r;
  r.command = std::move(std::get<ArisCommand>(decoded));
  return r;
}

std::vector<ArisDecodedCommand> ArisCommandDecoder::feed(std::span<const std::uint8_t> bytes) {
  stats_.bytes += bytes.size();
  std::vector<ArisDecodedCommand> out;
  if (closed_) return out;
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
  std::size_t pos = 0;
  while (buffer_.size() - pos >= kLengthPrefixBytes) {
    std::uint64_t length = 0;
    for (std::size_t i = 0; i < kLengthPrefixBytes; ++i) length = (length << 8) | buffer_[pos + i];
    if (length > config_.max_message_bytes) {
      out.push_back(refuse(ArisCommandRefusal::kLengthOutOfBounds,
                           "length prefix " + std::to_string(length) + " above max_message_bytes " +
                               std::to_string(config_.max_message_bytes) + ": the stream is out of step"));
      closed_ = true;
      buffer_.clear();
      return out;
    }
    if (buffer_.size() - pos - kLengthPrefixBytes < length) break;
    out.push_back(decodeMessage(std::span(buffer_).subspan(pos + kLengthPrefixBytes, length)));
    pos += kLengthPrefixBytes + length;
  }
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(pos));
  return out;
}

std::optional<ArisCommandCheck> validateArisCommand(const ArisCommand& command, ArisSystemType model) {
  const ArisModelLimits& m = arisModelLimits(model);
  return std::visit([&](const auto& c) { return check(c, m); }, command);
}

// ---- Acoustic settings ----

const ArisModelLimits& arisModelLimits(ArisSystemType model) {
  const auto i = static_cast<std::size_t>(model);
  assert(i < kModels.size());
  return kModels[i];
}

Result<int> arisPingsPerFrame(std::uint32_t ping_mode) {
  // ARIS Integration SDK, SoundMetrics.Aris.Core/PingMode.cs.
  switch (ping_mode) {
    case 1: return 3;
    case 3: return 6;
    case 6: return 4;
    case 9: return 8;
    default: return Error{"PingMode " + std::to_string(ping_mode) + ": not an ARIS ping mode (1, 3, 6, 9)"};
  }
}

Status ArisSonarConfig::validate() const {
  if (static_cast<std::size_t>(model) >= kModels.size()) {
    return Error{"model: " + std::to_string(static_cast<int>(model)) + ", must be 0 (1800), 1 (3000) or 2 (1200)"};
  }
  const ArisModelLimits& m = arisModelLimits(model);
  const std::string of_model = "the " + std::string(m.name) + "'s ";
  if (!within(sound_speed_mps, 1400.0, 1600.0)) {
    return Error{"sound_speed_mps: " + num(sound_speed_mps) + ", must be in [1400, 1600]"};
  }
  if (!within(window_start_m, m.window_start_min_m, m.window_start_max_m)) {
    return Error{"window_start_m: " + num(window_start_m) + ", outside " + of_model +
                 range(m.window_start_min_m, m.window_start_max_m) + " m"};
  }
  if (!within(window_end_m, m.window_end_min_m, m.window_end_max_m)) {
    return Error{"window_end_m: " + num(window_end_m) + ", outside " + of_model +
                 range(m.window_end_min_m, m.window_end_max_m) + " m"};
  }
  if (!(window_end_m > window_start_m)) {
    return Error{"window_end_m: " + num(window_end_m) + ", must be beyond window_start_m " + num(window_start_m)};
  }
  if (!isModelPingMode(m, ping_mode)) {
    return Error{"ping_mode: " + std::to_string(ping_mode) + ", " + of_model + "are " + modelPingModes(m)};
  }
  if (!within(frame_rate_hz, kArisFrameRateMinHz, kArisFrameRateMaxHz)) {
    return Error{"frame_rate_hz: " + num(frame_rate_hz) + ", must be in " +
                 range(kArisFrameRateMinHz, kArisFrameRateMaxHz)};
  }
  if (salinity != ArisSalinity::kFresh && salinity != ArisSalinity::kBrackish && salinity != ArisSalinity::kSaltwater) {
    return Error{"salinity: " + std::to_string(static_cast<int>(salinity)) + ", must be 0, 15 or 35"};
  }
  if (frequency != ArisFrequency::kLow && frequency != ArisFrequency::kHigh) {
    return Error{"frequency: " + std::to_string(static_cast<int>(frequency)) + ", must be 0 (low) or 1 (high)"};
  }
  if ((samples_per_beam == 0) == (range_resolution_m == 0.0)) {
    return Error{"samples_per_beam: " + std::to_string(samples_per_beam) +
                 ", range_resolution_m: " + num(range_resolution_m) + ", exactly one must be non-zero"};
  }
  if (samples_per_beam != 0 && !within(samples_per_beam, kArisSamplesPerBeamMin, kArisSamplesPerBeamMax)) {
    return Error{"samples_per_beam: " + std::to_string(samples_per_beam) + ", must be in " +
                 range(kArisSamplesPerBeamMin, kArisSamplesPerBeamMax)};
  }
  if (samples_per_beam == 0 && !within(range_resolution_m, 1e-4, 1.0)) {
    return Error{"range_resolution_m: " + num(range_resolution_m) + ", must be in [0.0001, 1]"};
  }
  if (!within(receiver_gain_db, 0.0, kArisReceiverGainMaxDb)) {
    return Error{"receiver_gain_db: " + num(receiver_gain_db) + ", must be in " + range(0.0, kArisReceiverGainMaxDb)};
  }
  return {};
}

Result<ArisDerivedSettings> deriveArisAcousticSettings(const ArisSonarConfig& config) {
  if (const Status st = config.validate(); !st.ok()) return st.error();
  const ArisModelLimits& m = arisModelLimits(config.model);
  const std::string of_model = "the " + std::string(m.name) + "'s ";
  // Range per microsecond of two-way travel (ARIS File SDK, "range of a sample": t x c / 2).
  const double m_per_us = config.sound_speed_mps * 1e-6 / 2.0;

  const double delay_us = std::round(config.window_start_m / m_per_us);
  if (!within(delay_us, m.sample_start_delay_min_us, m.sample_start_delay_max_us)) {
    return Error{"window_start_m: " + num(config.window_start_m) + " at " + num(config.sound_speed_mps) +
                 " m/s is a sample start delay of " + num(delay_us) + " us, outside " + of_model +
                 range(m.sample_start_delay_min_us, m.sample_start_delay_max_us) + " us"};
  }
  const double start_m = delay_us * m_per_us;
  const double length_m = config.window_end_m - start_m;  // from the achieved start: the end is covered

  // The fewest samples of `period_us` that reach the window end; the tolerance keeps an exact fit
  // from gaining a sample through rounding.
  const auto samples_for = [&](double period_us) { return std::ceil(length_m / (period_us * m_per_us) - 1e-9); };
  const double wanted_us = config.samples_per_beam != 0 ? length_m / (config.samples_per_beam * m_per_us)
                                                        : config.range_resolution_m / m_per_us;
  double period_us = std::clamp(std::round(wanted_us), double(m.sample_period_min_us), double(m.sample_period_max_us));
  double samples = samples_for(period_us);
  if (samples > kArisSamplesPerBeamMax) {
    period_us = std::ceil(length_m / (kArisSamplesPerBeamMax * m_per_us) - 1e-9);
    if (period_us > m.sample_period_max_us) {
      return Error{"window_end_m: " + num(config.window_end_m) + " needs a sample period of " + num(period_us) +
                   " us for 4000 samples, above " + of_model + num(m.sample_period_max_us) + " us"};
    }
    samples = samples_for(period_us);
  } else if (samples < kArisSamplesPerBeamMin) {
    period_us = std::max(double(m.sample_period_min_us), std::floor(length_m / (kArisSamplesPerBeamMin * m_per_us)));
    samples = std::max(double(kArisSamplesPerBeamMin), samples_for(period_us));
  }

  // Cycle period: the sampling plus the SDK's margin (MaxFrameRate: ssd + sp x spb + margin).
  const double cycle_us =
      std::max(double(m.cycle_period_min_us), delay_us + samples * period_us + kArisCyclePeriodMarginUs);
  if (cycle_us > m.cycle_period_max_us) {
    return Error{"window_end_m: " + num(config.window_end_m) + " needs a cycle period of " + num(cycle_us) +
                 " us, above " + of_model + num(m.cycle_period_max_us) + " us"};
  }
  // The SDK's maximum frame rate (common/code/FrameRate/FrameRate.cpp): each ping takes the cycle
  // period plus time that grows with the samples (1400 us per 2000 samples, three times as steep
  // above 2000) and at the shortest sample periods (3000 us / period below 7 us, 400 us more at 4 us).
  double extra_us = samples <= 2000 ? 1400.0 * samples / 2000 : 1400.0 + 2 * 1400.0 * (samples - 2000) / 2000;
  if (period_us < 7) extra_us += 3000.0 / period_us;
  if (period_us == 4) extra_us += 400.0;
  const double ping_us = std::min(double(m.cycle_period_max_us), cycle_us + extra_us);
  const int pings = *arisPingsPerFrame(config.ping_mode);  // a ping mode of the model: validated
  const double max_rate_hz = std::min(kArisFrameRateMaxHz, 1e6 / (ping_us * pings));
  if (config.frame_rate_hz > max_rate_hz) {
    return Error{"frame_rate_hz: " + num(config.frame_rate_hz) + ", above the " + num(max_rate_hz) +
                 " frames/s that ping mode " + std::to_string(config.ping_mode) + " with " + num(samples) +
                 " samples of " + num(period_us) + " us allows"};
  }

  const double end_m = start_m + samples * period_us * m_per_us;
  // Pulse width: the SDK's automatic rule (ARIScope 2), multiplier x window end in m, within the
  // frequency's limits, then capped so that pulse width x frame rate stays within the energy limit.
  const auto& pw = config.frequency == ArisFrequency::kLow ? m.pulse_low : m.pulse_high;
  const double pulse_us = std::min(std::clamp(std::round(pw.us_per_m * end_m), double(pw.min_us), double(pw.max_us)),
                                   std::floor(m.max_pulse_us_per_s / config.frame_rate_hz));

  ArisDerivedSettings d;
  d.acoustic = ArisAcousticSettings{.cookie = 0,
                                    .frame_rate_hz = static_cast<float>(config.frame_rate_hz),
                                    .samples_per_beam = static_cast<std::uint32_t>(samples),
                                    .sample_start_delay_us = static_cast<std::uint32_t>(delay_us),
                                    .cycle_period_us = static_cast<std::uint32_t>(cycle_us),
                                    .sample_period_us = static_cast<std::uint32_t>(period_us),
                                    .pulse_width_us = static_cast<std::uint32_t>(pulse_us),
                                    .ping_mode = config.ping_mode,
                                    .enable_transmit = config.enable_transmit,
                                    .frequency = config.frequency,
                                    .enable_150_volts = config.enable_150_volts,
                                    .receiver_gain_db = static_cast<float>(config.receiver_gain_db)};
  d.salinity = ArisSetSalinity{config.salinity};
  d.focus = ArisSetFocus{static_cast<float>((start_m + end_m) / 2)};
  d.window_start_m = start_m;
  d.window_end_m = end_m;
  d.sample_length_m = period_us * m_per_us;
  d.max_frame_rate_hz = max_rate_hz;
  return d;
}

void ArisSettingsCookies::stamp(ArisAcousticSettings& settings) {
  settings.cookie = last_.cookie;
  if (last_.cookie != 0 && settings == last_) return;
  settings.cookie = next_;
  next_ = next_ == UINT32_MAX ? 1 : next_ + 1;
  last_ = settings;
}

std::uint32_t arisFirstCookie(std::int64_t unix_time_s) {
  constexpr std::int64_t kSpan = (std::int64_t{1} << 31) - 1;
  const std::int64_t folded = unix_time_s % kSpan;
  return static_cast<std::uint32_t>((folded < 0 ? folded + kSpan : folded) + 1);
}

std::vector<ArisCommand> arisConnectCommands(const ArisDerivedSettings& settings,
                                             const ArisSetFrameStreamSettings& stream,
                                             const ArisSetFrameStreamReceiver& receiver, std::int64_t unix_time_s) {
  return {ArisSetDateTime{arisDateTimeText(unix_time_s)},
          stream,
          settings.salinity,
          settings.acoustic,
          settings.focus,
          receiver};
}

}  // namespace vog::sonar
