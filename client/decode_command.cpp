// `vogctl decode`: decodes a device recording with the same codecs the daemon uses and prints
// every frame, then a summary of what was dropped (garbage, bad checksums, malformed frames).

#include "commands.hpp"
#include "vog/client/json_line.hpp"

#include "vog/backseat/backseat.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/depth/digiquartz.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/dvl/pd6.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/mission/mission_store.hpp"
#include "vog/mission/raw_log.hpp"
#include "vog/sonar/aris_command.hpp"
#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/sonar/sonar_files.hpp"

#include <cstdio>
#include <iostream>
#include <map>
#include <string>
#include <variant>
#include <vector>

namespace vog::client {
namespace {

using Value = std::variant<std::string, double, std::int64_t, bool>;

// One decoded frame, printed as `kind key=value ...` or as one JSON object.
struct Record {
  std::string kind;
  std::vector<std::pair<std::string, Value>> fields;
  Record& add(std::string key, Value v) {
    fields.emplace_back(std::move(key), std::move(v));
    return *this;
  }
};

struct Printer {
  bool json = false;

  void print(const Record& r) const {
    if (json) {
      JsonLine line;
      line.add("type", r.kind);
      for (const auto& field : r.fields) {
        std::visit([&line, &field](const auto& v) { line.add(field.first, v); }, field.second);
      }
      std::cout << line.str() << '\n';
      return;
    }
    std::string text = r.kind;
    for (const auto& [key, value] : r.fields) {
      text += "  " + key + "=";
      std::visit(
          [&text](const auto& v) {
            using T = std::decay_t<decltype(v)>;
            if constexpr (std::is_same_v<T, std::string>) {
              text += v;
            } else if constexpr (std::is_same_v<T, double>) {
              char buf[40];
              std::snprintf(buf, sizeof buf, "%.6g", v);
              text += buf;
            } else if constexpr (std::is_same_v<T, bool>) {
              text += v ? "yes" : "no";
            } else {
              text += std::to_string(v);
            }
          },
          value);
    }
    std::cout << text << '\n';
  }
};

Record summary(const codec::StreamStats& s, std::size_t trailing) {
  Record r{"summary", {}};
  r.add("frames", static_cast<std::int64_t>(s.frames))
      .add("bad_checksum", static_cast<std::int64_t>(s.bad_checksum))
      .add("malformed", static_cast<std::int64_t>(s.malformed))
      .add("garbage_bytes", static_cast<std::int64_t>(s.garbage_bytes))
      .add("truncated_bytes", static_cast<std::int64_t>(trailing));
  if (!s.last_error.empty()) r.add("last_error", s.last_error);
  return r;
}

template <class Codec, class ToRecord>
int decodeStream(const std::vector<std::uint8_t>& bytes, const Printer& out, ToRecord toRecord) {
  const auto decoded = codec::decodeAll<Codec>(bytes);
  for (const auto& frame : decoded.frames) out.print(toRecord(frame));
  out.print(summary(decoded.stats, decoded.trailing_bytes));
  return 0;
}

Record pd0Record(const dvl::DvlEnsemble& e) {
  const auto& v = e.variable;
  char time[40];
  std::snprintf(time, sizeof time, "%04d-%02d-%02dT%02d:%02d:%02d.%02d", v.clock.year, v.clock.month, v.clock.day,
                v.clock.hour, v.clock.minute, v.clock.second, v.clock.hundredths);
  Record r{"pd0", {}};
  r.add("ensemble", static_cast<std::int64_t>(v.ensemble_number))
      .add("time", std::string(time))
      .add("heading_deg", v.heading_deg)
      .add("pitch_deg", v.pitch_deg)
      .add("roll_deg", v.roll_deg)
      .add("sound_speed_mps", v.sound_speed_mps)
      .add("temperature_c", v.temperature_c)
      .add("depth_m", v.transducer_depth_m)
      .add("frame", std::string(dvl::toString(e.fixed.coordinate_frame)))
      .add("beams", static_cast<std::int64_t>(e.fixed.n_beams))
      .add("cells", static_cast<std::int64_t>(e.fixed.n_cells));
  if (e.bottom_track) {
    const auto bv = dvl::bottomVelocity(e);
    if (bv.ok()) {
      r.add("bt_vx_mps", bv->velocity_mps[0])
          .add("bt_vy_mps", bv->velocity_mps[1])
          .add("bt_vz_mps", bv->velocity_mps[2]);
    } else {
      r.add("bt_invalid", bv.error().message);
    }
  }
  return r;
}

Record pd6Record(const dvl::Pd6Sentence& s) {
  return std::visit(
      [](const auto& x) -> Record {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, dvl::Pd6Attitude>) {
          return Record{"pd6.SA", {}}
              .add("pitch_deg", x.pitch_deg)
              .add("roll_deg", x.roll_deg)
              .add("heading_deg", x.heading_deg);
        } else if constexpr (std::is_same_v<T, dvl::Pd6TimeAndScaling>) {
          return Record{"pd6.TS", {}}
              .add("salinity_ppt", x.salinity_ppt)
              .add("temperature_c", x.temperature_c)
              .add("depth_m", x.transducer_depth_m)
              .add("sound_speed_mps", x.sound_speed_mps);
        } else if constexpr (std::is_same_v<T, dvl::Pd6Velocity>) {
          const char frame =
              x.frame == dvl::CoordinateFrame::kShip ? 'S' : (x.frame == dvl::CoordinateFrame::kEarth ? 'E' : 'I');
          return Record{std::string("pd6.") + (x.bottom ? 'B' : 'W') + frame, {}}
              .add("vx_mps", x.velocity_mps[0])
              .add("vy_mps", x.velocity_mps[1])
              .add("vz_mps", x.velocity_mps[2])
              .add("valid", x.valid);
        } else {
          return Record{x.bottom ? "pd6.BD" : "pd6.WD", {}}
              .add("east_m", x.east_m)
              .add("north_m", x.north_m)
              .add("up_m", x.up_m)
              .add("range_to_bottom_m", x.range_to_bottom_m);
        }
      },
      s);
}

Record digiquartzRecord(const depth::DigiquartzMessage& m) {
  const char* kind =
      m.kind == depth::DigiquartzMessage::Kind::kCommand
          ? "digiquartz.command"
          : (m.kind == depth::DigiquartzMessage::Kind::kPressure ? "digiquartz.pressure" : "digiquartz.parameter");
  Record r{kind, {}};
  r.add("destination", static_cast<std::int64_t>(m.destination))
      .add("source", static_cast<std::int64_t>(m.source))
      .add("body", m.body);
  if (m.kind == depth::DigiquartzMessage::Kind::kPressure) r.add("value", m.value);
  return r;
}

Record backseatRecord(const backseat::BackseatSentence& s) {
  return std::visit(
      [](const auto& x) -> Record {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, backseat::NavSentence>) {
          return Record{"BFNVG", {}}
              .add("time_s", x.time.seconds_since_midnight)
              .add("latitude_deg", x.latitude_deg)
              .add("longitude_deg", x.longitude_deg)
              .add("depth_m", x.depth_m)
              .add("altitude_m", x.altitude_m)
              .add("heading_deg", x.heading_deg)
              .add("roll_deg", x.roll_deg)
              .add("pitch_deg", x.pitch_deg);
        } else if constexpr (std::is_same_v<T, backseat::NavRateSentence>) {
          return Record{"BFNVR", {}}
              .add("time_s", x.time.seconds_since_midnight)
              .add("east_mps", x.east_mps)
              .add("north_mps", x.north_mps)
              .add("down_mps", x.down_mps);
        } else if constexpr (std::is_same_v<T, backseat::AckSentence>) {
          return Record{"BFACK", {}}
              .add("command", x.command)
              .add("id", static_cast<std::int64_t>(x.command_id))
              .add("accepted", x.status == backseat::AckStatus::kAccepted)
              .add("reason", x.reason);
        } else if constexpr (std::is_same_v<T, backseat::WaypointCommand>) {
          return Record{"BPGHP", {}}
              .add("id", static_cast<std::int64_t>(x.id))
              .add("latitude_deg", x.latitude_deg)
              .add("longitude_deg", x.longitude_deg)
              .add("depth_m", x.depth_m)
              .add("speed_mps", x.speed_mps);
        } else if constexpr (std::is_same_v<T, backseat::Heartbeat>) {
          return Record{"BPSTS", {}}.add("state", static_cast<std::int64_t>(x.state)).add("text", x.text);
        } else {
          std::string joined;
          for (const auto& f : x.fields) joined += (joined.empty() ? "" : ",") + f;
          return Record{x.name, {}}.add("fields", joined);
        }
      },
      s);
}

