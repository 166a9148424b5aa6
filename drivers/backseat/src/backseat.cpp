#include "vog/backseat/backseat.hpp"

#include "vog/codec/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace vog::backseat {
namespace {

using codec::BadKind;
using ResultBs = codec::DecodeResult<BackseatSentence>;

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// "hhmmss.ss" -> seconds since midnight.
std::optional<TimeOfDay> parseTime(std::string_view s) {
  if (s.size() < 6) return std::nullopt;
  const auto hh = codec::parseInt(s.substr(0, 2));
  const auto mm = codec::parseInt(s.substr(2, 2));
  const auto ss = codec::parseDouble(s.substr(4));
  if (!hh || !mm || !ss || *hh < 0 || *hh > 23 || *mm < 0 || *mm > 59 || *ss < 0.0 || *ss >= 61.0 || s[0] == '+' ||
      s[2] == '+' || s[4] == '+' || s[4] == '-') {
    return std::nullopt;
  }
  return TimeOfDay{static_cast<double>(*hh * 3600 + *mm * 60) + *ss};
}

// "ddmm.mmmm" + hemisphere -> signed degrees; `degree_digits` is 2 for latitude, 3 for longitude.
std::optional<double> parseAngle(std::string_view value, std::string_view hemisphere, std::size_t degree_digits,
                                 double limit) {
  if (value.size() < degree_digits + 2 || hemisphere.size() != 1) return std::nullopt;
  const auto deg = codec::parseInt(value.substr(0, degree_digits));
  const auto min = codec::parseDouble(value.substr(degree_digits));
  if (!deg || !min || *deg < 0 || *min < 0.0 || *min >= 60.0 || value[0] == '+' || value[degree_digits] == '+') {
    return std::nullopt;
  }
  const double v = static_cast<double>(*deg) + *min / 60.0;
  if (v > limit) return std::nullopt;
  const char h = hemisphere[0];
  const bool negative_h = degree_digits == 2 ? h == 'S' : h == 'W';
  const bool positive_h = degree_digits == 2 ? h == 'N' : h == 'E';
  if (!negative_h && !positive_h) return std::nullopt;
  return negative_h ? -v : v;
}

struct Parser {
  const std::vector<std::string_view>& f;
  std::string why;

  std::optional<double> num(std::size_t i) {
    auto v = codec::parseDouble(f[i]);
    if (!v) why = "field " + std::to_string(i) + " " + codec::quoted(f[i]) + " is not a number";
    return v;
  }
  std::optional<TimeOfDay> time(std::size_t i) {
    auto t = parseTime(f[i]);
    if (!t) why = "field " + std::to_string(i) + " " + codec::quoted(f[i]) + " is not hhmmss.ss";
    return t;
  }
  std::optional<double> angle(std::size_t i, std::size_t digits, double limit) {
    auto a = parseAngle(f[i], f[i + 1], digits, limit);
    if (!a)
      why =
          "field " + std::to_string(i) + " " + codec::quoted(f[i]) + "," + std::string(f[i + 1]) + " is not a position";
    return a;
  }
  std::optional<BackseatSentence> fail(std::string message) {
    why = std::move(message);
    return std::nullopt;
  }
  bool count(std::size_t n) {
    if (f.size() == n) return true;
    why = std::string(f[0]) + " has " + std::to_string(f.size() - 1) + " fields, expected " + std::to_string(n - 1);
    return false;
  }

