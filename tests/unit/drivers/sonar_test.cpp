#include "vog/codec/stream_decoder.hpp"
#include "vog/sonar/range_extraction.hpp"
#include "vog/sonar/sonar_files.hpp"
#include "vog/sonar/sonar_udp.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace vog::sonar {
namespace {

SonarFrame makeFrame(int beams, int samples, std::uint32_t index, std::uint32_t seed) {
  SonarFrame f;
  f.stamp_ns = 1'700'000'000'000'000'000LL + index * 100'000'000LL;
  f.frame_index = index;
  f.n_beams = beams;
  f.n_samples = samples;
  f.window_start_m = 0.75;
  f.window_length_m = 9.0;
  f.sound_speed_mps = 1500.0;
  std::mt19937 rng(seed);
  f.samples.resize(static_cast<std::size_t>(beams) * static_cast<std::size_t>(samples));
  for (auto& v : f.samples) v = static_cast<std::uint8_t>(rng() % 256);
  return f;
}

// ../shared/data/aris/sample.aris, checked with xxd and the field tables: file header FrameCount
// (offset 4) = 6, NumRawBeams (16) = 48, SamplesPerChannel (24) = 2000; frame 0 header: FrameTime (4)
// = 1371198079122519 us, PingMode (436) = 1, SamplePeriod (452) = 14 us, SoundSpeed (464) =
// 1435.9333 m/s, SamplesPerBeam (468) = 2000, SampleStartDelay (476) = 4593 us, WindowStart (52) =
// 3.3299 m and WindowLength (56) = 20.3 m as set by the operator.
TEST(Aris, RealSampleDecodesToSixFramesOf48By2000) {
  const auto bytes = loadFile(test::sharedDataDir() / "aris" / "sample.aris");
  ASSERT_TRUE(bytes.ok()) << bytes.error().message;
  ASSERT_EQ(bytes->size(), 583168u);  // 1024 + 6 * (1024 + 48 * 2000)
  const auto rec = decodeArisFile(*bytes);
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  EXPECT_EQ(rec->ddf_version, 5);
  EXPECT_EQ(rec->header_frame_count, 6u);
  EXPECT_EQ(rec->truncated_bytes, 0u);
  ASSERT_EQ(rec->frames.size(), 6u);
  for (std::size_t k = 0; k < 6; ++k) {
    const SonarFrame& f = rec->frames[k];
    EXPECT_EQ(f.frame_index, k);
    EXPECT_EQ(f.n_beams, 48);
    EXPECT_EQ(f.n_samples, 2000);
    EXPECT_EQ(f.samples.size(), 96000u);
    EXPECT_NEAR(f.sound_speed_mps, 1435.9333, 1e-3);
    EXPECT_NEAR(f.window_start_m, 4593e-6 * 1435.9333 / 2.0, 1e-5);          // 3.2976 m
    EXPECT_NEAR(f.window_length_m, 14e-6 * 1435.9333 / 2.0 * 2000.0, 1e-4);  // 20.103 m
    EXPECT_EQ(rec->aris_meta[k].ping_mode, 1u);
    EXPECT_NEAR(rec->aris_meta[k].header_window_start_m, 3.3299, 1e-4);
    EXPECT_NEAR(rec->aris_meta[k].header_window_length_m, 20.3, 1e-4);
  }
  EXPECT_EQ(rec->frames[0].stamp_ns, 1371198079122519000LL);
  EXPECT_EQ(rec->frames[5].stamp_ns, 1371198079886496000LL);
  // Sample data is the bytes right after the frame header.
  EXPECT_EQ(rec->frames[0].samples[0], (*bytes)[2048]);
  EXPECT_EQ(rec->frames[5].samples.back(), bytes->back());
  // The same file through the DDF entry point.
  const auto via_ddf = decodeDdfFile(*bytes);
  ASSERT_TRUE(via_ddf.ok());
  EXPECT_EQ(via_ddf->frames.size(), 6u);
}

TEST(Aris, RoundTripKeepsSamplesAndQuantisedWindow) {
  std::vector<SonarFrame> frames = {makeFrame(96, 512, 0, 1), makeFrame(96, 512, 1, 2)};
  const auto bytes = encodeArisFile(frames);
  ASSERT_TRUE(bytes.ok()) << bytes.error().message;
  const auto rec = decodeArisFile(*bytes);
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  ASSERT_EQ(rec->frames.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(rec->frames[k].samples, frames[k].samples);
    EXPECT_EQ(rec->frames[k].n_beams, 96);
    EXPECT_EQ(rec->frames[k].stamp_ns, frames[k].stamp_ns);
    // 1 us of two-way travel is 0.75 mm at 1500 m/s.
    EXPECT_NEAR(rec->frames[k].window_start_m, frames[k].window_start_m, 0.00075);
    EXPECT_NEAR(rec->frames[k].sampleLength_m(), frames[k].sampleLength_m(), 0.00075);
  }
  // Once quantised, encoding is stable: decode -> encode reproduces the file byte for byte.
  const auto again = *encodeArisFile(rec->frames);
  EXPECT_EQ(*encodeArisFile(decodeArisFile(again)->frames), again);
}

TEST(Aris, TruncatedAndCorruptFilesAreReportedNotTrusted) {
  auto bytes = *encodeArisFile(std::vector<SonarFrame>{makeFrame(48, 100, 0, 3), makeFrame(48, 100, 1, 4)});
  auto cut = bytes;
  cut.resize(cut.size() - 10);
  const auto rec = decodeArisFile(cut);
  ASSERT_TRUE(rec.ok());
  EXPECT_EQ(rec->frames.size(), 1u);
  EXPECT_EQ(rec->truncated_bytes, 1024u + 4800u - 10u);
  auto bad_mode = bytes;
  bad_mode[1024 + 436] = 77;  // PingMode 77
  const auto r = decodeArisFile(bad_mode);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("PingMode 77"), std::string::npos);
  EXPECT_FALSE(decodeArisFile(std::vector<std::uint8_t>(100, 0)).ok());
}