Record imuRecord(const imu::ImuSample& s) {
  Record r{"imu", {}};
  r.add("seq", static_cast<std::int64_t>(s.sequence)).add("status", static_cast<std::int64_t>(s.status));
  if (s.attitude) {
    r.add("roll_rad", s.attitude->roll_rad).add("pitch_rad", s.attitude->pitch_rad).add("yaw_rad", s.attitude->yaw_rad);
  }
  r.add("dvx_mps", s.delta_velocity_mps.x())
      .add("dvy_mps", s.delta_velocity_mps.y())
      .add("dvz_mps", s.delta_velocity_mps.z());
  r.add("dt_s", s.dt_s);
  return r;
}

int decodeSonar(const std::vector<std::uint8_t>& bytes, bool aris_only, const Printer& out) {
  const auto rec = aris_only ? sonar::decodeArisFile(bytes) : sonar::decodeDdfFile(bytes);
  if (!rec.ok()) {
    std::cerr << "vogctl decode: " << rec.error().message << '\n';
    return 1;
  }
  for (const auto& f : rec->frames) {
    double sum = 0.0;
    for (const std::uint8_t v : f.samples) sum += v;
    out.print(Record{"sonar_frame", {}}
                  .add("index", static_cast<std::int64_t>(f.frame_index))
                  .add("stamp_ns", f.stamp_ns)
                  .add("beams", static_cast<std::int64_t>(f.n_beams))
                  .add("samples", static_cast<std::int64_t>(f.n_samples))
                  .add("window_start_m", f.window_start_m)
                  .add("window_length_m", f.window_length_m)
                  .add("sound_speed_mps", f.sound_speed_mps)
                  .add("mean_intensity", f.samples.empty() ? 0.0 : sum / static_cast<double>(f.samples.size())));
  }
  out.print(Record{"summary", {}}
                .add("ddf_version", static_cast<std::int64_t>(rec->ddf_version))
                .add("frames", static_cast<std::int64_t>(rec->frames.size()))
                .add("header_frame_count", static_cast<std::int64_t>(rec->header_frame_count))
                .add("truncated_bytes", static_cast<std::int64_t>(rec->truncated_bytes)));
  return 0;
}

