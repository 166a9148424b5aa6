#include "vog/dvl/pd0.hpp"

#include "vog/core/bytes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace vog::dvl {
namespace {

using codec::BadKind;
using Result0 = codec::DecodeResult<DvlEnsemble>;

constexpr std::uint8_t kSync = 0x7F;

// Bytes to drop before the next possible "7F 7F" header.
std::size_t skipToSync(Bytes b) {
  for (std::size_t i = 1; i + 1 < b.size(); ++i) {
    if (b[i] == kSync && b[i + 1] == kSync) return i;
  }
  return b.back() == kSync ? b.size() - 1 : b.size();
}

CoordinateFrame frameFromEx(std::uint8_t ex) {
  // Fixed leader byte 25 (EX command), bits 3-4 (RDI PD0 manual, "Coordinate Transformation").
  return static_cast<CoordinateFrame>((ex & 0x18U) >> 3);
}

void parseFixedLeader(Bytes blk, DvlFixedLeader& f) {
  f.firmware_version = blk[2];
  f.firmware_revision = blk[3];
  f.system_configuration = readU16LE(blk, 4);
  f.n_beams = blk[8];
  f.n_cells = blk[9];
  f.pings_per_ensemble = readU16LE(blk, 10);
  f.cell_length_m = readU16LE(blk, 12) * 0.01;
  f.blank_m = readU16LE(blk, 14) * 0.01;
  f.coordinate_transform = blk[25];
  f.coordinate_frame = frameFromEx(blk[25]);
  f.tilts_used = (blk[25] & 0x04U) != 0;
  f.three_beam_allowed = (blk[25] & 0x02U) != 0;
  f.bin_mapping = (blk[25] & 0x01U) != 0;
  f.heading_alignment_deg = readI16LE(blk, 26) * 0.01;
  f.heading_bias_deg = readI16LE(blk, 28) * 0.01;
  f.bin1_distance_m = readU16LE(blk, 32) * 0.01;
  if (blk.size() >= 36) f.transmit_pulse_length_m = readU16LE(blk, 34) * 0.01;
  if (blk.size() >= 58) f.serial_number = readU32LE(blk, 54);
  if (blk.size() >= 59) f.beam_angle_deg = blk[58];
}

void parseVariableLeader(Bytes blk, DvlVariableLeader& v) {
  v.ensemble_number = readU16LE(blk, 2) | (static_cast<std::uint32_t>(blk[11]) << 16);
  // Bytes 4..10: RTC yy mm dd hh mm ss hundredths; bytes 57..64 (if present): Y2K clock with century.
  const int yy = blk[4];
  v.clock.year = yy < 80 ? 2000 + yy : 1900 + yy;
  v.clock.month = blk[5];
  v.clock.day = blk[6];
  v.clock.hour = blk[7];
  v.clock.minute = blk[8];
  v.clock.second = blk[9];
  v.clock.hundredths = blk[10];
  if (blk.size() >= 65 && blk[57] != 0) {
    v.clock.year = blk[57] * 100 + blk[58];
    v.clock.month = blk[59];
    v.clock.day = blk[60];
    v.clock.hour = blk[61];
    v.clock.minute = blk[62];
    v.clock.second = blk[63];
    v.clock.hundredths = blk[64];
  }
  v.bit_result = readU16LE(blk, 12);
  v.sound_speed_mps = readU16LE(blk, 14);
  v.transducer_depth_m = readU16LE(blk, 16) * 0.1;
  v.heading_deg = readU16LE(blk, 18) * 0.01;
  v.pitch_deg = readI16LE(blk, 20) * 0.01;
  v.roll_deg = readI16LE(blk, 22) * 0.01;
  v.salinity_ppt = readU16LE(blk, 24);
  v.temperature_c = readI16LE(blk, 26) * 0.01;
  if (blk.size() >= 52) v.pressure_pa = readU32LE(blk, 48) * 10.0;  // daPa
}

void parseBottomTrack(Bytes blk, DvlBottomTrack& bt) {
  bt.pings_per_ensemble = readU16LE(blk, 2);
  for (std::size_t i = 0; i < 4; ++i) {
    std::uint32_t range_cm = readU16LE(blk, 16 + 2 * i);
    if (blk.size() >= 81) range_cm |= static_cast<std::uint32_t>(blk[77 + i]) << 16;
    bt.range_m[i] = range_cm * 0.01;
    const std::int16_t vel = readI16LE(blk, 24 + 2 * i);
    bt.velocity_valid[i] = vel != pd0::kBadVelocity;
    bt.velocity_mps[i] = bt.velocity_valid[i] ? vel * 0.001 : 0.0;
    bt.correlation[i] = blk[32 + i];
    bt.amplitude[i] = blk[36 + i];
    bt.percent_good[i] = blk[40 + i];
  }
}

std::string hex16(std::uint16_t v) {
  static const char* digits = "0123456789ABCDEF";
  std::string s = "0x0000";
  for (int i = 0; i < 4; ++i) s[static_cast<std::size_t>(5 - i)] = digits[(v >> (4 * i)) & 0xF];
  return s;
}

}  // namespace

