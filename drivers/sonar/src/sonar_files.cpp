#include "vog/sonar/sonar_files.hpp"

#include "vog/core/bytes.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

namespace vog::sonar {
namespace {

constexpr std::uint32_t kArisSignature = 0x05464444;  // "DDF" + 0x05, little-endian
constexpr std::size_t kArisFileHeaderBytes = 1024;
constexpr std::size_t kArisFrameHeaderBytes = 1024;

// ARIS frame header offsets (FrameHeader.fields.csv, packed; verified on sample.aris).
namespace aris {
constexpr std::size_t kFrameIndex = 0;
constexpr std::size_t kFrameTime = 4;
constexpr std::size_t kVersion = 12;
constexpr std::size_t kWindowStart = 52;
constexpr std::size_t kWindowLength = 56;
constexpr std::size_t kSampleRate = 420;
constexpr std::size_t kPingMode = 436;
constexpr std::size_t kSamplePeriod = 452;
constexpr std::size_t kSoundSpeed = 464;
constexpr std::size_t kSamplesPerBeam = 468;
constexpr std::size_t kSampleStartDelay = 476;
constexpr std::size_t kReorderedSamples = 516;
constexpr std::size_t kSalinity = 520;
constexpr std::size_t kAppliedSettings = 680;
static_assert(kAppliedSettings + 4 == kArisFrameHeaderUsedBytes);
// File header (FileHeader.fields.csv).
constexpr std::size_t kFileFrameCount = 4;
constexpr std::size_t kFileNumRawBeams = 16;
constexpr std::size_t kFileSamplesPerChannel = 24;
constexpr std::size_t kFileSize = 424;
}  // namespace aris

// Classic DIDSON window lengths for high frequency (PROTOCOLS.md); low frequency doubles them.
// DIDSON window lengths by index (drivers/sonar/README.md): the index is the frame's window length
// code, plus 2 at low frequency. Classic windows of a standard DIDSON; a long-range (LR) DIDSON's
// are twice these. Extended windows (ConfigFlags bit 0 clear) have their own table, whose first
// entry the public readers do not agree on (0.83 or 1.25 m): it is refused.
constexpr std::array<double, 6> kDidsonWindowLength_m = {1.125, 2.25, 4.5, 9.0, 18.0, 36.0};
constexpr std::array<double, 6> kDidsonExtendedWindowLength_m = {0.0, 2.5, 5.0, 10.0, 20.0, 40.0};
constexpr std::array<double, 6> kDidsonLongRangeExtendedWindowLength_m = {2.5, 5.0, 10.0, 20.0, 40.0, 70.0};
constexpr double kDidsonStartStep_m = 0.375;          // classic windows, high frequency
constexpr double kDidsonExtendedStartStep_m = 0.419;  // extended windows, high frequency
constexpr int kDidsonSamples = 512;

Result<std::int64_t> usToNs(std::uint64_t us) {
  if (us > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max() / 1000)) {
    return Error{"frame time " + std::to_string(us) + " us out of range"};
  }
  return static_cast<std::int64_t>(us) * 1000;
}

}  // namespace

Result<int> arisBeamsForPingMode(std::uint32_t ping_mode) {
  if (ping_mode >= 1 && ping_mode <= 2) return 48;
  if (ping_mode >= 3 && ping_mode <= 5) return 96;
  if (ping_mode >= 6 && ping_mode <= 8) return 64;
  if (ping_mode >= 9 && ping_mode <= 12) return 128;
  return Error{"ARIS PingMode " + std::to_string(ping_mode) + " unknown (1..12)"};
}

Result<ArisFrameMeta> decodeArisFrameHeader(std::span<const std::uint8_t> h) {
  if (h.size() < kArisFrameHeaderUsedBytes) {
    return Error{"ARIS frame header of " + std::to_string(h.size()) + " bytes is shorter than the " +
                 std::to_string(kArisFrameHeaderUsedBytes) + " bytes that hold its fields up to AppliedSettings"};
  }
  ArisFrameMeta meta;
  meta.frame_index = readU32LE(h, aris::kFrameIndex);
  meta.frame_time_us = readU64LE(h, aris::kFrameTime);
  meta.ping_mode = readU32LE(h, aris::kPingMode);
  meta.sample_period_us = readU32LE(h, aris::kSamplePeriod);
  meta.sample_start_delay_us = readU32LE(h, aris::kSampleStartDelay);
  meta.header_window_start_m = readF32LE(h, aris::kWindowStart);
  meta.header_window_length_m = readF32LE(h, aris::kWindowLength);
  meta.samples_per_beam = readU32LE(h, aris::kSamplesPerBeam);
  meta.sound_speed_mps = readF32LE(h, aris::kSoundSpeed);
  meta.reordered_samples = readU32LE(h, aris::kReorderedSamples) != 0;
  meta.salinity = readU32LE(h, aris::kSalinity);
  meta.settings_cookie = readU32LE(h, aris::kAppliedSettings);
  return meta;
}