TEST(Ddf, RoundTripV3AndV4) {
  for (const int version : {3, 4}) {
    for (const bool hf : {true, false}) {
      std::vector<SonarFrame> frames = {makeFrame(96, 512, 0, 5), makeFrame(96, 512, 1, 6)};
      for (auto& f : frames) {
        f.window_start_m = (hf ? 1.0 : 2.0) * 0.375 * 4;
        f.window_length_m = (hf ? 1.0 : 2.0) * 4.5;
      }
      const auto bytes = encodeDdfFile(frames, version, hf);
      ASSERT_TRUE(bytes.ok()) << bytes.error().message;
      EXPECT_EQ(bytes->size(), (version == 3 ? 512u + 2 * (256u + 49152u) : 1024u + 2 * (1024u + 49152u)));
      const auto rec = decodeDdfFile(*bytes);
      ASSERT_TRUE(rec.ok()) << rec.error().message;
      EXPECT_EQ(rec->ddf_version, version);
      EXPECT_EQ(rec->high_frequency, hf);
      ASSERT_EQ(rec->frames.size(), 2u);
      EXPECT_EQ(rec->frames[1].samples, frames[1].samples);
      EXPECT_DOUBLE_EQ(rec->frames[1].window_start_m, frames[1].window_start_m);
      EXPECT_DOUBLE_EQ(rec->frames[1].window_length_m, frames[1].window_length_m);
      EXPECT_EQ(rec->frames[1].stamp_ns, frames[1].stamp_ns);
    }
  }
  SonarFrame odd = makeFrame(96, 512, 0, 7);
  odd.window_length_m = 5.0;  // not a DIDSON window
  EXPECT_FALSE(encodeDdfFile(std::vector<SonarFrame>{odd}, 4).ok());
}

// A DDF v4 file laid out as the public readers read it (drivers/sonar/README.md): one frame of 96
// beams with the given window codes, Threshold (offset 60) and ConfigFlags (offset 192).
std::vector<std::uint8_t> publicLayoutDdf4(bool high_frequency, std::uint32_t start_code, std::uint32_t length_code,
                                           std::uint32_t threshold, std::uint32_t config_flags) {
  std::vector<std::uint8_t> b(1024 + 1024 + 96 * 512, 0);
  auto put = [&](std::size_t at, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
  };
  b[0] = 'D';
  b[1] = 'D';
  b[2] = 'F';
  b[3] = 4;
  put(4, 1);                        // numframes
  put(8, 7);                        // framerate
  put(12, high_frequency ? 1 : 0);  // resolution
  put(16, 96);                      // numbeams
  put(24, 512);                     // samplesperchannel
  put(1024 + 0, 1);                 // framenumber
  put(1024 + 52, start_code);       // windowstart
  put(1024 + 56, length_code);      // windowlength
  put(1024 + 60, threshold);        // threshold
  put(1024 + 192, config_flags);    // configflags
  return b;
}