// Raw-log device ids of vogd's ARIS link (daemon/app DeviceId: kArisFrames, kArisCommands).
constexpr std::uint16_t kRawArisFrames = 0x0006;
constexpr std::uint16_t kRawArisCommands = 0x0007;

Record arisCommandRecord(const sonar::ArisCommand& c, std::int64_t stamp_ns) {
  Record r{"aris_command", {}};
  r.add("stamp_ns", stamp_ns).add("command", std::string(sonar::arisCommandName(c)));
  if (const auto* a = std::get_if<sonar::ArisAcousticSettings>(&c)) {
    r.add("cookie", static_cast<std::int64_t>(a->cookie))
        .add("ping_mode", static_cast<std::int64_t>(a->ping_mode))
        .add("samples_per_beam", static_cast<std::int64_t>(a->samples_per_beam))
        .add("sample_start_delay_us", static_cast<std::int64_t>(a->sample_start_delay_us))
        .add("sample_period_us", static_cast<std::int64_t>(a->sample_period_us))
        .add("frame_rate_hz", static_cast<double>(a->frame_rate_hz));
  } else if (const auto* to = std::get_if<sonar::ArisSetFrameStreamReceiver>(&c)) {
    r.add("ip", to->ip).add("port", static_cast<std::int64_t>(to->port));
  }
  return r;
}