Result<SonarFrame> arisFrameFromMeta(const ArisFrameMeta& meta, std::uint32_t samples, const SonarFileLimits& limits) {
  const auto beams = arisBeamsForPingMode(meta.ping_mode);
  if (!beams.ok()) return beams.error();
  if (*beams > limits.max_beams || samples == 0 || samples > static_cast<std::uint32_t>(limits.max_samples)) {
    return Error{std::to_string(*beams) + " beams x " + std::to_string(samples) + " samples outside limits"};
  }
  const float c = meta.sound_speed_mps;
  if (!std::isfinite(c) || c < 1000.0f || c > 2000.0f) {
    return Error{"sound speed " + std::to_string(c) + " m/s outside [1000, 2000]"};
  }
  if (meta.sample_period_us == 0) return Error{"SamplePeriod is 0"};
  const auto stamp = usToNs(meta.frame_time_us);
  if (!stamp.ok()) return stamp.error();
  SonarFrame f;
  f.stamp_ns = *stamp;
  f.frame_index = meta.frame_index;
  f.n_beams = *beams;
  f.n_samples = static_cast<int>(samples);
  f.sound_speed_mps = static_cast<double>(c);
  // Range of a sample (ARIS File SDK): the echo travels out and back at c.
  const double half_c = f.sound_speed_mps / 2.0;
  f.window_start_m = meta.sample_start_delay_us * 1e-6 * half_c;
  f.window_length_m = meta.sample_period_us * 1e-6 * half_c * samples;
  return f;
}

Result<SonarRecording> decodeArisFile(std::span<const std::uint8_t> b, const SonarFileLimits& limits) {
  if (b.size() < kArisFileHeaderBytes) {
    return Error{"ARIS file of " + std::to_string(b.size()) + " bytes is shorter than its 1024-byte header"};
  }
  if (readU32LE(b, 0) != kArisSignature) return Error{"not an ARIS file: signature is not DDF v5 (0x05464444)"};
  SonarRecording rec;
  rec.ddf_version = 5;
  rec.header_frame_count = readU32LE(b, aris::kFileFrameCount);
  std::size_t pos = kArisFileHeaderBytes;
  while (pos < b.size()) {
    const std::size_t k = rec.frames.size();
    const std::string where = "ARIS frame " + std::to_string(k);
    if (b.size() - pos < kArisFrameHeaderBytes) {
      rec.truncated_bytes = b.size() - pos;
      break;
    }
    if (k >= limits.max_frames)
      return Error{"ARIS file has more than " + std::to_string(limits.max_frames) + " frames"};
    const auto h = b.subspan(pos, kArisFrameHeaderBytes);
    if (readU32LE(h, aris::kVersion) != kArisSignature) return Error{where + ": frame header version is not DDF v5"};
    const ArisFrameMeta meta = *decodeArisFrameHeader(h);  // 1024 bytes hold every field
    std::uint32_t samples = meta.samples_per_beam;
    if (samples == 0) samples = readU32LE(b, aris::kFileSamplesPerChannel);
    auto frame = arisFrameFromMeta(meta, samples, limits);
    if (!frame.ok()) return Error{where + ": " + frame.error().message};
    SonarFrame& f = *frame;
    const std::size_t data_bytes = static_cast<std::size_t>(f.n_beams) * samples;
    if (b.size() - pos - kArisFrameHeaderBytes < data_bytes) {
      rec.truncated_bytes = b.size() - pos;
      break;
    }
    const auto data = b.subspan(pos + kArisFrameHeaderBytes, data_bytes);
    f.samples.assign(data.begin(), data.end());
    rec.frames.push_back(std::move(f));
    rec.aris_meta.push_back(meta);
    pos += kArisFrameHeaderBytes + data_bytes;
  }
  return rec;
}