TEST(Ddf, WindowsFollowThePublicLayout) {
  // Classic windows (ConfigFlags 1), a threshold set: high frequency, start 4 x 0.375 m, 2.25 m.
  auto rec = decodeDdfFile(publicLayoutDdf4(true, 4, 1, 20, 1));
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  ASSERT_EQ(rec->frames.size(), 1u);
  EXPECT_DOUBLE_EQ(rec->frames[0].window_start_m, 1.5);
  EXPECT_DOUBLE_EQ(rec->frames[0].window_length_m, 2.25);
  // Low frequency: start steps of 0.75 m, lengths 4.5, 9, 18, 36 m for codes 0-3.
  rec = decodeDdfFile(publicLayoutDdf4(false, 4, 0, 20, 1));
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  EXPECT_DOUBLE_EQ(rec->frames[0].window_start_m, 3.0);
  EXPECT_DOUBLE_EQ(rec->frames[0].window_length_m, 4.5);
  rec = decodeDdfFile(publicLayoutDdf4(false, 0, 3, 0, 1));
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  EXPECT_DOUBLE_EQ(rec->frames[0].window_length_m, 36.0);
  // A long-range DIDSON (bit 1): classic lengths doubled.
  rec = decodeDdfFile(publicLayoutDdf4(true, 0, 1, 0, 3));
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  EXPECT_DOUBLE_EQ(rec->frames[0].window_length_m, 4.5);
  // Extended windows (bit 0 clear): 0.419 m start steps, their own lengths; code 0 at high
  // frequency, on which the readers disagree, is refused by name.
  rec = decodeDdfFile(publicLayoutDdf4(true, 4, 2, 0, 0));
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  EXPECT_DOUBLE_EQ(rec->frames[0].window_start_m, 4 * 0.419);
  EXPECT_DOUBLE_EQ(rec->frames[0].window_length_m, 5.0);
  rec = decodeDdfFile(publicLayoutDdf4(true, 4, 0, 0, 2));
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  EXPECT_DOUBLE_EQ(rec->frames[0].window_length_m, 2.5);  // long range, extended
  rec = decodeDdfFile(publicLayoutDdf4(true, 4, 0, 0, 0));
  ASSERT_FALSE(rec.ok());
  EXPECT_TRUE(test::contains(rec.error().message, "extended window length code 0")) << rec.error().message;
}

TEST(SonarUdp, FragmentsReassembleInAnyOrderAndLossDropsOnlyThatFrame) {
  const SonarFrame a = makeFrame(96, 512, 10, 8);
  const SonarFrame b = makeFrame(96, 512, 11, 9);
  auto da = encodeSonarDatagrams(a);
  auto db = encodeSonarDatagrams(b);
  ASSERT_TRUE(da.ok() && db.ok());
  ASSERT_EQ(da->size(), (49152u + 1399u) / 1400u);
  for (const auto& d : *da) EXPECT_LE(d.size(), 1472u);  // fits a 1500-byte MTU with IP and UDP headers
  std::vector<std::vector<std::uint8_t>> all = *da;
  all.insert(all.end(), db->begin(), db->end() - 1);  // b's last fragment lost
  std::mt19937 rng(3);
  std::shuffle(all.begin(), all.end(), rng);
  all.push_back((*da)[0]);  // a late duplicate

  FrameReassembler reassembler(2);
  std::vector<SonarFrame> done;
  for (const auto& d : all) {
    auto r = SonarUdpCodec{}.decode(d);
    ASSERT_TRUE(r.isFrame()) << r.reason();
    EXPECT_EQ(r.consumed(), d.size());
    if (auto f = reassembler.add(r.frame())) done.push_back(std::move(*f));
  }
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].frame_index, 10u);
  EXPECT_EQ(done[0].samples, a.samples);
  EXPECT_EQ(done[0].stamp_ns, a.stamp_ns);
  EXPECT_DOUBLE_EQ(done[0].window_length_m, a.window_length_m);
  EXPECT_EQ(reassembler.stats().frames_completed, 1u);
}