codec::DecodeResult<DvlEnsemble> Pd0Codec::decode(std::span<const std::uint8_t> b) const {
  if (b.empty()) return Result0::needMore();
  if (b[0] != kSync || (b.size() >= 2 && b[1] != kSync)) {
    return Result0::bad(BadKind::kNoSync, skipToSync(b), "PD0: no 7F 7F header");
  }
  if (b.size() < 6) return Result0::needMore();
  const std::size_t size = readU16LE(b, 2);
  const int n_types = b[5];
  const std::size_t header_bytes = 6 + 2 * static_cast<std::size_t>(n_types);
  if (n_types < 1 || n_types > config_.max_data_types) {
    return Result0::bad(BadKind::kMalformed, 2,
                        "PD0: number of data types " + std::to_string(n_types) + " out of range");
  }
  if (size > config_.max_ensemble_bytes) {
    return Result0::bad(
        BadKind::kMalformed, 2,
        "PD0: ensemble size " + std::to_string(size) + " exceeds limit " + std::to_string(config_.max_ensemble_bytes));
  }
  if (size < header_bytes + 2) {
    return Result0::bad(BadKind::kMalformed, 2,
                        "PD0: ensemble size " + std::to_string(size) + " smaller than its header");
  }
  if (b.size() < header_bytes) return Result0::needMore();
  std::vector<std::size_t> offsets(static_cast<std::size_t>(n_types));
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    offsets[i] = readU16LE(b, 6 + 2 * i);
    const std::size_t min_offset = i == 0 ? header_bytes : offsets[i - 1] + 2;
    if (offsets[i] < min_offset || offsets[i] + 2 > size) {
      return Result0::bad(BadKind::kMalformed, 2,
                          "PD0: data type " + std::to_string(i) + " offset " + std::to_string(offsets[i]) +
                              " outside the ensemble or out of order");
    }
  }
  if (b.size() < size + 2) return Result0::needMore();

  std::uint32_t sum = 0;
  for (std::size_t i = 0; i < size; ++i) sum += b[i];
  const std::uint16_t expected = readU16LE(b, size);
  if (static_cast<std::uint16_t>(sum) != expected) {
    return Result0::bad(BadKind::kChecksum, 2,
                        "PD0: checksum " + hex16(static_cast<std::uint16_t>(sum)) + " != " + hex16(expected));
  }

  // The checksum holds, so the frame boundaries are right: structural errors below drop the whole
  // ensemble.
  const std::size_t whole = size + 2;
  auto malformed = [whole](const std::string& why) { return Result0::bad(BadKind::kMalformed, whole, "PD0: " + why); };
  const Bytes ens = b.first(size);
  auto block = [&](std::size_t i) {
    const std::size_t end = i + 1 < offsets.size() ? offsets[i + 1] : size;
    return ens.subspan(offsets[i], end - offsets[i]);
  };

  DvlEnsemble out;
  bool have_fixed = false;
  bool have_variable = false;
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    const Bytes blk = block(i);
    const std::uint16_t id = readU16LE(blk, 0);
    out.data_type_ids.push_back(id);
    if (id == pd0::kFixedLeaderId) {
      if (blk.size() < 34) return malformed("fixed leader of " + std::to_string(blk.size()) + " bytes, need 34");
      parseFixedLeader(blk, out.fixed);
      if (out.fixed.n_beams < 1 || out.fixed.n_beams > 4) {
        return malformed("fixed leader beams " + std::to_string(out.fixed.n_beams) + " unsupported (1..4)");
      }
      if (out.fixed.n_cells > config_.max_cells) {
        return malformed("fixed leader cells " + std::to_string(out.fixed.n_cells) + " exceeds limit");
      }
      have_fixed = true;
    } else if (id == pd0::kVariableLeaderId) {
      if (blk.size() < 28) return malformed("variable leader of " + std::to_string(blk.size()) + " bytes, need 28");
      parseVariableLeader(blk, out.variable);
      have_variable = true;
    }
  }
  if (!have_fixed) return malformed("no fixed leader");
  if (!have_variable) return malformed("no variable leader");

  for (std::size_t i = 0; i < offsets.size(); ++i) {
    const Bytes blk = block(i);
    const std::uint16_t id = out.data_type_ids[i];
    if (id == pd0::kVelocityId) {
      const std::size_t beams = static_cast<std::size_t>(out.fixed.n_beams);
      const std::size_t cells = static_cast<std::size_t>(out.fixed.n_cells);
      if (blk.size() < 2 + cells * beams * 2) {
        return malformed("velocity block of " + std::to_string(blk.size()) + " bytes for " + std::to_string(cells) +
                         " cells");
      }
      out.cell_velocity_mps.assign(cells, {});
      out.cell_velocity_valid.assign(cells, {});
      for (std::size_t c = 0; c < cells; ++c) {
        for (std::size_t k = 0; k < beams; ++k) {
          const std::int16_t vel = readI16LE(blk, 2 + 2 * (c * beams + k));
          out.cell_velocity_valid[c][k] = vel != pd0::kBadVelocity;
          out.cell_velocity_mps[c][k] = vel != pd0::kBadVelocity ? vel * 0.001 : 0.0;
        }
      }
    } else if (id == pd0::kBottomTrackId) {
      if (blk.size() < 44) return malformed("bottom track of " + std::to_string(blk.size()) + " bytes, need 44");
      out.bottom_track.emplace();
      parseBottomTrack(blk, *out.bottom_track);
    }
  }
  return Result0::decoded(std::move(out), whole);
}

