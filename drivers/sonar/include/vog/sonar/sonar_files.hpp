#pragma once
// DIDSON / ARIS recording files (DDF). Readers and writers work on byte buffers (pure); loadFile()
// is the only function here that touches the file system.
//
// ARIS (DDF v5, signature 0x05464444 little-endian = "DDF\x05"): 1024-byte file header, then per
// frame a 1024-byte frame header and beams * samples bytes, sample-major. Offsets follow the field
// tables ../shared/data/aris/{File,Frame}Header.fields.csv (fields packed in listed order) and were
// checked against ../shared/data/aris/sample.aris:
//   file header:  0 Version, 4 FrameCount, 16 NumRawBeams, 24 SamplesPerChannel
//   frame header: 0 FrameIndex, 4 FrameTime (u64 us since the Unix epoch), 12 Version,
//                 52 WindowStart (f32, as set), 56 WindowLength (f32, as set), 436 PingMode,
//                 452 SamplePeriod (u32 us), 464 SoundSpeed (f32 m/s), 468 SamplesPerBeam,
//                 476 SampleStartDelay (u32 us), 516 ReorderedSamples (u32, 0 = sonar order),
//                 520 Salinity (u32, parts per thousand: 0 fresh, 15 brackish, 35 salt),
//                 680 AppliedSettings (u32, the cookie of the acoustic settings the frame was made
//                 with: "cookie indices for command acknowledge", FrameHeader.fields.csv)
// The live frame stream (aris_frame_assembler.hpp) sends the same header, unpadded.
// The window actually sampled is start = SampleStartDelay * 1e-6 * c / 2 and sample length =
// SamplePeriod * 1e-6 * c / 2 (ARIS File SDK, "range of a sample"), which is what SonarFrame holds.
//
// DIDSON DDF v3 / v4: "DDF" + version byte; file header 512 (v3) or 1024 (v4) bytes, frame header
// 256 (v3) or 1024 (v4) bytes, then beams x 512 bytes sample-major. The file header shares the
// ARIS prefix (4 FrameCount, 8 FrameRate, 12 HighResolution, 16 NumRawBeams); the frame header
// carries 0 FrameIndex, 4 FrameTime (8 bytes, read as u64 us), 52 window start code (u32), 56
// window length code (u32, 0..3), 192 ConfigFlags (bit 0 classic/extended windows, bit 1 long
// range). Classic windows: length {1.125, 2.25, 4.5, 9} m for codes 0-3 at high frequency, {4.5, 9,
// 18, 36} m at low frequency (doubled for a long-range DIDSON); start = code x 0.375 m (x 0.75 m at
// low frequency). Extended windows: 0.419 m start steps and their own lengths. The layouts, the
// public readers they were checked against and where those disagree: drivers/sonar/README.md. The
// DDF frame header holds no sound speed (the windows are in metres): frames keep the nominal one.

#include "vog/core/result.hpp"
#include "vog/sonar/sonar_frame.hpp"

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace vog::sonar {

// Per-frame ARIS header fields kept for display and checks.
struct ArisFrameMeta {
  std::uint32_t frame_index = 0;
  std::uint64_t frame_time_us = 0;
  std::uint32_t ping_mode = 0;
  std::uint32_t sample_start_delay_us = 0;
  std::uint32_t sample_period_us = 0;
  float header_window_start_m = 0.0f;   // WindowStart field as written by the recorder
  float header_window_length_m = 0.0f;  // WindowLength field as written by the recorder
  std::uint32_t samples_per_beam = 0;   // SamplesPerBeam (0 in some files: SamplesPerChannel applies)
  float sound_speed_mps = 0.0f;         // SoundSpeed
  bool reordered_samples = false;       // ReorderedSamples: data already in beam/sample order
  std::uint32_t salinity = 0;           // Salinity: parts per thousand (SET_SALINITY's value)
  std::uint32_t settings_cookie = 0;    // AppliedSettings: cookie of SetAcousticSettings in effect
};

// Bytes of an ARIS frame header that hold every field ArisFrameMeta reads (up to AppliedSettings);
// a file's header is 1024 bytes, the live stream's may be shorter.
inline constexpr std::size_t kArisFrameHeaderUsedBytes = 684;

// Reads the ArisFrameMeta fields of one frame header; error if it is shorter than
// kArisFrameHeaderUsedBytes. No value is checked here (arisFrameFromMeta does).
Result<ArisFrameMeta> decodeArisFrameHeader(std::span<const std::uint8_t> header);

struct SonarRecording {
  int ddf_version = 0;  // 3, 4 or 5 (ARIS)
  std::uint32_t header_frame_count = 0;
  bool high_frequency = true;  // DDF v3/v4 only
  std::vector<SonarFrame> frames;
  std::vector<ArisFrameMeta> aris_meta;  // one per frame for ARIS, empty otherwise
  std::size_t truncated_bytes = 0;       // bytes of an incomplete last frame (recording cut short)
};

struct SonarFileLimits {
  int max_beams = 128;
  int max_samples = 4096;
  std::size_t max_frames = 100000;
};

// ARIS beams per PingMode (1-2 -> 48, 3-5 -> 96, 6-8 -> 64, 9-12 -> 128); error otherwise.
Result<int> arisBeamsForPingMode(std::uint32_t ping_mode);

// The frame a header describes, samples left empty: beams from PingMode, `samples` per beam,
// stamp from FrameTime, window from SampleStartDelay, SamplePeriod and SoundSpeed. Error (naming
// the field and its value) if PingMode is unknown, beams or samples exceed the limits, the sound
// speed is outside [1000, 2000] m/s or SamplePeriod is 0. Shared by the file and live paths.
Result<SonarFrame> arisFrameFromMeta(const ArisFrameMeta& meta, std::uint32_t samples, const SonarFileLimits& limits);

Result<SonarRecording> decodeArisFile(std::span<const std::uint8_t> bytes, const SonarFileLimits& limits = {});
// Frames must share beams and samples; beams must be 48, 64, 96 or 128. SampleStartDelay and
// SamplePeriod are rounded to whole microseconds (the window after a round trip is the quantised one).
Result<std::vector<std::uint8_t>> encodeArisFile(std::span<const SonarFrame> frames);

// The ARIS frame header fields a frame does not determine.
struct ArisHeaderOptions {
  std::uint32_t ping_mode = 1;        // must have the frame's beam count
  bool reordered_samples = true;      // ReorderedSamples: false when the data will be in sonar order
  std::uint32_t settings_cookie = 0;  // AppliedSettings
  std::uint32_t salinity = 0;         // Salinity, parts per thousand (0 fresh, 15 brackish, 35 salt)
};
// The 1024-byte ARIS frame header of `frame`, as encodeArisFile writes it (same rounding and errors).
Result<std::vector<std::uint8_t>> encodeArisFrameHeader(const SonarFrame& frame, const ArisHeaderOptions& options);

// DDF v3, v4 (and v5, forwarded to decodeArisFile).
Result<SonarRecording> decodeDdfFile(std::span<const std::uint8_t> bytes, const SonarFileLimits& limits = {});
// version 3 or 4; frames must have 512 samples, 48 or 96 beams, and a window that is one of the
// classic codes (start a multiple of 0.375 m, length in the table; doubled for low frequency).
Result<std::vector<std::uint8_t>> encodeDdfFile(std::span<const SonarFrame> frames, int version,
                                                bool high_frequency = true);

// Whole file into memory; error names the path.
Result<std::vector<std::uint8_t>> loadFile(const std::filesystem::path& path);

}  // namespace vog::sonar