TEST(SonarUdp, CorruptedDatagramIsCountedAndStreamResyncs) {
  const auto d = *encodeSonarDatagrams(makeFrame(48, 64, 1, 10), 1000);
  std::vector<std::uint8_t> stream = {1, 2, 3};
  for (std::size_t i = 0; i < d.size(); ++i) {
    auto copy = d[i];
    if (i == 1) copy[100] ^= 0xFF;
    stream.insert(stream.end(), copy.begin(), copy.end());
  }
  const auto r = codec::decodeAll<SonarUdpCodec>(stream);
  EXPECT_EQ(r.frames.size(), d.size() - 1);
  EXPECT_EQ(r.stats.bad_checksum, 1u);
  EXPECT_EQ(r.trailing_bytes, 0u);
  // Truncated datagram: need more; absurd geometry: rejected before waiting for bytes.
  EXPECT_TRUE(SonarUdpCodec{}.decode(std::span(d[0]).first(80)).isNeedMore());
  auto big = d[0];
  big[32] = 0xFF;
  big[33] = 0xFF;  // 65535 beams
  EXPECT_EQ(SonarUdpCodec{}.decode(big).badKind(), codec::BadKind::kMalformed);
}

// A frame of speckle noise with a bright target at known ranges per beam.
SonarFrame targetFrame(std::uint32_t seed, const std::vector<int>& target_sample) {
  SonarFrame f;
  f.n_beams = static_cast<int>(target_sample.size());
  f.n_samples = 512;
  f.window_start_m = 1.0;
  f.window_length_m = 10.24;  // 2 cm per sample
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(5, 35);
  f.samples.resize(static_cast<std::size_t>(f.n_beams) * 512);
  for (int s = 0; s < 512; ++s) {
    for (int b = 0; b < f.n_beams; ++b) {
      int v = noise(rng);
      const int t = target_sample[static_cast<std::size_t>(b)];
      if (t >= 0 && s >= t && s < t + 12) v = 200;
      if (rng() % 997 == 0) v = 255;  // isolated speckle spikes: denoising must ignore them
      f.samples[static_cast<std::size_t>(s) * static_cast<std::size_t>(f.n_beams) + static_cast<std::size_t>(b)] =
          static_cast<std::uint8_t>(v);
    }
  }
  return f;
}

TEST(RangeExtraction, FindsTheFirstStrongReturnPerBeamWithinOneWindow) {
  std::vector<int> target(96);
  for (int b = 0; b < 96; ++b) target[static_cast<std::size_t>(b)] = b % 10 == 9 ? -1 : 100 + 3 * b;
  const SonarFrame f = targetFrame(11, target);
  const auto scan = extractRanges(f, RangeExtractionConfig{});
  ASSERT_TRUE(scan.ok()) << scan.error().message;
  ASSERT_EQ(scan->range_m.size(), 96u);
  for (std::size_t b = 0; b < 96; ++b) {
    if (target[b] < 0) {
      EXPECT_EQ(scan->range_m[b], geometry::RangeScan::kNoReturn) << "beam " << b;
    } else {
      // The median of three may move the leading edge by one sample.
      EXPECT_NEAR(scan->range_m[b], f.rangeOfSample_m(target[b]), 1.01 * f.sampleLength_m()) << "beam " << b;
    }
  }
}

TEST(RangeExtraction, MinimumRangeGateSkipsNearReturns) {
  std::vector<int> near(8, 5);  // returns at 1.1 m
  SonarFrame f = targetFrame(12, near);
  // A second, farther return at sample 300 (7.0 m).
  for (int s = 300; s < 310; ++s) {
    for (int b = 0; b < 8; ++b) f.samples[static_cast<std::size_t>(s * 8 + b)] = 220;
  }
  RangeExtractionConfig cfg;
  cfg.min_range_m = 0.5;
  auto scan = extractRanges(f, cfg);
  ASSERT_TRUE(scan.ok());
  EXPECT_NEAR(scan->range_m[0], f.rangeOfSample_m(5), 0.1);
  cfg.min_range_m = 2.0;
  scan = extractRanges(f, cfg);
  ASSERT_TRUE(scan.ok());
  for (const float r : scan->range_m) EXPECT_NEAR(r, f.rangeOfSample_m(300), 0.1);
}

TEST(RangeExtraction, BadFrameOrConfigIsAnError) {
  SonarFrame f = targetFrame(13, std::vector<int>(4, 50));
  f.samples.pop_back();
  EXPECT_FALSE(extractRanges(f, RangeExtractionConfig{}).ok());
  RangeExtractionConfig cfg;
  cfg.min_range_m = 5.0;
  cfg.max_range_m = 4.0;
  const auto st = cfg.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("min_range_m"), std::string::npos);
}

}  // namespace
}  // namespace vog::sonar