Result<std::vector<std::uint8_t>> encodeArisFrameHeader(const SonarFrame& f, const ArisHeaderOptions& options) {
  const auto beams = arisBeamsForPingMode(options.ping_mode);
  if (!beams.ok()) return beams.error();
  if (f.n_beams != *beams) {
    return Error{"PingMode " + std::to_string(options.ping_mode) + " has " + std::to_string(*beams) +
                 " beams, the frame " + std::to_string(f.n_beams)};
  }
  if (f.n_samples <= 0 ||
      f.samples.size() != static_cast<std::size_t>(f.n_beams) * static_cast<std::size_t>(f.n_samples)) {
    return Error{"samples size " + std::to_string(f.samples.size()) + " does not match " + std::to_string(f.n_beams) +
                 " beams x " + std::to_string(f.n_samples) + " samples"};
  }
  if (!(f.sound_speed_mps >= 1000.0 && f.sound_speed_mps <= 2000.0)) {
    return Error{"sound speed " + std::to_string(f.sound_speed_mps) + " m/s outside [1000, 2000]"};
  }
  if (f.stamp_ns < 0) return Error{"negative stamp_ns " + std::to_string(f.stamp_ns)};
  const double half_c = f.sound_speed_mps / 2.0;
  const double delay_us = std::round(f.window_start_m / half_c * 1e6);
  const double period_us = std::round(f.sampleLength_m() / half_c * 1e6);
  if (!(delay_us >= 0.0 && delay_us < 4e9) || !(period_us >= 1.0 && period_us < 4e9)) {
    return Error{"window start " + std::to_string(f.window_start_m) + " m / length " +
                 std::to_string(f.window_length_m) + " m not representable in whole microseconds"};
  }
  std::vector<std::uint8_t> h(kArisFrameHeaderBytes, 0);
  writeU32LE(h, aris::kFrameIndex, f.frame_index);
  writeU64LE(h, aris::kFrameTime, static_cast<std::uint64_t>(f.stamp_ns / 1000));
  writeU32LE(h, aris::kVersion, kArisSignature);
  writeF32LE(h, aris::kWindowStart, static_cast<float>(f.window_start_m));
  writeF32LE(h, aris::kWindowLength, static_cast<float>(f.window_length_m));
  writeF32LE(h, aris::kSampleRate, static_cast<float>(1e6 / period_us));
  writeU32LE(h, aris::kPingMode, options.ping_mode);
  writeU32LE(h, aris::kSamplePeriod, static_cast<std::uint32_t>(period_us));
  writeF32LE(h, aris::kSoundSpeed, static_cast<float>(f.sound_speed_mps));
  writeU32LE(h, aris::kSamplesPerBeam, static_cast<std::uint32_t>(f.n_samples));
  writeU32LE(h, aris::kSampleStartDelay, static_cast<std::uint32_t>(delay_us));
  writeU32LE(h, aris::kReorderedSamples, options.reordered_samples ? 1U : 0U);
  writeU32LE(h, aris::kSalinity, options.salinity);
  writeU32LE(h, aris::kAppliedSettings, options.settings_cookie);
  return h;
}

Result<std::vector<std::uint8_t>> encodeArisFile(std::span<const SonarFrame> frames) {
  std::uint32_t ping_mode_for_beams = 0;
  const int beams = frames.empty() ? 48 : frames.front().n_beams;
  const int samples = frames.empty() ? 0 : frames.front().n_samples;
  switch (beams) {
    case 48: ping_mode_for_beams = 1; break;
    case 96: ping_mode_for_beams = 3; break;
    case 64: ping_mode_for_beams = 6; break;
    case 128: ping_mode_for_beams = 9; break;
    default: return Error{"ARIS: " + std::to_string(beams) + " beams is not an ARIS beam count (48, 64, 96, 128)"};
  }
  // Fixed-size header buffers keep every write provably in bounds.
  std::array<std::uint8_t, kArisFileHeaderBytes> fh{};
  writeU32LE(fh, 0, kArisSignature);
  writeU32LE(fh, aris::kFileFrameCount, static_cast<std::uint32_t>(frames.size()));
  writeU32LE(fh, aris::kFileNumRawBeams, static_cast<std::uint32_t>(beams));
  writeU32LE(fh, aris::kFileSamplesPerChannel, static_cast<std::uint32_t>(samples));
  const std::size_t frame_bytes = kArisFrameHeaderBytes + static_cast<std::size_t>(std::max(beams, 0)) *
                                                              static_cast<std::size_t>(std::max(samples, 0));
  writeU64LE(fh, aris::kFileSize, kArisFileHeaderBytes + frames.size() * frame_bytes);
  std::vector<std::uint8_t> out(fh.begin(), fh.end());
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const SonarFrame& f = frames[k];
    const std::string where = "ARIS frame " + std::to_string(k);
    if (f.n_beams != beams || f.n_samples != samples) return Error{where + ": geometry differs from frame 0"};
    // SonarFrame samples are in beam/sample order: the file's frames are reordered.
    const auto h = encodeArisFrameHeader(f, {.ping_mode = ping_mode_for_beams, .reordered_samples = true});
    if (!h.ok()) return Error{where + ": " + h.error().message};
    out.insert(out.end(), h->begin(), h->end());
    out.insert(out.end(), f.samples.begin(), f.samples.end());
  }
  return out;
}