  std::optional<BackseatSentence> parse() {
    const std::string_view name = f[0];
    if (name == "BFNVG") {
      if (!count(13)) return std::nullopt;
      NavSentence n;
      auto t = time(1);
      auto lat = t ? angle(2, 2, 90.0) : std::nullopt;
      auto lon = lat ? angle(4, 3, 180.0) : std::nullopt;
      auto q = lon ? num(6) : std::nullopt;
      auto alt = q ? num(7) : std::nullopt;
      auto depth = alt ? num(8) : std::nullopt;
      auto hdg = depth ? num(9) : std::nullopt;
      auto roll = hdg ? num(10) : std::nullopt;
      auto pitch = roll ? num(11) : std::nullopt;
      auto ct = pitch ? time(12) : std::nullopt;
      if (!ct) return std::nullopt;
      n.time = *t;
      n.latitude_deg = *lat;
      n.longitude_deg = *lon;
      n.quality = static_cast<int>(*q);
      n.altitude_m = *alt;
      n.depth_m = *depth;
      n.heading_deg = *hdg;
      n.roll_deg = *roll;
      n.pitch_deg = *pitch;
      n.computed_time = *ct;
      return n;
    }
    if (name == "BFNVR") {
      if (!count(8)) return std::nullopt;
      NavRateSentence r;
      auto t = time(1);
      if (!t) return std::nullopt;
      r.time = *t;
      double* out[6] = {&r.east_mps, &r.north_mps, &r.down_mps, &r.pitch_rate_dps, &r.roll_rate_dps, &r.yaw_rate_dps};
      for (std::size_t i = 0; i < 6; ++i) {
        auto v = num(2 + i);
        if (!v) return std::nullopt;
        *out[i] = *v;
      }
      return r;
    }
    if (name == "BFACK") {
      if (!count(7)) return std::nullopt;
      AckSentence a;
      auto t = time(1);
      auto ct = t ? time(3) : std::nullopt;
      if (!ct) return std::nullopt;
      const auto id = codec::parseInt(f[4]);
      const auto status = codec::parseInt(f[5]);
      if (!id || *id < 0 || *id > 0xFFFFFFFFLL) return fail("command id " + codec::quoted(f[4]) + " invalid");
      if (!status || (*status != 0 && *status != 1)) return fail("ack status " + codec::quoted(f[5]) + " not 0 or 1");
      a.time = *t;
      a.command = std::string(f[2]);
      a.command_time = *ct;
      a.command_id = static_cast<std::uint32_t>(*id);
      a.status = *status == 1 ? AckStatus::kAccepted : AckStatus::kFailed;
      a.reason = std::string(f[6]);
      return a;
    }
    if (name == "BPGHP") {
      if (f.size() != 9 && f.size() != 10) {
        why = "BPGHP has " + std::to_string(f.size() - 1) + " fields, expected 8 or 9";
        return std::nullopt;
      }
      WaypointCommand w;
      auto t = time(1);
      const auto id = codec::parseInt(f[2]);
      if (!t) return std::nullopt;
      if (!id || *id < 0 || *id > 0xFFFFFFFFLL) return fail("waypoint id " + codec::quoted(f[2]) + " invalid");
      auto lat = angle(3, 2, 90.0);
      auto lon = lat ? angle(5, 3, 180.0) : std::nullopt;
      auto depth = lon ? num(7) : std::nullopt;
      auto speed = depth ? num(8) : std::nullopt;
      if (!speed) return std::nullopt;
      w.time = *t;
      w.id = static_cast<std::uint32_t>(*id);
      w.latitude_deg = *lat;
      w.longitude_deg = *lon;
      w.depth_m = *depth;
      w.speed_mps = *speed;
      if (f.size() == 10 && !f[9].empty()) {
        auto heading = num(9);
        if (!heading) return std::nullopt;
        if (!(*heading >= 0.0 && *heading < 360.0))
          return fail("heading " + codec::quoted(f[9]) + " is outside [0, 360)");
        w.heading_deg = *heading;
      }
      return w;
    }
    if (name == "BPSTS") {
      if (!count(4)) return std::nullopt;
      Heartbeat h;
      auto t = time(1);
      const auto state = codec::parseInt(f[2]);
      if (!t) return std::nullopt;
      if (!state || *state < 0 || *state > 255) return fail("state " + codec::quoted(f[2]) + " invalid");
      h.time = *t;
      h.state = static_cast<int>(*state);
      h.text = std::string(f[3]);
      return h;
    }
    if (name.size() == 5 && (name.substr(0, 2) == "BF" || name.substr(0, 2) == "BP")) {
      BackseatOther o;
      o.name = std::string(name);
      for (std::size_t i = 1; i < f.size(); ++i) o.fields.emplace_back(f[i]);
      return o;
    }
    why = "unknown sentence name " + codec::quoted(name);
    return std::nullopt;
  }
};

std::string formatTime(const TimeOfDay& t) {
  double s = std::clamp(t.seconds_since_midnight, 0.0, 86399.99);
  s = std::round(s * 100.0) / 100.0;
  const int hh = static_cast<int>(s / 3600.0);
  const int mm = static_cast<int>((s - hh * 3600.0) / 60.0);
  const double ss = std::min(s - hh * 3600.0 - mm * 60.0, 59.99);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%02d%02d%05.2f", hh, mm, ss);
  return buf;
}

// Minutes with 6 decimals: 1e-6' is 2 mm of latitude (4 decimals, 0.19 m, is coarser than the map).
constexpr int kMinuteDecimals = 6;
constexpr double kMinuteScale = 1e6;

std::string formatAngle(double deg, int degree_digits, char pos, char neg) {
  const double a = std::abs(deg);
  int d = static_cast<int>(a);
  double m = std::round((a - d) * 60.0 * kMinuteScale) / kMinuteScale;
  if (m >= 60.0) {
    ++d;
    m = 0.0;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%0*d%0*.*f,%c", degree_digits, d, kMinuteDecimals + 3, kMinuteDecimals, m,
                deg < 0 ? neg : pos);
  return buf;
}

std::string num(double v, int decimals) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, std::isfinite(v) ? v : 0.0);
  return buf;
}