// A capture of the ARIS live link: the FramePart datagrams vogd received and the commands it sent,
// as its raw log holds them (FILE: the log, MISSION/raw.vogr, or the mission folder). The
// datagrams go through the receiver's assembler with their reception stamps, as vogd ran them.
int decodeArisStream(const std::string& path, const Printer& out) {
  std::filesystem::path log = path;
  if (std::filesystem::is_directory(log)) log /= mission::MissionStore::kRawLogFile;
  const auto raw = mission::readRawLog(log);
  if (!raw.ok()) {
    std::cerr << "vogctl decode: " << raw.error().message << '\n';
    return 1;
  }
  sonar::ArisFrameAssembler assembler;
  std::int64_t commands = 0, commands_malformed = 0;
  for (const mission::RawRecord& rec : raw->records) {
    if (rec.device_id == kRawArisCommands) {
      sonar::ArisCommandDecoder decoder;
      for (const sonar::ArisDecodedCommand& d : decoder.feed(rec.bytes)) {
        if (d.command) {
          ++commands;
          out.print(arisCommandRecord(*d.command, rec.stamp_ns));
        } else {
          ++commands_malformed;
        }
      }
      continue;
    }
    if (rec.device_id != kRawArisFrames) continue;
    const sonar::ArisPartResult r = assembler.add(rec.bytes, 1e-9 * static_cast<double>(rec.stamp_ns));
    if (!r.frame) continue;
    const sonar::SonarFrame& f = r.frame->frame;
    double sum = 0.0;
    for (const std::uint8_t v : f.samples) sum += v;
    out.print(Record{"aris_frame", {}}
                  .add("index", static_cast<std::int64_t>(f.frame_index))
                  .add("stamp_ns", rec.stamp_ns)
                  .add("cookie", static_cast<std::int64_t>(r.frame->meta.settings_cookie))
                  .add("ping_mode", static_cast<std::int64_t>(r.frame->meta.ping_mode))
                  .add("beams", static_cast<std::int64_t>(f.n_beams))
                  .add("samples", static_cast<std::int64_t>(f.n_samples))
                  .add("window_start_m", f.window_start_m)
                  .add("window_length_m", f.window_length_m)
                  .add("mean_intensity", f.samples.empty() ? 0.0 : sum / static_cast<double>(f.samples.size())));
  }
  const sonar::ArisFrameAssemblerStats& st = assembler.stats();
  Record summary{"summary", {}};
  summary.add("datagrams", static_cast<std::int64_t>(st.datagrams))
      .add("frames", static_cast<std::int64_t>(st.frames_completed))
      .add("frames_dropped_incomplete", static_cast<std::int64_t>(st.frames_dropped_incomplete))
      .add("datagrams_duplicated", static_cast<std::int64_t>(st.datagrams_duplicated))
      .add("datagrams_refused", static_cast<std::int64_t>(st.refusedTotal()));
  for (std::size_t i = 0; i < sonar::kArisPartRefusalCount; ++i) {
    if (st.refused[i] > 0) {
      summary.add("refused_" + std::string(sonar::arisPartRefusalName(static_cast<sonar::ArisPartRefusal>(i))),
                  static_cast<std::int64_t>(st.refused[i]));
    }
  }
  summary.add("commands", commands).add("commands_malformed", commands_malformed);
  out.print(summary);
  return 0;
}

int runDecode(const std::string& format, const std::string& path, bool json) {
  if (format == "aris-stream") return decodeArisStream(path, Printer{json});
  const auto bytes = sonar::loadFile(path);
  if (!bytes.ok()) {
    std::cerr << "vogctl decode: " << bytes.error().message << '\n';
    return kExitUsage;
  }
  const Printer out{json};
  if (format == "pd0") return decodeStream<dvl::Pd0Codec>(*bytes, out, pd0Record);
  if (format == "pd6") return decodeStream<dvl::Pd6Codec>(*bytes, out, pd6Record);
  if (format == "digiquartz") return decodeStream<depth::DigiquartzCodec>(*bytes, out, digiquartzRecord);
  if (format == "backseat") return decodeStream<backseat::BackseatCodec>(*bytes, out, backseatRecord);
  if (format == "imu-can") return decodeStream<imu::ImuCanCodec>(*bytes, out, imuRecord);
  if (format == "ddf") return decodeSonar(*bytes, false, out);
  if (format == "aris") return decodeSonar(*bytes, true, out);
  std::cerr << "vogctl decode: unknown format " << format << '\n';
  return kExitUsage;
}

}  // namespace

void addDecodeCommand(CLI::App& app, CommandAction& action) {
  auto* cmd = app.add_subcommand("decode", "Print what a device recording contains (frames, fields, drops)");
  struct Options {
    std::string format;
    std::string path;
    bool json = false;
  };
  auto opts = std::make_shared<Options>();
  cmd->add_option("--format", opts->format, "Wire format of the recording")
      ->required()
      ->check(CLI::IsMember({"pd0", "pd6", "digiquartz", "ddf", "aris", "aris-stream", "backseat", "imu-can"}));
  cmd->add_option("FILE", opts->path, "Recording to decode (aris-stream: a mission's raw log or its folder)")
      ->required();
  cmd->add_flag("--json", opts->json, "One JSON object per line instead of text");
  cmd->callback([opts, &action] { action = [opts] { return runDecode(opts->format, opts->path, opts->json); }; });
}

}  // namespace vog::client