namespace {

struct DdfSizes {
  std::size_t file_header;
  std::size_t frame_header;
};

Result<DdfSizes> ddfSizes(int version) {
  if (version == 3) return DdfSizes{512, 256};
  if (version == 4) return DdfSizes{1024, 1024};
  return Error{"DDF version " + std::to_string(version) + " unsupported (3, 4 or 5)"};
}

// DDF v3/v4 frame header offsets (see sonar_files.hpp).
constexpr std::size_t kDdfFrameIndex = 0;
constexpr std::size_t kDdfFrameTime = 4;
constexpr std::size_t kDdfWindowStartCode = 52;
constexpr std::size_t kDdfWindowLengthCode = 56;
constexpr std::size_t kDdfConfigFlags = 192;  // bit 0: 1 classic, 0 extended windows; bit 1: long range
constexpr std::size_t kDdfFileHighResolution = 12;

}  // namespace

Result<SonarRecording> decodeDdfFile(std::span<const std::uint8_t> b, const SonarFileLimits& limits) {
  if (b.size() < 4 || b[0] != 'D' || b[1] != 'D' || b[2] != 'F') return Error{"not a DDF file: no \"DDF\" signature"};
  const int version = b[3];
  if (version == 5) return decodeArisFile(b, limits);
  const auto sizes = ddfSizes(version);
  if (!sizes.ok()) return sizes.error();
  if (b.size() < sizes->file_header) {
    return Error{"DDF v" + std::to_string(version) + " file shorter than its " + std::to_string(sizes->file_header) +
                 "-byte header"};
  }
  SonarRecording rec;
  rec.ddf_version = version;
  rec.header_frame_count = readU32LE(b, 4);
  rec.high_frequency = readU32LE(b, kDdfFileHighResolution) != 0;
  const std::uint32_t beams = readU32LE(b, 16);
  if (beams != 48 && beams != 96) return Error{"DDF: NumRawBeams " + std::to_string(beams) + " is not 48 or 96"};
  const double scale = rec.high_frequency ? 1.0 : 2.0;
  const std::size_t data_bytes = static_cast<std::size_t>(beams) * kDidsonSamples;
  std::size_t pos = sizes->file_header;
  while (pos < b.size()) {
    const std::size_t k = rec.frames.size();
    if (b.size() - pos < sizes->frame_header + data_bytes) {
      rec.truncated_bytes = b.size() - pos;
      break;
    }
    if (k >= limits.max_frames) return Error{"DDF file has more than " + std::to_string(limits.max_frames) + " frames"};
    const auto h = b.subspan(pos, sizes->frame_header);
    const std::string where = "DDF frame " + std::to_string(k);
    const std::uint32_t start_code = readU32LE(h, kDdfWindowStartCode);
    const std::uint32_t length_code = readU32LE(h, kDdfWindowLengthCode);
    if (length_code > 3) {
      return Error{where + ": window length code " + std::to_string(length_code) + " not in 0..3"};
    }
    if (start_code > 255) return Error{where + ": window start code " + std::to_string(start_code) + " above 255"};
    const std::uint32_t config_flags = readU32LE(h, kDdfConfigFlags) & 3U;
    const bool classic = (config_flags & 1U) != 0;
    const bool long_range = (config_flags & 2U) != 0;
    const std::size_t length_index = length_code + (rec.high_frequency ? 0 : 2);
    double length_m = 0.0;
    if (classic) {
      length_m = kDidsonWindowLength_m[length_index] * (long_range ? 2.0 : 1.0);
    } else {
      length_m = (long_range ? kDidsonLongRangeExtendedWindowLength_m : kDidsonExtendedWindowLength_m)[length_index];
      if (length_m == 0.0) {
        return Error{where + ": extended window length code 0 at high frequency (ConfigFlags " +
                     std::to_string(config_flags) + "): its length is not known"};
      }
    }
    const auto stamp = usToNs(readU64LE(h, kDdfFrameTime));
    if (!stamp.ok()) return Error{where + ": " + stamp.error().message};
    SonarFrame f;
    f.stamp_ns = *stamp;
    f.frame_index = readU32LE(h, kDdfFrameIndex);
    f.n_beams = static_cast<int>(beams);
    f.n_samples = kDidsonSamples;
    f.window_start_m = start_code * (classic ? kDidsonStartStep_m : kDidsonExtendedStartStep_m) * scale;
    f.window_length_m = length_m;
    const auto data = b.subspan(pos + sizes->frame_header, data_bytes);
    f.samples.assign(data.begin(), data.end());
    rec.frames.push_back(std::move(f));
    pos += sizes->frame_header + data_bytes;
  }
  return rec;
}

