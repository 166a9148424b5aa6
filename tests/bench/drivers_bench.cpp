// vog-bench drivers: PD0 decode throughput (MB/s), sonar range extraction (frames/s on 96 x 512
// frames) and the ARIS live path (frames/s: FramePart datagrams assembled, reordered and their
// ranges extracted, for 128 x 512 and 96 x 2000 frames), single thread, medians over repeats.
// Targets: >= 100 MB/s and >= 2000 frames/s. Also the ARIS link's loss figures: frames lost per frame
// sent and datagrams resent per frame, mock sonar to receiver over a seeded lossy channel.
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/mock/aris_frame_sender.hpp"
#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/sonar/aris_reorder.hpp"
#include "vog/sonar/sonar_files.hpp"
#include "vog/sonar/range_extraction.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <iostream>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <random>
#include <utility>
#include <vector>

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

// The ARIS link under loss: `frames` frames sent by the mock sonar (ArisFrameSender) at
// `frame_rate_hz` of simulated time to a receiver with the default config; every datagram and every
// ack is lost with probability `loss` (seeded), none is delayed. The sender is polled at its
// deadlines until the next frame is due (the last frame until it is done).
struct ArisLossFigures {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_delivered = 0;
  std::uint64_t frames_with_a_lost_part = 0;  // a datagram of the frame (first send or resend) was lost
  std::uint64_t datagrams_resent = 0;
  std::uint64_t frames_given_up = 0;
  std::uint64_t receiver_refused = 0;
};

std::optional<ArisLossFigures> arisLossFigures(const std::vector<vog::sonar::SonarFrame>& images,
                                               std::uint32_t ping_mode, int frames, double frame_rate_hz,
                                               const vog::mock::ArisFrameSenderConfig& config, double loss,
                                               unsigned seed) {
  vog::mock::ArisFrameSender sender(config);
  vog::sonar::ArisFrameAssembler receiver;
  std::mt19937 rng(seed);
  std::bernoulli_distribution lost(loss);
  ArisLossFigures out;
  bool part_lost = false;  // of the frame being sent
  const auto deliver = [&](const std::vector<vog::mock::ArisFrameSender::Datagram>& datagrams, double t) {
    for (const auto& d : datagrams) {
      if (lost(rng)) {
        part_lost = true;
        continue;
      }
      const auto r = receiver.add(d, t);
      if (r.frame) ++out.frames_delivered;
      if (r.ack && !lost(rng)) sender.onAck(vog::sonar::encodeArisFramePartAck(*r.ack), t);
    }
  };
  for (int k = 0; k < frames; ++k) {
    vog::sonar::SonarFrame f = images[static_cast<std::size_t>(k) % images.size()];
    f.frame_index = static_cast<std::uint32_t>(k + 1);
    const double t0 = k / frame_rate_hz;
    const double next_s = k + 1 < frames ? (k + 1) / frame_rate_hz : std::numeric_limits<double>::infinity();
    const auto parts = sender.send(f, {.ping_mode = ping_mode}, t0);
    if (!parts.ok()) return std::nullopt;
    part_lost = false;
    deliver(*parts, t0);
    while (const auto deadline = sender.nextDeadline()) {
      if (*deadline >= next_s) break;
      deliver(sender.poll(*deadline), *deadline);
    }
    out.frames_with_a_lost_part += part_lost ? 1 : 0;
  }
  out.frames_sent = sender.stats().frames_sent;
  out.datagrams_resent = sender.stats().datagrams_resent;
  out.frames_given_up = sender.stats().frames_given_up;
  out.receiver_refused = receiver.stats().refusedTotal();
  return out;
}

}  // namespace

VOG_BENCH_COMMAND(drivers,
                  "Device codecs: PD0 decode MB/s, sonar range extraction frames/s (96 x 512), ARIS live frames/s") {
  int repeats = 7;
  int megabytes = 16;
  int frames = 2000;
  int aris_frames = 200;
  int aris_loss_frames = 300;
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
  app.add_option("--aris-loss-frames", aris_loss_frames, "ARIS frames per loss case (15 frames/s of simulated time)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--seed", seed, "data and loss seed");
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

  // ARIS link under 1 % and 5 % loss both ways, without retry (DROP_PARTIAL_FRAMES) and with it
  // (PESSIMISTIC_RETRY with the sender's default timeout and retries, resending through the end of
  // the frame; "retry_one_part": one part per resend). Simulated time: not repeated.
  struct ArisLossCase {
    std::string key;
    double loss;
    vog::mock::ArisPacketLossMitigation mode;
    std::size_t max_parts_per_resend;
    ArisLossFigures figures;
  };
  using vog::mock::ArisPacketLossMitigation;
  std::vector<ArisLossCase> loss_cases;
  for (const auto& [pct, loss] : {std::pair{"1pct", 0.01}, std::pair{"5pct", 0.05}}) {
    const std::string prefix = std::string("aris_loss_") + pct;
    loss_cases.push_back({prefix + "_drop", loss, ArisPacketLossMitigation::kDropPartialFrames, 0, {}});
    loss_cases.push_back({prefix + "_retry", loss, ArisPacketLossMitigation::kPessimisticRetry, 0, {}});
    loss_cases.push_back({prefix + "_retry_one_part", loss, ArisPacketLossMitigation::kPessimisticRetry, 1, {}});
  }
  const vog::mock::ArisFrameSenderConfig sender_defaults;
  {
    std::vector<vog::sonar::SonarFrame> images;
    for (int i = 0; i < 16; ++i) images.push_back(benchFrame(128, 512, rng));
    for (auto& c : loss_cases) {
      vog::mock::ArisFrameSenderConfig sender_config = sender_defaults;
      sender_config.mode = c.mode;
      sender_config.max_parts_per_resend = c.max_parts_per_resend;
      sender_config.part_bytes = aris_part_bytes;
      if (const vog::Status valid = sender_config.validate(); !valid.ok()) {
        std::cerr << "drivers bench: " << valid.error().message << "\n";
        return 1;
      }
      const auto figures = arisLossFigures(images, 9, aris_loss_frames, 15.0, sender_config, c.loss, seed);
      if (!figures) {
        std::cerr << "drivers bench: " << c.key << ": the sender refused a frame\n";
        return 1;
      }
      c.figures = *figures;
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
  for (const auto& c : loss_cases) {
    const auto sent = static_cast<double>(c.figures.frames_sent);
    j.add(c.key + "_frames_lost_ratio", static_cast<double>(c.figures.frames_sent - c.figures.frames_delivered) / sent);
    j.add(c.key + "_datagrams_resent_per_frame", static_cast<double>(c.figures.datagrams_resent) / sent);
    j.add(c.key + "_frames_with_a_lost_part_ratio", static_cast<double>(c.figures.frames_with_a_lost_part) / sent);
    j.add(c.key + "_frames_given_up", static_cast<std::int64_t>(c.figures.frames_given_up));
    j.add(c.key + "_receiver_refused", static_cast<std::int64_t>(c.figures.receiver_refused));
  }
  j.add("aris_loss_frames", aris_loss_frames);
  j.add("aris_loss_frame_rate_hz", 15.0);
  j.add("aris_loss_retry_timeout_s", sender_defaults.retry_timeout_s);
  j.add("aris_loss_max_retries", sender_defaults.max_retries);
  j.add("repeats", repeats);
  std::cout << j.str();
  return 0;
}
