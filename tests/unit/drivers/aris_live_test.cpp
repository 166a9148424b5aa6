// ARIS live protocol, receiver side: reordering (vendor vectors), FramePart assembly and acks.
#include "vog/sonar/aris_availability.pb.h"
#include "vog/sonar/aris_commands.pb.h"
#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/sonar/aris_frame_stream.pb.h"
#include "vog/sonar/aris_reorder.hpp"
#include "vog/sonar/sonar_files.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <string>

namespace vog::sonar {
namespace {

std::vector<std::uint8_t> randomBytes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint8_t> v(n);
  for (auto& b : v) b = static_cast<std::uint8_t>(rng() % 256);
  return v;
}

// ---- Reordering ----

struct Vector {
  const char* name;
  std::uint32_t ping_mode;
  std::uint32_t samples;
};

// data/aris-sdk/README.md: the vendor's reordering test, as received (input) and reordered (expected).
TEST(ArisReorder, VendorVectorsAreBitExactBothWays) {
  const auto dir = test::sharedDataDir() / "aris-sdk" / "reorder";
  for (const Vector& v : {Vector{"pingmode_1_1200", 1, 512}, Vector{"pingmode_1_1800", 1, 544},
                          Vector{"pingmode_3", 3, 512}, Vector{"pingmode_6", 6, 410}, Vector{"pingmode_9", 9, 512}}) {
    SCOPED_TRACE(v.name);
    const auto input = loadFile(dir / (std::string("input_") + v.name + ".dat"));
    const auto expected = loadFile(dir / (std::string("expected_") + v.name + ".dat"));
    ASSERT_TRUE(input.ok()) << input.error().message;
    ASSERT_TRUE(expected.ok()) << expected.error().message;
    ASSERT_EQ(input->size(), static_cast<std::size_t>(*arisBeamsForPingMode(v.ping_mode)) * v.samples);
    std::vector<std::uint8_t> out(input->size());
    const Status st = arisSonarToBeamOrder(v.ping_mode, v.samples, *input, out);
    ASSERT_TRUE(st.ok()) << st.error().message;
    EXPECT_EQ(out, *expected);
    std::vector<std::uint8_t> back(input->size());
    ASSERT_TRUE(arisBeamToSonarOrder(v.ping_mode, v.samples, *expected, back).ok());
    EXPECT_EQ(back, *input);
  }
}

TEST(ArisReorder, InverseRoundTripsEveryPingModeOfTheBeamTable) {
  for (std::uint32_t mode = 1; mode <= 12; ++mode) {
    const auto beams = arisBeamsForPingMode(mode);
    ASSERT_TRUE(beams.ok());
    for (const std::uint32_t samples : {1u, 7u, 512u, 2000u}) {
      SCOPED_TRACE("PingMode " + std::to_string(mode) + ", samples " + std::to_string(samples));
      const auto beam_order = randomBytes(static_cast<std::size_t>(*beams) * samples, mode * 1000 + samples);
      std::vector<std::uint8_t> sonar(beam_order.size());
      std::vector<std::uint8_t> back(beam_order.size());
      ASSERT_TRUE(arisBeamToSonarOrder(mode, samples, beam_order, sonar).ok());
      ASSERT_TRUE(arisSonarToBeamOrder(mode, samples, sonar, back).ok());
      EXPECT_EQ(back, beam_order);
      // A permutation: the same bytes, moved.
      auto a = beam_order;
      auto b = sonar;
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      EXPECT_EQ(a, b);
    }
  }
}

TEST(ArisReorder, UnknownPingModeOrWrongSizeIsAnErrorNamingTheValue) {
  std::vector<std::uint8_t> in(48 * 10);
  std::vector<std::uint8_t> out(48 * 10);
  for (const std::uint32_t mode : {0u, 13u}) {
    const Status st = arisSonarToBeamOrder(mode, 10, in, out);
    ASSERT_FALSE(st.ok());
    EXPECT_TRUE(test::contains(st.error().message, "PingMode " + std::to_string(mode))) << st.error().message;
  }
  const Status short_in = arisSonarToBeamOrder(1, 10, std::span(in).first(479), out);
  ASSERT_FALSE(short_in.ok());
  EXPECT_TRUE(test::contains(short_in.error().message, "480 bytes, got 479 in")) << short_in.error().message;
  const Status wrong_samples = arisBeamToSonarOrder(1, 11, in, out);
  ASSERT_FALSE(wrong_samples.ok());
  EXPECT_TRUE(test::contains(wrong_samples.error().message, "11 samples")) << wrong_samples.error().message;
}

// ../shared/data/aris/sample.aris was written by ARIScope: its frames say ReorderedSamples = 1
// (offset 516) and carry no settings cookie (AppliedSettings, offset 680, = 0).
TEST(ArisHeader, RealSampleFramesAreMarkedReordered) {
  const auto bytes = loadFile(test::sharedDataDir() / "aris" / "sample.aris");
  ASSERT_TRUE(bytes.ok()) << bytes.error().message;
  const auto rec = decodeArisFile(*bytes);
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  ASSERT_EQ(rec->aris_meta.size(), 6u);
  for (const auto& meta : rec->aris_meta) {
    EXPECT_TRUE(meta.reordered_samples);
    EXPECT_EQ(meta.settings_cookie, 0u);
    EXPECT_EQ(meta.samples_per_beam, 2000u);
  }
  // A header shorter than the fields read is an error that says how short.
  const auto short_header = decodeArisFrameHeader(std::span(*bytes).subspan(1024, kArisFrameHeaderUsedBytes - 1));
  ASSERT_FALSE(short_header.ok());
  EXPECT_TRUE(test::contains(short_header.error().message, "683 bytes")) << short_header.error().message;
}

// ---- Wire format (field numbers of PROTOCOLS.md) ----

TEST(ArisProto, FieldNumbersOnTheWire) {
  EXPECT_EQ(encodeArisFramePartAck({7, 1234}), (std::vector<std::uint8_t>{0x08, 0x07, 0x10, 0xD2, 0x09}));
  const auto ack = decodeArisFramePartAck(encodeArisFramePartAck({7, 1234}));
  ASSERT_TRUE(ack.ok());
  EXPECT_EQ(*ack, (ArisFramePartAck{7, 1234}));
  EXPECT_FALSE(decodeArisFramePartAck(std::vector<std::uint8_t>{0x08, 0x07}).ok());

  const std::vector<std::uint8_t> data = {0xAA};
  const std::vector<std::uint8_t> header = {0x55};
  // frame_index=1 (2), total_data_size=2 (1), header=3, data=4, data_offset=5 (0), ack_port=6 (700).
  EXPECT_EQ(
      encodeArisFramePart(
          {.frame_index = 2, .total_data_size = 1, .header = header, .data = data, .data_offset = 0, .ack_port = 700}),
      (std::vector<std::uint8_t>{0x08, 0x02, 0x10, 0x01, 0x1A, 0x01, 0x55, 0x22, 0x01, 0xAA, 0x28, 0x00, 0x30, 0xBC,
                                 0x05}));

  aris::Command cmd;
  cmd.set_type(aris::Command::SET_ACOUSTICS);
  cmd.mutable_settings()->set_cookie(5);
  cmd.mutable_settings()->set_pingmode(9);
  std::string wire;
  ASSERT_TRUE(cmd.SerializeToString(&wire));
  EXPECT_EQ(wire, std::string("\x08\x03\x2A\x04\x08\x05\x40\x09", 8));

  aris::Availability beacon;
  beacon.set_serialnumber(1234);
  beacon.set_systemtype(aris::Availability::ARIS_3000);
  beacon.mutable_softwareversion()->set_major(2);
  ASSERT_TRUE(beacon.SerializeToString(&wire));
  EXPECT_EQ(wire, std::string("\x08\xD2\x09\x10\x01\x1A\x02\x08\x02", 9));
}

// ---- Assembly ----

constexpr std::int32_t kAckPort = 56889;

// A frame of the ping mode's beams whose window survives the header's whole microseconds.
SonarFrame liveFrame(std::uint32_t ping_mode, int samples, std::uint32_t index, std::uint32_t seed) {
  SonarFrame f;
  f.frame_index = index;
  f.stamp_ns = 1'700'000'000'000'000'000LL + index * 66'000'000LL;
  f.n_beams = *arisBeamsForPingMode(ping_mode);
  f.n_samples = samples;
  f.sound_speed_mps = 1500.0;
  f.window_start_m = 0.75;              // 1000 us
  f.window_length_m = samples * 0.015;  // 20 us per sample
  f.samples = randomBytes(static_cast<std::size_t>(f.n_beams) * static_cast<std::size_t>(samples), seed);
  return f;
}

struct Sent {
  std::vector<std::vector<std::uint8_t>> parts;
  std::vector<std::int32_t> offsets;
  std::int32_t total = 0;
};

// What the sonar sends for `f`: the header unpadded (744 bytes, the fields in use), the data in
// sonar order unless `reordered`, `part_bytes` per part.
Sent sonarSends(const SonarFrame& f, std::uint32_t ping_mode, std::size_t part_bytes, bool reordered = false,
                std::uint32_t cookie = 42) {
  auto header =
      *encodeArisFrameHeader(f, {.ping_mode = ping_mode, .reordered_samples = reordered, .settings_cookie = cookie});
  header.resize(744);
  std::vector<std::uint8_t> data(f.samples.size());
  if (reordered) {
    data = f.samples;
  } else {
    EXPECT_TRUE(arisBeamToSonarOrder(ping_mode, static_cast<std::uint32_t>(f.n_samples), f.samples, data).ok());
  }
  Sent s;
  s.total = static_cast<std::int32_t>(data.size());
  for (std::size_t off = 0; off < data.size(); off += part_bytes) {
    const std::size_t n = std::min(part_bytes, data.size() - off);
    s.parts.push_back(encodeArisFramePart(
        {.frame_index = static_cast<std::int32_t>(f.frame_index),
         .total_data_size = s.total,
         .header = off == 0 ? std::span<const std::uint8_t>(header) : std::span<const std::uint8_t>(),
         .data = std::span(data).subspan(off, n),
         .data_offset = static_cast<std::int32_t>(off),
         .ack_port = kAckPort}));
    s.offsets.push_back(static_cast<std::int32_t>(off));
  }
  return s;
}

// The frame as the ARIS file path delivers it.
SonarFrame viaFile(const SonarFrame& f) {
  const auto rec = decodeArisFile(*encodeArisFile(std::vector<SonarFrame>{f}));
  EXPECT_TRUE(rec.ok());
  return rec->frames.at(0);
}

void expectSameFrame(const SonarFrame& got, const SonarFrame& want) {
  const SonarFrame file = viaFile(want);
  EXPECT_EQ(got.samples, want.samples);
  EXPECT_EQ(got.n_beams, file.n_beams);
  EXPECT_EQ(got.n_samples, file.n_samples);
  EXPECT_EQ(got.frame_index, file.frame_index);
  EXPECT_EQ(got.stamp_ns, file.stamp_ns);
  EXPECT_DOUBLE_EQ(got.window_start_m, file.window_start_m);
  EXPECT_DOUBLE_EQ(got.window_length_m, file.window_length_m);
  EXPECT_DOUBLE_EQ(got.sound_speed_mps, file.sound_speed_mps);
}

TEST(ArisAssembler, PartsInOrderAckEachOffsetAndDeliverTheReorderedFrame) {
  const SonarFrame f = liveFrame(3, 512, 5, 1);  // 96 x 512 = 49152 bytes
  const Sent s = sonarSends(f, 3, 6144);
  ASSERT_EQ(s.parts.size(), 8u);
  ArisFrameAssembler a;
  for (std::size_t k = 0; k < s.parts.size(); ++k) {
    const auto r = a.add(s.parts[k], 10.0 + 0.001 * static_cast<double>(k));
    ASSERT_FALSE(r.refusal) << r.refusal_detail;
    ASSERT_TRUE(r.ack);
    EXPECT_EQ(*r.ack, (ArisFramePartAck{5, static_cast<std::int32_t>(6144 * (k + 1))}));
    EXPECT_EQ(r.ack_port, kAckPort);
    ASSERT_EQ(r.frame.has_value(), k + 1 == s.parts.size());
    if (r.frame) {
      expectSameFrame(r.frame->frame, f);
      EXPECT_EQ(r.frame->meta.settings_cookie, 42u);
      EXPECT_EQ(r.frame->meta.ping_mode, 3u);
      EXPECT_FALSE(r.frame->meta.reordered_samples);
    }
  }
  EXPECT_EQ(a.stats().frames_completed, 1u);
  EXPECT_EQ(a.stats().datagrams, 8u);
  EXPECT_EQ(a.stats().datagrams_duplicated, 0u);
  EXPECT_EQ(a.stats().refusedTotal(), 0u);
  EXPECT_EQ(a.framesInFlight(), 0u);
}

TEST(ArisAssembler, AlreadyReorderedDataIsDeliveredAsIs) {
  const SonarFrame f = liveFrame(9, 100, 1, 2);
  const Sent s = sonarSends(f, 9, 5000, /*reordered=*/true);
  ArisFrameAssembler a;
  std::optional<ArisLiveFrame> got;
  for (const auto& p : s.parts) {
    auto r = a.add(p, 0.0);
    if (r.frame) got = std::move(r.frame);
  }
  ASSERT_TRUE(got);
  EXPECT_TRUE(got->meta.reordered_samples);
  expectSameFrame(got->frame, f);
}

TEST(ArisAssembler, ShuffledPartsCompleteAndAckTheContiguousPrefix) {
  const SonarFrame f = liveFrame(6, 410, 3, 3);  // 64 x 410 = 26240 bytes
  const Sent s = sonarSends(f, 6, 1400);
  std::vector<std::size_t> order(s.parts.size());
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(20260412);
  std::shuffle(order.begin(), order.end(), rng);
  ArisFrameAssembler a;
  std::set<std::size_t> have;
  for (std::size_t k = 0; k < order.size(); ++k) {
    have.insert(order[k]);
    std::size_t prefix_parts = 0;
    while (have.count(prefix_parts) != 0) ++prefix_parts;
    const auto want = prefix_parts == s.parts.size() ? s.total : static_cast<std::int32_t>(prefix_parts * 1400);
    const auto r = a.add(s.parts[order[k]], 1.0);
    ASSERT_TRUE(r.ack) << r.refusal_detail;
    EXPECT_EQ(*r.ack, (ArisFramePartAck{3, want})) << "after part " << order[k];
    EXPECT_EQ(r.frame.has_value(), k + 1 == order.size());
    if (r.frame) expectSameFrame(r.frame->frame, f);
  }
  EXPECT_EQ(a.stats().frames_completed, 1u);
  EXPECT_EQ(a.stats().datagrams_duplicated, 0u);
}

TEST(ArisAssembler, DuplicatesAreAckedAgainCountedAndDeliverNothingTwice) {
  const SonarFrame f = liveFrame(1, 544, 9, 4);
  const Sent s = sonarSends(f, 1, 4096);
  ArisFrameAssembler a;
  int frames = 0;
  for (std::size_t k = 0; k < s.parts.size(); ++k) {
    const auto first = a.add(s.parts[k], 2.0);
    const auto again = a.add(s.parts[k], 2.0);  // the same datagram twice
    ASSERT_TRUE(first.ack && again.ack);
    EXPECT_EQ(*again.ack, *first.ack);
    frames += first.frame.has_value() + again.frame.has_value();
    if (first.frame) expectSameFrame(first.frame->frame, f);
  }
  EXPECT_EQ(frames, 1);
  EXPECT_EQ(a.stats().datagrams_duplicated, s.parts.size());
  EXPECT_EQ(a.stats().frames_completed, 1u);
}

// The sonar in PESSIMISTIC_RETRY resends from the acknowledged offset.
TEST(ArisAssembler, LostPartIsRecoveredByResendingFromTheAckedOffset) {
  const SonarFrame f = liveFrame(3, 512, 11, 5);
  const Sent s = sonarSends(f, 3, 6144);
  ArisFrameAssembler a;
  for (std::size_t k = 0; k < s.parts.size(); ++k) {
    if (k == 2) continue;  // lost
    const auto r = a.add(s.parts[k], 3.0);
    ASSERT_TRUE(r.ack) << r.refusal_detail;
    EXPECT_EQ(r.ack->data_offset, k < 2 ? static_cast<std::int32_t>(6144 * (k + 1)) : 2 * 6144);
    EXPECT_FALSE(r.frame);
  }
  const std::int32_t acked = 2 * 6144;
  const auto at = std::find(s.offsets.begin(), s.offsets.end(), acked);
  ASSERT_NE(at, s.offsets.end());
  const auto r = a.add(s.parts[static_cast<std::size_t>(at - s.offsets.begin())], 3.1);
  ASSERT_TRUE(r.ack);
  EXPECT_EQ(*r.ack, (ArisFramePartAck{11, s.total}));
  ASSERT_TRUE(r.frame);
  expectSameFrame(r.frame->frame, f);
  EXPECT_EQ(a.stats().datagrams_duplicated, 0u);

  // The final ack is lost too: the resent last part is answered N again, without a second frame.
  const auto resent = a.add(s.parts.back(), 3.2);
  ASSERT_TRUE(resent.ack);
  EXPECT_EQ(*resent.ack, (ArisFramePartAck{11, s.total}));
  EXPECT_FALSE(resent.frame);
  EXPECT_EQ(a.stats().datagrams_duplicated, 1u);
  EXPECT_EQ(a.stats().frames_completed, 1u);
}

TEST(ArisAssembler, IncompleteFrameIsDroppedWhenANewerOneCompletes) {
  const Sent old_frame = sonarSends(liveFrame(1, 100, 1, 6), 1, 1000);
  const Sent new_frame = sonarSends(liveFrame(1, 100, 2, 7), 1, 1000);
  ArisFrameAssembler a;
  for (std::size_t k = 0; k < 3; ++k) ASSERT_TRUE(a.add(old_frame.parts[k], 0.0).ack);
  EXPECT_EQ(a.framesInFlight(), 1u);
  std::optional<ArisLiveFrame> got;
  for (const auto& p : new_frame.parts) {
    auto r = a.add(p, 0.1);
    if (r.frame) got = std::move(r.frame);
  }
  ASSERT_TRUE(got);
  EXPECT_EQ(got->frame.frame_index, 2u);
  EXPECT_EQ(a.stats().frames_dropped_incomplete, 1u);
  EXPECT_EQ(a.framesInFlight(), 0u);
}

TEST(ArisAssembler, IncompleteFrameIsDroppedAfterMaxAgeAndStartsOverIfResent) {
  const Sent s = sonarSends(liveFrame(1, 100, 1, 8), 1, 1000);
  ArisFrameAssembler a({.max_frame_age_s = 0.5});
  ASSERT_EQ(a.add(s.parts[0], 100.0).ack->data_offset, 1000);
  ASSERT_EQ(a.add(s.parts[1], 100.4).ack->data_offset, 2000);
  EXPECT_EQ(a.stats().frames_dropped_incomplete, 0u);
  // 0.6 s after its first part the frame is gone: a later part of it starts a new frame, acked 0.
  const auto r = a.add(s.parts[2], 100.6);
  ASSERT_TRUE(r.ack);
  EXPECT_EQ(*r.ack, (ArisFramePartAck{1, 0}));
  EXPECT_EQ(a.stats().frames_dropped_incomplete, 1u);
  EXPECT_EQ(a.framesInFlight(), 1u);
}

// ---- Refusals: counted by reason, not stored, not acknowledged ----

void expectRefused(const ArisPartResult& r, ArisPartRefusal reason, const std::string& detail) {
  ASSERT_TRUE(r.refusal) << "accepted, expected " << arisPartRefusalName(reason);
  EXPECT_EQ(*r.refusal, reason) << arisPartRefusalName(*r.refusal) << ": " << r.refusal_detail;
  EXPECT_FALSE(r.ack);
  EXPECT_FALSE(r.frame);
  EXPECT_TRUE(test::contains(r.refusal_detail, detail)) << r.refusal_detail << " does not name " << detail;
}

std::vector<std::uint8_t> serialize(const frame_stream::FramePart& part) {
  std::string wire;
  EXPECT_TRUE(part.SerializeToString(&wire));
  return {wire.begin(), wire.end()};
}

frame_stream::FramePart parsed(const std::vector<std::uint8_t>& datagram) {
  frame_stream::FramePart p;
  EXPECT_TRUE(p.ParseFromArray(datagram.data(), static_cast<int>(datagram.size())));
  return p;
}

TEST(ArisAssembler, RefusesEveryMalformedPartWithItsReason) {
  const SonarFrame f = liveFrame(3, 512, 4, 9);
  const Sent s = sonarSends(f, 3, 6144);
  ArisFrameAssembler a;
  using R = ArisPartRefusal;

  expectRefused(a.add(std::vector<std::uint8_t>{0xFF, 0xFF, 0xFF}, 0.0), R::kUndecodable, "3 bytes");
  auto p = parsed(s.parts[1]);
  p.clear_total_data_size();
  expectRefused(a.add(serialize(p), 0.0), R::kUndecodable, "total_data_size");
  p = parsed(s.parts[1]);
  p.set_frame_index(0);
  expectRefused(a.add(serialize(p), 0.0), R::kUndecodable, "frame_index 0");

  p = parsed(s.parts[1]);
  p.set_total_data_size(0);
  expectRefused(a.add(serialize(p), 0.0), R::kTotalSizeOutOfBounds, "total_data_size 0");
  p.set_total_data_size(128 * 4096 + 1);
  expectRefused(a.add(serialize(p), 0.0), R::kTotalSizeOutOfBounds, "524289");

  p = parsed(s.parts[1]);
  p.set_data_offset(-1);
  expectRefused(a.add(serialize(p), 0.0), R::kOutsideFrame, "[-1, 6143)");
  p.set_data_offset(s.total);
  expectRefused(a.add(serialize(p), 0.0), R::kOutsideFrame, "[49152, ");
  p.set_data_offset(s.total - 10);
  expectRefused(a.add(serialize(p), 0.0), R::kOutsideFrame, "[49142, 55286)");

  p = parsed(s.parts[1]);
  p.set_header(parsed(s.parts[0]).header());
  expectRefused(a.add(serialize(p), 0.0), R::kHeaderOnLaterPart, "data_offset 6144");

  p = parsed(s.parts[0]);
  p.clear_header();
  expectRefused(a.add(serialize(p), 0.0), R::kHeaderMissing, "data_offset 0");
  p = parsed(s.parts[0]);
  p.mutable_header()->resize(kArisFrameHeaderUsedBytes - 1);
  expectRefused(a.add(serialize(p), 0.0), R::kHeaderShort, "683 bytes");

  p = parsed(s.parts[0]);
  (*p.mutable_header())[436] = 77;  // PingMode (FrameHeader.fields.csv offset 436)
  expectRefused(a.add(serialize(p), 0.0), R::kHeaderInvalid, "PingMode 77");
  p = parsed(s.parts[0]);
  p.set_total_data_size(48 * 512);  // a 96-beam header
  expectRefused(a.add(serialize(p), 0.0), R::kHeaderInvalid, "49152 bytes, total_data_size 24576");

  EXPECT_EQ(a.framesInFlight(), 0u);  // nothing refused was kept
  ASSERT_TRUE(a.add(s.parts[0], 0.0).ack);
  p = parsed(s.parts[1]);
  p.set_total_data_size(s.total - 96);
  expectRefused(a.add(serialize(p), 0.0), R::kTotalSizeChanged, "earlier parts said 49152");

  // The refusals left the frame intact: the rest of it completes it.
  std::optional<ArisLiveFrame> got;
  for (std::size_t k = 1; k < s.parts.size(); ++k) {
    auto r = a.add(s.parts[k], 0.0);
    if (r.frame) got = std::move(r.frame);
  }
  ASSERT_TRUE(got);
  expectSameFrame(got->frame, f);
  p = parsed(s.parts.back());
  p.set_total_data_size(s.total + 96);
  expectRefused(a.add(serialize(p), 0.0), R::kTotalSizeChanged, "completed with 49152");

  const auto& st = a.stats();
  EXPECT_EQ(st.refusedBy(R::kUndecodable), 3u);
  EXPECT_EQ(st.refusedBy(R::kTotalSizeOutOfBounds), 2u);
  EXPECT_EQ(st.refusedBy(R::kOutsideFrame), 3u);
  EXPECT_EQ(st.refusedBy(R::kHeaderOnLaterPart), 1u);
  EXPECT_EQ(st.refusedBy(R::kHeaderMissing), 1u);
  EXPECT_EQ(st.refusedBy(R::kHeaderShort), 1u);
  EXPECT_EQ(st.refusedBy(R::kHeaderInvalid), 2u);
  EXPECT_EQ(st.refusedBy(R::kTotalSizeChanged), 2u);
  EXPECT_EQ(st.refusedTotal(), 15u);
  EXPECT_EQ(st.frames_completed, 1u);
}

TEST(ArisAssembler, RefusesTooManyFramesInFlightAndTooFragmentedFrames) {
  ArisFrameAssembler a({.max_frames_in_flight = 2, .max_ranges_per_frame = 2});
  const Sent f1 = sonarSends(liveFrame(1, 100, 1, 10), 1, 500);
  const Sent f2 = sonarSends(liveFrame(1, 100, 2, 11), 1, 500);
  const Sent f3 = sonarSends(liveFrame(1, 100, 3, 12), 1, 500);
  EXPECT_EQ(*a.add(f1.parts[1], 0.0).ack, (ArisFramePartAck{1, 0}));
  EXPECT_EQ(*a.add(f1.parts[3], 0.0).ack, (ArisFramePartAck{1, 0}));  // two ranges
  expectRefused(a.add(f1.parts[5], 0.0), ArisPartRefusal::kTooFragmented, "3 disjoint ranges");
  EXPECT_EQ(*a.add(f1.parts[2], 0.0).ack, (ArisFramePartAck{1, 0}));  // joins them: one range
  EXPECT_EQ(*a.add(f1.parts[0], 0.0).ack, (ArisFramePartAck{1, 2000}));

  ASSERT_TRUE(a.add(f2.parts[0], 0.0).ack);
  // Full: a newer frame takes the oldest one's place; a part of the evicted (older) frame is refused.
  ASSERT_TRUE(a.add(f3.parts[0], 0.0).ack);
  EXPECT_EQ(a.stats().frames_dropped_incomplete, 1u);
  expectRefused(a.add(f1.parts[4], 0.0), ArisPartRefusal::kTooManyFramesInFlight, "2 newer frames");
  EXPECT_EQ(a.stats().refusedBy(ArisPartRefusal::kTooFragmented), 1u);
  EXPECT_EQ(a.stats().refusedBy(ArisPartRefusal::kTooManyFramesInFlight), 1u);
  EXPECT_EQ(a.framesInFlight(), 2u);
  for (const auto& part : f3.parts) (void)a.add(part, 0.0);
  EXPECT_EQ(a.stats().frames_completed, 1u);
}

// DROP_PARTIAL_FRAMES under loss: frames that never complete fill the frames in flight, and every
// frame that arrives whole after them is still delivered (none waits for the incomplete ones to age out).
TEST(ArisAssembler, IncompleteFramesDoNotBlockWholeFramesThatFollow) {
  ArisFrameAssembler a({.max_frames_in_flight = 4});
  std::uint64_t delivered = 0;
  for (std::uint32_t index = 1; index <= 20; ++index) {
    const Sent s = sonarSends(liveFrame(1, 100, index, 20 + index), 1, 1000);
    const bool lossy = index <= 6;  // the first six each lose their last part
    for (std::size_t k = 0; k + (lossy ? 1 : 0) < s.parts.size(); ++k) {
      if (a.add(s.parts[k], 0.01 * index).frame) ++delivered;
    }
  }
  EXPECT_EQ(delivered, 14u);
  EXPECT_EQ(a.stats().refusedTotal(), 0u);
  EXPECT_EQ(a.stats().frames_dropped_incomplete, 6u);
}

TEST(ArisAssembler, ConfigValidationNamesTheKey) {
  EXPECT_TRUE(ArisFrameAssemblerConfig{}.validate().ok());
  const Status age = ArisFrameAssemblerConfig{.max_frame_age_s = -1.0}.validate();
  ASSERT_FALSE(age.ok());
  EXPECT_TRUE(test::contains(age.error().message, "max_frame_age_s: -1")) << age.error().message;
  const Status beams = ArisFrameAssemblerConfig{.max_beams = 200}.validate();
  ASSERT_FALSE(beams.ok());
  EXPECT_TRUE(test::contains(beams.error().message, "max_beams: 200")) << beams.error().message;
  EXPECT_FALSE(ArisFrameAssemblerConfig{.max_frames_in_flight = 0}.validate().ok());
  EXPECT_FALSE(ArisFrameAssemblerConfig{.max_ranges_per_frame = 0}.validate().ok());
}

}  // namespace
}  // namespace vog::sonar
