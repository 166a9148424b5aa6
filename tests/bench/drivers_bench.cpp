// vog-bench drivers: PD0 decode throughput (MB/s) and sonar range extraction (frames/s on 96 x 512
// frames), single thread, medians over repeats. Targets: >= 100 MB/s and >= 2000 frames/s.
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/sonar/range_extraction.hpp"

#include <CLI/CLI.hpp>

#include <iostream>
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

vog::sonar::SonarFrame benchFrame(std::mt19937& rng) {
  vog::sonar::SonarFrame f;
  f.n_beams = 96;
  f.n_samples = 512;
  f.window_start_m = 0.75;
  f.window_length_m = 9.0;
  f.samples.resize(96 * 512);
  std::uniform_int_distribution<int> noise(0, 40);
  const int target = 150 + static_cast<int>(rng() % 200);
  for (int s = 0; s < 512; ++s) {
    for (int b = 0; b < 96; ++b) {
      const bool hit = s >= target + b && s < target + b + 10;
      f.samples[static_cast<std::size_t>(s * 96 + b)] = static_cast<std::uint8_t>(hit ? 200 : noise(rng));
    }
  }
  return f;
}

}  // namespace

VOG_BENCH_COMMAND(drivers, "Device codecs: PD0 decode MB/s, sonar range extraction frames/s (96 x 512)") {
  int repeats = 7;
  int megabytes = 16;
  int frames = 2000;
  unsigned seed = 1;
  bool json = false;
  CLI::App app{"vog-bench drivers"};
  app.add_option("--repeats", repeats, "timed repeats (median reported)")->check(CLI::Range(1, 1000));
  app.add_option("--megabytes", megabytes, "PD0 stream size per repeat")->check(CLI::Range(1, 1024));
  app.add_option("--frames", frames, "sonar frames per repeat")->check(CLI::Range(1, 100000));
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
  for (int i = 0; i < 64; ++i) sonar_frames.push_back(benchFrame(rng));
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

  vog::bench::JsonObject j;
  j.add("pd0_stream_bytes", static_cast<std::int64_t>(stream.size()));
  j.add("pd0_ensembles", static_cast<std::int64_t>(n));
  j.add("pd0_decode_mb_per_s_median", vog::bench::median(mbps));
  j.add("pd0_decode_target_mb_per_s", 100.0);
  j.add("range_extraction_frames_per_s_median", vog::bench::median(fps));
  j.add("range_extraction_target_frames_per_s", 2000.0);
  j.add("range_extraction_returns_per_frame", static_cast<double>(returns) / frames);
  j.add("repeats", repeats);
  std::cout << j.str();
  return 0;
}
