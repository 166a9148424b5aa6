#include "vog/sonar/sonar_udp.hpp"

#include "vog/core/bytes.hpp"
#include "vog/core/crc.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace vog::sonar {
namespace {

using codec::BadKind;
using ResultUdp = codec::DecodeResult<SonarFragment>;
constexpr std::uint8_t kMagic[4] = {'V', 'O', 'G', 'F'};
constexpr std::uint8_t kVersion = 1;

std::size_t skipToMagic(std::span<const std::uint8_t> b) {
  for (std::size_t i = 1; i < b.size(); ++i) {
    std::size_t k = 0;
    while (k < 4 && i + k < b.size() && b[i + k] == kMagic[k]) ++k;
    if (k == 4 || i + k == b.size()) return i;
  }
  return b.size();
}

}  // namespace

codec::DecodeResult<SonarFragment> SonarUdpCodec::decode(std::span<const std::uint8_t> b) const {
  if (b.empty()) return ResultUdp::needMore();
  for (std::size_t k = 0; k < 4 && k < b.size(); ++k) {
    if (b[k] != kMagic[k]) return ResultUdp::bad(BadKind::kNoSync, skipToMagic(b), "sonar UDP: no VOGF magic");
  }
  if (b.size() < udp::kHeaderBytes) return ResultUdp::needMore();
  auto malformed = [](const std::string& why) { return ResultUdp::bad(BadKind::kMalformed, 4, "sonar UDP: " + why); };
  if (b[4] != kVersion) return malformed("format version " + std::to_string(b[4]) + ", expected 1");
  if (b[5] != udp::kHeaderBytes) return malformed("header size " + std::to_string(b[5]) + ", expected 68");
  SonarFragment f;
  f.fragment_index = readU16LE(b, 6);
  f.fragment_count = readU16LE(b, 8);
  const std::size_t payload_bytes = readU16LE(b, 10);
  f.frame_index = readU32LE(b, 12);
  f.total_bytes = readU32LE(b, 16);
  f.offset = readU32LE(b, 20);
  f.stamp_ns = readI64LE(b, 24);
  f.n_beams = readU16LE(b, 32);
  f.n_samples = readU16LE(b, 34);
  f.window_start_m = readF64LE(b, 36);
  f.window_length_m = readF64LE(b, 44);
  f.sound_speed_mps = readF64LE(b, 52);
  const std::size_t datagram = udp::kHeaderBytes + payload_bytes + udp::kCrcBytes;
  if (datagram > udp::kMaxDatagramBytes)
    return malformed("payload of " + std::to_string(payload_bytes) + " bytes too large");
  if (f.n_beams < 1 || f.n_beams > limits_.max_beams || f.n_samples < 1 || f.n_samples > limits_.max_samples) {
    return malformed(std::to_string(f.n_beams) + " beams x " + std::to_string(f.n_samples) + " samples outside limits");
  }
  if (f.total_bytes != static_cast<std::uint32_t>(f.n_beams) * static_cast<std::uint32_t>(f.n_samples)) {
    return malformed("total bytes " + std::to_string(f.total_bytes) + " != beams x samples");
  }
  if (f.fragment_count == 0 || f.fragment_index >= f.fragment_count ||
      static_cast<std::size_t>(f.offset) + payload_bytes > f.total_bytes) {
    return malformed("fragment " + std::to_string(f.fragment_index) + "/" + std::to_string(f.fragment_count) +
                     " at offset " + std::to_string(f.offset) + " outside the frame");
  }
  if (b.size() < datagram) return ResultUdp::needMore();
  const std::uint32_t crc = readU32LE(b, udp::kHeaderBytes + payload_bytes);
  if (crc32Ieee(b.first(udp::kHeaderBytes + payload_bytes)) != crc) {
    return ResultUdp::bad(BadKind::kChecksum, 4,
                          "sonar UDP: CRC mismatch in frame " + std::to_string(f.frame_index) + " fragment " +
                              std::to_string(f.fragment_index));
  }
  // Checked after the CRC: a damaged header must count as a bad checksum, not as bad geometry.
  if (!std::isfinite(f.window_start_m) || !std::isfinite(f.window_length_m) || !(f.window_length_m > 0.0) ||
      f.window_start_m < 0.0 || !(f.sound_speed_mps > 0.0) || !std::isfinite(f.sound_speed_mps)) {
    return ResultUdp::bad(BadKind::kMalformed, datagram, "sonar UDP: window or sound speed not positive and finite");
  }
  const auto payload = b.subspan(udp::kHeaderBytes, payload_bytes);
  f.payload.assign(payload.begin(), payload.end());
  return ResultUdp::decoded(std::move(f), datagram);
}