Result<std::vector<std::uint8_t>> encodeDdfFile(std::span<const SonarFrame> frames, int version, bool high_frequency) {
  const auto sizes = ddfSizes(version);
  if (!sizes.ok()) return sizes.error();
  const int beams = frames.empty() ? 96 : frames.front().n_beams;
  if (beams != 48 && beams != 96) return Error{"DDF: " + std::to_string(beams) + " beams, DIDSON has 48 or 96"};
  const double scale = high_frequency ? 1.0 : 2.0;
  std::array<std::uint8_t, 1024> fh{};  // v3 uses the first 512 bytes
  fh[0] = 'D';
  fh[1] = 'D';
  fh[2] = 'F';
  fh[3] = static_cast<std::uint8_t>(version);
  writeU32LE(fh, 4, static_cast<std::uint32_t>(frames.size()));
  writeU32LE(fh, kDdfFileHighResolution, high_frequency ? 1U : 0U);
  writeU32LE(fh, 16, static_cast<std::uint32_t>(beams));
  writeU32LE(fh, 24, static_cast<std::uint32_t>(kDidsonSamples));
  std::vector<std::uint8_t> out(fh.begin(), fh.begin() + static_cast<std::ptrdiff_t>(sizes->file_header));
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const SonarFrame& f = frames[k];
    const std::string where = "DDF frame " + std::to_string(k);
    if (f.n_beams != beams || f.n_samples != kDidsonSamples ||
        f.samples.size() != static_cast<std::size_t>(beams) * kDidsonSamples) {
      return Error{where + ": must have " + std::to_string(beams) + " beams x 512 samples"};
    }
    const double start_code = f.window_start_m / (kDidsonStartStep_m * scale);
    if (!(start_code >= 0.0 && start_code <= 255.0) || std::abs(start_code - std::round(start_code)) > 1e-6) {
      return Error{where + ": window start " + std::to_string(f.window_start_m) + " m is not a DIDSON start code"};
    }
    // Classic windows of a standard DIDSON: codes 0-3 index the table from 0 (high) or 2 (low).
    const std::size_t first = high_frequency ? 0 : 2;
    std::size_t length_code = 4;
    for (std::size_t i = 0; i < 4; ++i) {
      if (std::abs(kDidsonWindowLength_m[first + i] - f.window_length_m) < 1e-9) length_code = i;
    }
    if (length_code == 4) {
      return Error{where + ": window length " + std::to_string(f.window_length_m) + " m is not a DIDSON window"};
    }
    if (f.stamp_ns < 0) return Error{where + ": negative stamp_ns"};
    std::array<std::uint8_t, 1024> h{};  // v3 uses the first 256 bytes
    writeU32LE(h, kDdfFrameIndex, f.frame_index);
    writeU64LE(h, kDdfFrameTime, static_cast<std::uint64_t>(f.stamp_ns / 1000));
    writeU32LE(h, kDdfWindowStartCode, static_cast<std::uint32_t>(std::lround(start_code)));
    writeU32LE(h, kDdfWindowLengthCode, static_cast<std::uint32_t>(length_code));
    writeU32LE(h, kDdfConfigFlags, 1U);  // classic windows, standard range
    out.insert(out.end(), h.begin(), h.begin() + static_cast<std::ptrdiff_t>(sizes->frame_header));
    out.insert(out.end(), f.samples.begin(), f.samples.end());
  }
  return out;
}

Result<std::vector<std::uint8_t>> loadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{"cannot open " + path.string()};
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return Error{"read error on " + path.string()};
  return bytes;
}

}  // namespace vog::sonar