namespace {

template <class T>
T saturate(double v) {
  if (!(v == v)) return T{0};  // NaN
  const double lo = static_cast<double>(std::numeric_limits<T>::min());
  const double hi = static_cast<double>(std::numeric_limits<T>::max());
  return static_cast<T>(std::clamp(std::round(v), lo, hi));
}

std::int16_t velocityCount(double v_mps, bool valid) {
  if (!valid) return pd0::kBadVelocity;
  // -32768 is reserved for "bad"; keep valid values off it.
  return static_cast<std::int16_t>(std::max<int>(saturate<std::int16_t>(v_mps * 1000.0), -32767));
}

}  // namespace

std::vector<std::uint8_t> encodePd0(const DvlEnsemble& e) {
  const std::size_t beams = static_cast<std::size_t>(std::clamp(e.fixed.n_beams, 1, 4));
  const std::size_t cells = e.cell_velocity_mps.size();
  std::vector<std::size_t> sizes = {pd0::kFixedLeaderBytes, pd0::kVariableLeaderBytes};
  if (cells > 0) sizes.push_back(2 + cells * beams * 2);
  if (e.bottom_track) sizes.push_back(pd0::kBottomTrackBytes);
  const std::size_t n_types = sizes.size();

  std::vector<std::uint8_t> out;
  ByteWriter w(out);
  w.u8(kSync);
  w.u8(kSync);
  w.u16(0);  // size, patched below
  w.u8(0);
  w.u8(static_cast<std::uint8_t>(n_types));
  std::size_t offset = 6 + 2 * n_types;
  for (const std::size_t s : sizes) {
    w.u16(static_cast<std::uint16_t>(offset));
    offset += s;
  }

  // Fixed leader.
  const DvlFixedLeader& f = e.fixed;
  const std::size_t fixed_start = out.size();
  w.u16(pd0::kFixedLeaderId);
  w.u8(f.firmware_version);
  w.u8(f.firmware_revision);
  w.u16(f.system_configuration);
  w.u8(0);  // real/simulated flag
  w.u8(0);  // lag length
  w.u8(static_cast<std::uint8_t>(beams));
  w.u8(saturate<std::uint8_t>(cells > 0 ? static_cast<double>(cells) : f.n_cells));
  w.u16(saturate<std::uint16_t>(f.pings_per_ensemble));
  w.u16(saturate<std::uint16_t>(f.cell_length_m * 100.0));
  w.u16(saturate<std::uint16_t>(f.blank_m * 100.0));
  w.zeros(25 - (out.size() - fixed_start));
  const std::uint8_t ex =
      static_cast<std::uint8_t>((static_cast<unsigned>(f.coordinate_frame) << 3) | (f.tilts_used ? 0x04U : 0U) |
                                (f.three_beam_allowed ? 0x02U : 0U) | (f.bin_mapping ? 0x01U : 0U));
  w.u8(ex);
  w.i16(saturate<std::int16_t>(f.heading_alignment_deg * 100.0));
  w.i16(saturate<std::int16_t>(f.heading_bias_deg * 100.0));
  w.u8(0);  // sensor source
  w.u8(0);  // sensors available
  w.u16(saturate<std::uint16_t>(f.bin1_distance_m * 100.0));
  w.u16(saturate<std::uint16_t>(f.transmit_pulse_length_m * 100.0));
  w.zeros(54 - (out.size() - fixed_start));
  w.u32(f.serial_number);
  w.u8(saturate<std::uint8_t>(f.beam_angle_deg));

  // Variable leader.
  const DvlVariableLeader& v = e.variable;
  const std::size_t var_start = out.size();
  w.u16(pd0::kVariableLeaderId);
  w.u16(static_cast<std::uint16_t>(v.ensemble_number & 0xFFFFU));
  w.u8(static_cast<std::uint8_t>(((v.clock.year % 100) + 100) % 100));
  w.u8(saturate<std::uint8_t>(v.clock.month));
  w.u8(saturate<std::uint8_t>(v.clock.day));
  w.u8(saturate<std::uint8_t>(v.clock.hour));
  w.u8(saturate<std::uint8_t>(v.clock.minute));
  w.u8(saturate<std::uint8_t>(v.clock.second));
  w.u8(saturate<std::uint8_t>(v.clock.hundredths));
  w.u8(static_cast<std::uint8_t>((v.ensemble_number >> 16) & 0xFFU));
  w.u16(v.bit_result);
  w.u16(saturate<std::uint16_t>(v.sound_speed_mps));
  w.u16(saturate<std::uint16_t>(v.transducer_depth_m * 10.0));
  double heading = std::fmod(v.heading_deg, 360.0);
  if (heading < 0) heading += 360.0;
  w.u16(saturate<std::uint16_t>(heading * 100.0) % 36000);
  w.i16(saturate<std::int16_t>(v.pitch_deg * 100.0));
  w.i16(saturate<std::int16_t>(v.roll_deg * 100.0));
  w.u16(saturate<std::uint16_t>(v.salinity_ppt));
  w.i16(saturate<std::int16_t>(v.temperature_c * 100.0));
  w.zeros(48 - (out.size() - var_start));
  w.u32(saturate<std::uint32_t>(v.pressure_pa.value_or(0.0) / 10.0));
  w.zeros(57 - (out.size() - var_start));
  w.u8(saturate<std::uint8_t>(v.clock.year / 100));
  w.u8(saturate<std::uint8_t>(v.clock.year % 100));
  w.u8(saturate<std::uint8_t>(v.clock.month));
  w.u8(saturate<std::uint8_t>(v.clock.day));
  w.u8(saturate<std::uint8_t>(v.clock.hour));
  w.u8(saturate<std::uint8_t>(v.clock.minute));
  w.u8(saturate<std::uint8_t>(v.clock.second));
  w.u8(saturate<std::uint8_t>(v.clock.hundredths));

  if (cells > 0) {
    w.u16(pd0::kVelocityId);
    for (std::size_t c = 0; c < cells; ++c) {
      for (std::size_t k = 0; k < beams; ++k) {
        const bool valid = c < e.cell_velocity_valid.size() ? e.cell_velocity_valid[c][k] : true;
        w.i16(velocityCount(e.cell_velocity_mps[c][k], valid));
      }
    }
  }

  if (e.bottom_track) {
    const DvlBottomTrack& bt = *e.bottom_track;
    const std::size_t bt_start = out.size();
    w.u16(pd0::kBottomTrackId);
    w.u16(saturate<std::uint16_t>(bt.pings_per_ensemble));
    w.zeros(16 - (out.size() - bt_start));
    std::array<std::uint32_t, 4> range_cm{};
    for (std::size_t i = 0; i < 4; ++i) {
      range_cm[i] = std::min<std::uint32_t>(saturate<std::uint32_t>(bt.range_m[i] * 100.0), 0xFFFFFFU);
      w.u16(static_cast<std::uint16_t>(range_cm[i] & 0xFFFFU));
    }
    for (std::size_t i = 0; i < 4; ++i) w.i16(velocityCount(bt.velocity_mps[i], bt.velocity_valid[i]));
    for (std::size_t i = 0; i < 4; ++i) w.u8(bt.correlation[i]);
    for (std::size_t i = 0; i < 4; ++i) w.u8(bt.amplitude[i]);
    for (std::size_t i = 0; i < 4; ++i) w.u8(bt.percent_good[i]);
    w.zeros(77 - (out.size() - bt_start));
    for (std::size_t i = 0; i < 4; ++i) w.u8(static_cast<std::uint8_t>(range_cm[i] >> 16));
    w.zeros(pd0::kBottomTrackBytes - (out.size() - bt_start));
  }

  writeU16LE(out, 2, static_cast<std::uint16_t>(out.size()));
  std::uint32_t sum = 0;
  for (const std::uint8_t byte : out) sum += byte;
  w.u16(static_cast<std::uint16_t>(sum));
  return out;
}

}  // namespace vog::dvl