Result<std::vector<std::vector<std::uint8_t>>> encodeSonarDatagrams(const SonarFrame& frame,
                                                                    std::size_t payload_bytes) {
  const std::size_t total = frame.samples.size();
  if (frame.n_beams < 1 || frame.n_beams > 0xFFFF || frame.n_samples < 1 || frame.n_samples > 0xFFFF ||
      total != static_cast<std::size_t>(frame.n_beams) * static_cast<std::size_t>(frame.n_samples)) {
    return Error{"sonar UDP: frame " + std::to_string(frame.frame_index) + " has " + std::to_string(total) +
                 " sample bytes for " + std::to_string(frame.n_beams) + " x " + std::to_string(frame.n_samples)};
  }
  if (payload_bytes == 0 || payload_bytes > 0xFFFF ||
      udp::kHeaderBytes + payload_bytes + udp::kCrcBytes > udp::kMaxDatagramBytes) {
    return Error{"sonar UDP: payload size " + std::to_string(payload_bytes) + " outside [1, " +
                 std::to_string(udp::kMaxDatagramBytes - udp::kHeaderBytes - udp::kCrcBytes) + "]"};
  }
  const std::size_t count = (total + payload_bytes - 1) / payload_bytes;
  if (count > 0xFFFF) return Error{"sonar UDP: frame needs " + std::to_string(count) + " fragments, limit 65535"};
  std::vector<std::vector<std::uint8_t>> out;
  out.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t offset = i * payload_bytes;
    const std::size_t n = std::min(payload_bytes, total - offset);
    std::vector<std::uint8_t> d;
    d.reserve(udp::kHeaderBytes + n + udp::kCrcBytes);
    ByteWriter w(d);
    for (const std::uint8_t m : kMagic) w.u8(m);
    w.u8(kVersion);
    w.u8(static_cast<std::uint8_t>(udp::kHeaderBytes));
    w.u16(static_cast<std::uint16_t>(i));
    w.u16(static_cast<std::uint16_t>(count));
    w.u16(static_cast<std::uint16_t>(n));
    w.u32(frame.frame_index);
    w.u32(static_cast<std::uint32_t>(total));
    w.u32(static_cast<std::uint32_t>(offset));
    w.i64(frame.stamp_ns);
    w.u16(static_cast<std::uint16_t>(frame.n_beams));
    w.u16(static_cast<std::uint16_t>(frame.n_samples));
    w.f64(frame.window_start_m);
    w.f64(frame.window_length_m);
    w.f64(frame.sound_speed_mps);
    w.u32(0);
    w.u32(0);
    w.bytes(std::span(frame.samples).subspan(offset, n));
    w.u32(crc32Ieee(d));
    out.push_back(std::move(d));
  }
  return out;
}

std::optional<SonarFrame> FrameReassembler::add(const SonarFragment& frag) {
  auto it = std::find_if(partial_.begin(), partial_.end(),
                         [&](const Partial& p) { return p.first.frame_index == frag.frame_index; });
  if (it == partial_.end()) {
    if (frag.fragment_count == 0 || frag.fragment_index >= frag.fragment_count ||
        frag.total_bytes != static_cast<std::uint32_t>(frag.n_beams) * static_cast<std::uint32_t>(frag.n_samples) ||
        frag.offset + frag.payload.size() > frag.total_bytes) {
      ++stats_.fragments_rejected;
      return std::nullopt;
    }
    if (partial_.size() >= max_in_flight_) {
      partial_.pop_front();
      ++stats_.frames_dropped;
    }
    Partial p;
    p.first = frag;
    p.first.payload.clear();
    p.frame.stamp_ns = frag.stamp_ns;
    p.frame.frame_index = frag.frame_index;
    p.frame.n_beams = frag.n_beams;
    p.frame.n_samples = frag.n_samples;
    p.frame.window_start_m = frag.window_start_m;
    p.frame.window_length_m = frag.window_length_m;
    p.frame.sound_speed_mps = frag.sound_speed_mps;
    p.frame.samples.assign(frag.total_bytes, 0);
    p.received.assign(frag.fragment_count, false);
    partial_.push_back(std::move(p));
    it = std::prev(partial_.end());
  } else {
    const SonarFragment& f0 = it->first;
    if (frag.fragment_count != f0.fragment_count || frag.total_bytes != f0.total_bytes || frag.n_beams != f0.n_beams ||
        frag.n_samples != f0.n_samples || frag.stamp_ns != f0.stamp_ns || frag.fragment_index >= f0.fragment_count ||
        frag.offset + frag.payload.size() > f0.total_bytes) {
      ++stats_.fragments_rejected;
      return std::nullopt;
    }
  }
  Partial& p = *it;
  if (p.received[frag.fragment_index]) {
    ++stats_.fragments_duplicate;
    return std::nullopt;
  }
  std::copy(frag.payload.begin(), frag.payload.end(), p.frame.samples.begin() + frag.offset);
  p.received[frag.fragment_index] = true;
  ++p.received_count;
  if (p.received_count < p.received.size()) return std::nullopt;
  SonarFrame done = std::move(p.frame);
  partial_.erase(it);
  ++stats_.frames_completed;
  return done;
}

}  // namespace vog::sonar