// Free text cannot carry the separators of the sentence.
std::string sanitize(const std::string& s) {
  std::string out = s;
  for (char& c : out) {
    if (c == ',' || c == '*' || c == '$' || c == '\r' || c == '\n') c = ' ';
  }
  return out;
}

struct Encoder {
  std::string operator()(const NavSentence& n) const {
    return "BFNVG," + formatTime(n.time) + "," + formatAngle(n.latitude_deg, 2, 'N', 'S') + "," +
           formatAngle(n.longitude_deg, 3, 'E', 'W') + "," + std::to_string(n.quality) + "," + num(n.altitude_m, 2) +
           "," + num(n.depth_m, 2) + "," + num(n.heading_deg, 2) + "," + num(n.roll_deg, 2) + "," +
           num(n.pitch_deg, 2) + "," + formatTime(n.computed_time);
  }
  std::string operator()(const NavRateSentence& r) const {
    return "BFNVR," + formatTime(r.time) + "," + num(r.east_mps, 3) + "," + num(r.north_mps, 3) + "," +
           num(r.down_mps, 3) + "," + num(r.pitch_rate_dps, 3) + "," + num(r.roll_rate_dps, 3) + "," +
           num(r.yaw_rate_dps, 3);
  }
  std::string operator()(const AckSentence& a) const {
    return "BFACK," + formatTime(a.time) + "," + sanitize(a.command) + "," + formatTime(a.command_time) + "," +
           std::to_string(a.command_id) + "," + (a.status == AckStatus::kAccepted ? "1" : "0") + "," +
           sanitize(a.reason);
  }
  std::string operator()(const WaypointCommand& w) const {
    return "BPGHP," + formatTime(w.time) + "," + std::to_string(w.id) + "," + formatAngle(w.latitude_deg, 2, 'N', 'S') +
           "," + formatAngle(w.longitude_deg, 3, 'E', 'W') + "," + num(w.depth_m, 2) + "," + num(w.speed_mps, 2) +
           (w.heading_deg ? "," + num(*w.heading_deg, 2) : "");
  }
  std::string operator()(const Heartbeat& h) const {
    return "BPSTS," + formatTime(h.time) + "," + std::to_string(std::clamp(h.state, 0, 255)) + "," + sanitize(h.text);
  }
  std::string operator()(const BackseatOther& o) const {
    std::string s = sanitize(o.name);
    for (const auto& f : o.fields) {
      s += ',';
      s += sanitize(f);
    }
    return s;
  }
};

}  // namespace

std::uint8_t xorChecksum(std::string_view body) {
  std::uint8_t x = 0;
  for (const char c : body) x = static_cast<std::uint8_t>(x ^ static_cast<std::uint8_t>(c));
  return x;
}

std::string encodeBackseat(const BackseatSentence& sentence) {
  const std::string body = std::visit(Encoder{}, sentence);
  char tail[8];
  std::snprintf(tail, sizeof tail, "*%02X\r\n", xorChecksum(body));
  std::string out;
  out.reserve(body.size() + 6);
  out += '$';
  out += body;
  out += tail;
  return out;
}

