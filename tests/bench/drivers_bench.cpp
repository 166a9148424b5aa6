// vog-bench drivers: PD0 decode throughput (MB/s), sonar range extraction (frames/s on 96 x 512
// frames) and the ARIS live path (frames/s: FramePart datagrams assembled, reordered and their
// ranges extracted, for 128 x 512 and 96 x 2000 frames), single thread, medians over repeats.
// Targets: >= 100 MB/s and >= 2000 frames/s.
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/sonar/aris_reorder.hpp"
#include "vog/sonar/sonar_files.hpp"
#include "vog/sonar/range_extraction.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <iostream>
#include <optional>
#include <span>
#include <string>
#include <random>

namespace {

// A WorkHorse-sized ensemble: 30 cells, 4 beams, bottom track (like ../shared/data/pd0 plus BT).
vog::dvl::DvlEnsemble benchEnsemble(std::uint32_t n, std::mt19937& rng) {
  vog::dvl::DvlEnsemble e;
  e.fixed.n_beams = 4;
  e.fixed.coordinate_frame = vog::dvl::CoordinateFrame::kEarth;
  e.fixed.beam_angle_deg = 20;
  e.variable.ensemble_number = n;
  e.variable.clock = {2026, 11, 21, 12, 0, static_cast<int>(n % 60), static_cast<int>(n % 100)};
  e.variable.sound_speed_mps = 1500;
  e.variable.heading_deg = static_cast<double>(rng() % 36000) / 100.0;
  std::uniform_real_distribution<double> v(-1.0, 1.0);
  e.cell_velocity_mps.resize(30);
  e.cell_velocity_valid.assign(30, {true, true, true, true});
  for (auto& c : e.cell_velocity_mps) c = {v(rng), v(rng), v(rng), v(rng)};
  vog::dvl::DvlBottomTrack bt;
  bt.velocity_mps = {v(rng), v(rng), v(rng), v(rng)};
  bt.velocity_valid = {true, true, true, true};
  bt.range_m = {10, 10, 10, 10};
  e.bottom_track = bt;
  return e;
}

// A frame with one sloping return across the beams over noise (the 96 x 512 case is the range
// extraction figure's frame).
vog::sonar::SonarFrame benchFrame(int beams, int samples, std::mt19937& rng) {
  vog::sonar::SonarFrame f;
  f.n_beams = beams;
  f.n_samples = samples;
  f.window_start_m = 0.75;
  f.window_length_m = 9.0 * samples / 512.0;
  f.samples.resize(static_cast<std::size_t>(beams) * static_cast<std::size_t>(samples));
  std::uniform_int_distribution<int> noise(0, 40);
  const int target = samples * 150 / 512 + static_cast<int>(rng() % static_cast<unsigned>(samples * 200 / 512));
  for (int s = 0; s < samples; ++s) {
    for (int b = 0; b < beams; ++b) {
      const bool hit = s >= target + b && s < target + b + 10;
      f.samples[static_cast<std::size_t>(s * beams + b)] = static_cast<std::uint8_t>(hit ? 200 : noise(rng));
    }
  }
  return f;
}

// What an ARIS sends for `frames` frames of one geometry: FramePart datagrams of `part_bytes`, data
// in sonar order, frame indices 1..frames (16 distinct images, reused).
std::vector<std::vector<std::uint8_t>> arisDatagrams(std::uint32_t ping_mode, int samples, int frames,
                                                     std::size_t part_bytes, std::mt19937& rng) {
  const int beams = *vog::sonar::arisBeamsForPingMode(ping_mode);
  std::vector<vog::sonar::SonarFrame> images;
  for (int i = 0; i < 16; ++i) images.push_back(benchFrame(beams, samples, rng));
  std::vector<std::vector<std::uint8_t>> out;
  std::vector<std::uint8_t> sonar_order(images[0].samples.size());
  for (int k = 0; k < frames; ++k) {
    vog::sonar::SonarFrame f = images[static_cast<std::size_t>(k) % images.size()];
    f.frame_index = static_cast<std::uint32_t>(k + 1);
    const auto header = vog::sonar::encodeArisFrameHeader(f, {.ping_mode = ping_mode, .reordered_samples = false});
    if (!header.ok() ||
        !vog::sonar::arisBeamToSonarOrder(ping_mode, static_cast<std::uint32_t>(samples), f.samples, sonar_order)
             .ok()) {
      return {};
    }
    for (std::size_t off = 0; off < sonar_order.size(); off += part_bytes) {
      const std::size_t n = std::min(part_bytes, sonar_order.size() - off);
      out.push_back(vog::sonar::encodeArisFramePart(
          {.frame_index = k + 1,
           .total_data_size = static_cast<std::int32_t>(sonar_order.size()),
           .header = off == 0 ? std::span<const std::uint8_t>(*header) : std::span<const std::uint8_t>(),
           .data = std::span(sonar_order).subspan(off, n),
           .data_offset = static_cast<std::int32_t>(off),
           .ack_port = 56889}));
    }
  }
  return out;
}

// Frames per second through the live path: assemble (decode, copy, ack), reorder, extract ranges.
// Empty when a frame does not complete or its ranges fail.
std::optional<double> arisFramesPerSecond(const std::vector<std::vector<std::uint8_t>>& datagrams, int frames,
                                          const vog::sonar::RangeExtractionConfig& config) {
  vog::sonar::ArisFrameAssembler assembler;
  std::size_t completed = 0;
  const vog::bench::Stopwatch clock;
  for (const auto& d : datagrams) {
    const auto r = assembler.add(d, 0.0);
    if (!r.frame) continue;
    const auto scan = vog::sonar::extractRanges(r.frame->frame, config);
    if (!scan.ok()) return std::nullopt;
    ++completed;
  }
  const double s = clock.seconds();
  if (completed != static_cast<std::size_t>(frames)) return std::nullopt;
  return frames / s;
}

}  // namespace

VOG_BENCH_COMMAND(drivers,
                  "Device codecs: PD0 decode MB/s, sonar range extraction frames/s (96 x 512), ARIS live frames/s") {
  int repeats = 7;
  int megabytes = 16;
  int frames = 2000;
  int aris_frames = 200;
  std::size_t aris_part_bytes = 8192;
  unsigned seed = 1;
  bool json = false;
  CLI::App app{"vog-bench drivers"};
  app.add_option("--repeats", repeats, "timed repeats (median reported)")->check(CLI::Range(1, 1000));
  app.add_option("--megabytes", megabytes, "PD0 stream size per repeat")->check(CLI::Range(1, 1024));
  app.add_option("--frames", frames, "sonar frames per repeat")->check(CLI::Range(1, 100000));
  app.add_option("--aris-frames", aris_frames, "ARIS frames per repeat")->check(CLI::Range(1, 10000));
  app.add_option("--aris-part-bytes", aris_part_bytes, "frame data bytes per FramePart datagram")
      ->check(CLI::Range(64, 65000));
  app.add_option("--seed", seed, "data seed");
  app.add_flag("--json", json, "print JSON (the only output format)");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;
  std::mt19937 rng(seed);

  // PD0: a stream of distinct ensembles decoded through the stream decoder, as the driver does.
  std::vector<std::uint8_t> stream;
  std::uint32_t n = 0;
  while (stream.size() < static_cast<std::size_t>(megabytes) * 1000000) {
    const auto bytes = vog::dvl::encodePd0(benchEnsemble(++n, rng));
    stream.insert(stream.end(), bytes.begin(), bytes.end());
  }
  std::vector<double> mbps;
  std::size_t decoded = 0;
  for (int r = 0; r < repeats; ++r) {
    const vog::bench::Stopwatch clock;
    const auto out = vog::codec::decodeAll<vog::dvl::Pd0Codec>(stream);
    const double s = clock.seconds();
    decoded = out.frames.size();
    mbps.push_back(static_cast<double>(stream.size()) / 1e6 / s);
  }
  if (decoded != n) {
    std::cerr << "drivers bench: decoded " << decoded << " of " << n << " ensembles\n";
    return 1;
  }

  // Range extraction on distinct frames (generation not timed).
  std::vector<vog::sonar::SonarFrame> sonar_frames;
  for (int i = 0; i < 64; ++i) sonar_frames.push_back(benchFrame(96, 512, rng));
  const vog::sonar::RangeExtractionConfig config;
  std::vector<double> fps;
  std::size_t returns = 0;
  for (int r = 0; r < repeats; ++r) {
    returns = 0;
    const vog::bench::Stopwatch clock;
    for (int i = 0; i < frames; ++i) {
      const auto scan =
          vog::sonar::extractRanges(sonar_frames[static_cast<std::size_t>(i) % sonar_frames.size()], config);
      if (!scan.ok()) return 1;
      for (const float x : scan->range_m) returns += x != vog::geometry::RangeScan::kNoReturn ? 1 : 0;
    }
    fps.push_back(frames / clock.seconds());
  }

  // ARIS live path, per geometry: {PingMode, samples}.
  struct ArisCase {
    const char* key;
    std::uint32_t ping_mode;
    int samples;
    std::vector<double> fps;
  };
  std::vector<ArisCase> aris_cases = {{"aris_128x512", 9, 512, {}}, {"aris_96x2000", 3, 2000, {}}};
  for (auto& c : aris_cases) {
    const auto datagrams = arisDatagrams(c.ping_mode, c.samples, aris_frames, aris_part_bytes, rng);
    for (int r = 0; r < repeats; ++r) {
      const auto fps_once = arisFramesPerSecond(datagrams, aris_frames, config);
      if (!fps_once) {
        std::cerr << "drivers bench: " << c.key << ": a frame did not complete or its ranges failed\n";
        return 1;
      }
      c.fps.push_back(*fps_once);
    }
  }

  vog::bench::JsonObject j;
  j.add("pd0_stream_bytes", static_cast<std::int64_t>(stream.size()));
  j.add("pd0_ensembles", static_cast<std::int64_t>(n));
  j.add("pd0_decode_mb_per_s_median", vog::bench::median(mbps));
  j.add("pd0_decode_target_mb_per_s", 100.0);
  j.add("range_extraction_frames_per_s_median", vog::bench::median(fps));
  j.add("range_extraction_target_frames_per_s", 2000.0);
  j.add("range_extraction_returns_per_frame", static_cast<double>(returns) / frames);
  for (const auto& c : aris_cases) j.add(std::string(c.key) + "_frames_per_s_median", vog::bench::median(c.fps));
  j.add("aris_frames_per_repeat", aris_frames);
  j.add("aris_part_bytes", static_cast<std::int64_t>(aris_part_bytes));
  j.add("repeats", repeats);
  std::cout << j.str();
  return 0;
}