codec::DecodeResult<BackseatSentence> BackseatCodec::decode(std::span<const std::uint8_t> b) const {
  if (b.empty()) return ResultBs::needMore();
  if (b[0] != '$')
    return ResultBs::bad(BadKind::kNoSync, codec::findByte(b, '$', 1), "backseat: no '$' sentence start");
  const std::size_t lf = codec::findByte(b, '\n');
  if (lf == b.size()) {
    const std::size_t next = codec::findByte(b, '$', 1);
    if (next < b.size()) {
      return ResultBs::bad(BadKind::kMalformed, next, "backseat: sentence cut short by a new '$'");
    }
    if (b.size() > config_.max_sentence_bytes)
      return ResultBs::bad(BadKind::kMalformed, 1, "backseat: sentence longer than limit");
    return ResultBs::needMore();
  }
  const std::size_t consumed = lf + 1;
  std::string_view line = codec::asText(b.first(lf));
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  const std::size_t second = line.find('$', 1);
  if (second != std::string_view::npos) {
    return ResultBs::bad(BadKind::kMalformed, second,
                         "backseat: truncated sentence " + codec::quoted(line.substr(0, second)));
  }
  const std::size_t star = line.rfind('*');
  if (star == std::string_view::npos || star + 3 != line.size()) {
    return ResultBs::bad(BadKind::kMalformed, consumed, "backseat: no *hh checksum in " + codec::quoted(line));
  }
  const int hi = hexValue(line[star + 1]);
  const int lo = hexValue(line[star + 2]);
  if (hi < 0 || lo < 0)
    return ResultBs::bad(BadKind::kMalformed, consumed, "backseat: checksum not hex in " + codec::quoted(line));
  const std::string_view body = line.substr(1, star - 1);
  const std::uint8_t expected = static_cast<std::uint8_t>(hi * 16 + lo);
  if (xorChecksum(body) != expected) {
    return ResultBs::bad(BadKind::kChecksum, consumed, "backseat: checksum mismatch in " + codec::quoted(line));
  }
  const auto fields = codec::splitFields(body);
  Parser parser{fields, {}};
  auto sentence = parser.parse();
  if (!sentence) return ResultBs::bad(BadKind::kMalformed, consumed, "backseat: " + parser.why);
  return ResultBs::decoded(std::move(*sentence), consumed);
}

Status AckTrackerConfig::validate() const {
  if (resend_after_ns <= 0)
    return Error{"backseat.resend_after_ns: " + std::to_string(resend_after_ns) + " must be > 0"};
  if (max_attempts < 1) return Error{"backseat.max_attempts: " + std::to_string(max_attempts) + " must be >= 1"};
  return {};
}

Result<std::string> AckTracker::send(const WaypointCommand& command, std::int64_t now_ns) {
  if (auto st = config_.validate(); !st.ok()) return st.error();
  const bool busy =
      std::any_of(pending_.begin(), pending_.end(), [&](const Pending& p) { return p.command.id == command.id; });
  if (busy) return Error{"waypoint command " + std::to_string(command.id) + " is already awaiting acknowledgement"};
  Pending p;
  p.command = command;
  p.sentence = encodeBackseat(command);
  p.last_sent_ns = now_ns;
  p.attempts = 1;
  pending_.push_back(p);
  return p.sentence;
}

Result<AckTracker::Outcome> AckTracker::onAck(const AckSentence& ack) {
  const auto it = std::find_if(pending_.begin(), pending_.end(), [&](const Pending& p) {
    return ack.command == "BPGHP" && p.command.id == ack.command_id;
  });
  if (it == pending_.end()) {
    return Error{"acknowledgement of " + ack.command + " " + std::to_string(ack.command_id) +
                 " matches no pending command"};
  }
  Outcome o;
  o.command_id = it->command.id;
  o.accepted = ack.status == AckStatus::kAccepted;
  o.reason = ack.reason;
  pending_.erase(it);
  outcomes_.push_back(o);
  return o;
}

std::vector<std::string> AckTracker::poll(std::int64_t now_ns) {
  std::vector<std::string> resend;
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (now_ns - it->last_sent_ns < config_.resend_after_ns) {
      ++it;
      continue;
    }
    if (it->attempts >= config_.max_attempts) {
      outcomes_.push_back(
          Outcome{it->command.id, false, "no acknowledgement after " + std::to_string(it->attempts) + " attempts"});
      it = pending_.erase(it);
      continue;
    }
    ++it->attempts;
    it->last_sent_ns = now_ns;
    resend.push_back(it->sentence);
    ++it;
  }
  return resend;
}

std::vector<AckTracker::Outcome> AckTracker::takeOutcomes() {
  std::vector<Outcome> out;
  out.swap(outcomes_);
  return out;
}

std::string HeartbeatScheduler::emit(const Heartbeat& heartbeat, std::int64_t now_ns) {
  sent_ = true;
  last_ns_ = now_ns;
  return encodeBackseat(heartbeat);
}

}  // namespace vog::backseat
