// ARIS live frame stream, sending side: the mock sonar's ArisFrameSender against the receiver's
// ArisFrameAssembler, without loss and over a seeded lossy channel (both directions).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "vog/mock/aris_frame_sender.hpp"
#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/sonar/aris_frame_stream.pb.h"
#include "vog/sonar/sonar_files.hpp"

namespace vog::mock {
namespace {

using sonar::ArisFrameAssembler;
using sonar::ArisFramePartAck;
using sonar::ArisLiveFrame;
using sonar::SonarFrame;

constexpr double kFramePeriod_s = 1.0 / 15.0;  // the ARIS's fastest frame rate

bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// A frame of the ping mode's beams whose window survives the header's whole microseconds.
SonarFrame liveFrame(std::uint32_t ping_mode, int samples, std::uint32_t index, std::uint32_t seed) {
  SonarFrame f;
  f.frame_index = index;
  f.stamp_ns = 1'700'000'000'000'000'000LL + index * 66'000'000LL;
  f.n_beams = *sonar::arisBeamsForPingMode(ping_mode);
  f.n_samples = samples;
  f.sound_speed_mps = 1500.0;
  f.window_start_m = 0.75;              // 1000 us
  f.window_length_m = samples * 0.015;  // 20 us per sample
  std::mt19937 rng(seed);
  f.samples.resize(static_cast<std::size_t>(f.n_beams) * static_cast<std::size_t>(samples));
  for (auto& b : f.samples) b = static_cast<std::uint8_t>(rng() % 256);
  return f;
}

frame_stream::FramePart parsed(const std::vector<std::uint8_t>& datagram) {
  frame_stream::FramePart p;
  EXPECT_TRUE(p.ParseFromArray(datagram.data(), static_cast<int>(datagram.size())));
  return p;
}

std::vector<std::uint8_t> ackBytes(std::int32_t frame_index, std::int32_t offset) {
  return sonar::encodeArisFramePartAck({frame_index, offset});
}

// The frame as the receiver delivers it equals the frame sent: samples bit for bit (beam order),
// geometry as the header carries it, and the header options as given.
void expectDelivered(const ArisLiveFrame& got, const SonarFrame& sent, std::uint32_t ping_mode, std::uint32_t cookie) {
  EXPECT_EQ(got.frame.samples, sent.samples);
  EXPECT_EQ(got.frame.frame_index, sent.frame_index);
  EXPECT_EQ(got.frame.n_beams, sent.n_beams);
  EXPECT_EQ(got.frame.n_samples, sent.n_samples);
  EXPECT_EQ(got.frame.stamp_ns, sent.stamp_ns);
  EXPECT_NEAR(got.frame.window_start_m, sent.window_start_m, 1e-9);
  EXPECT_NEAR(got.frame.window_length_m, sent.window_length_m, 1e-9);
  EXPECT_DOUBLE_EQ(got.frame.sound_speed_mps, sent.sound_speed_mps);
  EXPECT_EQ(got.meta.ping_mode, ping_mode);
  EXPECT_EQ(got.meta.settings_cookie, cookie);
  EXPECT_EQ(got.meta.frame_index, sent.frame_index);
  EXPECT_FALSE(got.meta.reordered_samples);  // the data went in sonar order
}

// ---- No loss ----

TEST(ArisFrameSender, RoundTripWithoutLossDeliversTheFrameBitIdentical) {
  struct Case {
    std::uint32_t ping_mode;
    int samples;
    std::size_t part_bytes;
    std::size_t header_bytes;
  };
  // Parts that divide the frame and parts that do not; a frame that fits in one part.
  for (const Case c :
       {Case{9, 512, 8192, 1024}, Case{3, 2000, 1400, 744}, Case{6, 410, 5000, 684}, Case{1, 544, 64000, 1024}}) {
    SCOPED_TRACE("PingMode " + std::to_string(c.ping_mode) + ", part_bytes " + std::to_string(c.part_bytes));
    ArisFrameSender sender({.part_bytes = c.part_bytes, .header_bytes = c.header_bytes, .ack_port = 700});
    ArisFrameAssembler assembler;
    const std::uint32_t cookie = 1000 + c.ping_mode;
    for (std::uint32_t index = 1; index <= 3; ++index) {
      const SonarFrame f = liveFrame(c.ping_mode, c.samples, index, index * 7 + c.ping_mode);
      const double t = index * kFramePeriod_s;
      const auto datagrams =
          // reordered_samples is cleared by the sender: the data goes in sonar order.
          sender.send(f, {.ping_mode = c.ping_mode, .reordered_samples = true, .settings_cookie = cookie}, t);
      ASSERT_TRUE(datagrams.ok()) << datagrams.error().message;
      const std::size_t n = f.samples.size();
      ASSERT_EQ(datagrams->size(), (n + c.part_bytes - 1) / c.part_bytes);
      std::optional<ArisLiveFrame> got;
      for (std::size_t k = 0; k < datagrams->size(); ++k) {
        const auto p = parsed((*datagrams)[k]);
        EXPECT_EQ(p.frame_index(), static_cast<std::int32_t>(index));
        EXPECT_EQ(p.total_data_size(), static_cast<std::int32_t>(n));
        EXPECT_EQ(p.data_offset(), static_cast<std::int32_t>(k * c.part_bytes));
        EXPECT_EQ(p.data().size(), std::min(c.part_bytes, n - k * c.part_bytes));
        EXPECT_EQ(p.ack_port(), 700);
        EXPECT_EQ(p.header().size(), k == 0 ? c.header_bytes : 0u) << "part " << k;
        auto r = assembler.add((*datagrams)[k], t);
        ASSERT_FALSE(r.refusal) << r.refusal_detail;
        ASSERT_TRUE(r.ack);
        EXPECT_EQ(r.ack_port, 700);
        const auto outcome = sender.onAck(sonar::encodeArisFramePartAck(*r.ack), t);
        EXPECT_EQ(outcome, k + 1 == datagrams->size() ? ArisAckOutcome::kFinished : ArisAckOutcome::kProgress);
        if (r.frame) got = std::move(r.frame);
      }
      ASSERT_TRUE(got);
      expectDelivered(*got, f, c.ping_mode, cookie);
      EXPECT_FALSE(sender.inFlight());
      EXPECT_FALSE(sender.nextDeadline());
      EXPECT_TRUE(sender.poll(t + 1.0).empty());
    }
    const auto& st = sender.stats();
    EXPECT_EQ(st.frames_sent, 3u);
    EXPECT_EQ(st.frames_finished, 3u);
    EXPECT_EQ(st.frames_given_up, 0u);
    EXPECT_EQ(st.datagrams_resent, 0u);
    EXPECT_EQ(st.retries, 0u);
    EXPECT_EQ(st.datagrams_sent, assembler.stats().datagrams);
    EXPECT_EQ(assembler.stats().frames_completed, 3u);
  }
}

// ---- Retry rules, step by step ----

TEST(ArisFrameSender, ResendsFromTheAckedOffsetAfterTheRetryTimeout) {
  const SonarFrame f = liveFrame(9, 512, 4, 1);  // 65536 bytes: 8 parts of 8192
  for (const std::size_t burst : {std::size_t{1}, std::size_t{0}}) {
    SCOPED_TRACE("max_parts_per_resend " + std::to_string(burst));
    ArisFrameSender sender({.retry_timeout_s = 0.01, .max_retries = 3, .max_parts_per_resend = burst});
    ArisFrameAssembler assembler;
    const auto parts = sender.send(f, {.ping_mode = 9, .settings_cookie = 5}, 10.0);
    ASSERT_TRUE(parts.ok());
    ASSERT_EQ(parts->size(), 8u);
    for (std::size_t k = 0; k < parts->size(); ++k) {
      if (k == 2) continue;  // lost
      const auto r = assembler.add((*parts)[k], 10.0);
      ASSERT_TRUE(r.ack);
      EXPECT_EQ(sender.onAck(sonar::encodeArisFramePartAck(*r.ack), 10.001),
                k < 2 ? ArisAckOutcome::kProgress : ArisAckOutcome::kNoProgress);
    }
    // The last progress (the ack of part 1) at 10.001: nothing is due before 10.011.
    ASSERT_TRUE(sender.nextDeadline());
    EXPECT_DOUBLE_EQ(*sender.nextDeadline(), 10.001 + 0.01);
    EXPECT_TRUE(sender.poll(10.0105).empty());
    const auto resent = sender.poll(10.011);
    ASSERT_EQ(resent.size(), burst == 1 ? 1u : 6u);  // part 2 alone, or parts 2..7
    for (std::size_t k = 0; k < resent.size(); ++k) {
      EXPECT_EQ(resent[k], (*parts)[2 + k]) << "a resend is the original datagram";
    }
    EXPECT_EQ(sender.stats().datagrams_resent, resent.size());
    EXPECT_EQ(sender.stats().retries, 1u);
    std::optional<ArisLiveFrame> got;
    for (const auto& d : resent) {
      auto r = assembler.add(d, 10.012);
      ASSERT_TRUE(r.ack);
      sender.onAck(sonar::encodeArisFramePartAck(*r.ack), 10.012);
      if (r.frame) got = std::move(r.frame);
    }
    ASSERT_TRUE(got);
    expectDelivered(*got, f, 9, 5);
    EXPECT_EQ(sender.stats().frames_finished, 1u);
    EXPECT_FALSE(sender.inFlight());
  }
}

TEST(ArisFrameSender, GivesUpAfterMaxRetriesOnADeadLink) {
  ArisFrameSender sender({.part_bytes = 4096, .retry_timeout_s = 0.005, .max_retries = 3});
  const auto parts = sender.send(liveFrame(1, 512, 1, 2), {.ping_mode = 1}, 0.0);  // 48 x 512: 6 parts
  ASSERT_TRUE(parts.ok());
  ASSERT_EQ(parts->size(), 6u);
  // No ack ever comes: each timeout resends the whole frame from 0, three times, then gives up.
  double t = 0.0;
  int polls = 0;
  while (const auto deadline = sender.nextDeadline()) {
    ASSERT_LE(++polls, 10) << "the sender never gives up";
    EXPECT_DOUBLE_EQ(*deadline, t + 0.005);
    t = *deadline;
    const auto resent = sender.poll(t);
    EXPECT_EQ(resent.size(), polls <= 3 ? 6u : 0u);
    if (!resent.empty()) {
      EXPECT_EQ(resent.front(), parts->front());  // from offset 0, with the header
    }
  }
  EXPECT_EQ(polls, 4);
  const auto& st = sender.stats();
  EXPECT_EQ(st.retries, 3u);
  EXPECT_EQ(st.datagrams_resent, 18u);
  EXPECT_EQ(st.datagrams_sent, 24u);
  EXPECT_EQ(st.frames_given_up, 1u);
  EXPECT_EQ(st.frames_given_up_for_next, 0u);
  EXPECT_EQ(st.frames_finished, 0u);
  EXPECT_FALSE(sender.inFlight());
  // A late ack of the given-up frame changes nothing.
  EXPECT_EQ(sender.onAck(ackBytes(1, 24576), t), ArisAckOutcome::kStale);
  EXPECT_EQ(sender.stats().frames_finished, 0u);
}

TEST(ArisFrameSender, TheNextFrameGivesUpTheUnfinishedOne) {
  ArisFrameSender sender;
  ASSERT_TRUE(sender.send(liveFrame(9, 512, 1, 3), {.ping_mode = 9}, 0.0).ok());
  ASSERT_EQ(sender.onAck(ackBytes(1, 8192), 0.001), ArisAckOutcome::kProgress);
  ASSERT_TRUE(sender.send(liveFrame(9, 512, 2, 4), {.ping_mode = 9}, kFramePeriod_s).ok());
  EXPECT_EQ(sender.stats().frames_given_up, 1u);
  EXPECT_EQ(sender.stats().frames_given_up_for_next, 1u);
  EXPECT_EQ(sender.onAck(ackBytes(1, 65536), 0.07), ArisAckOutcome::kStale);
  EXPECT_EQ(sender.onAck(ackBytes(2, 65536), 0.07), ArisAckOutcome::kFinished);
  EXPECT_EQ(sender.stats().frames_finished, 1u);
  EXPECT_EQ(sender.stats().acks_stale, 1u);
}

TEST(ArisFrameSender, MalformedAcksAreCountedAndChangeNothing) {
  ArisFrameSender sender({.retry_timeout_s = 0.01});
  ASSERT_TRUE(sender.send(liveFrame(9, 512, 3, 5), {.ping_mode = 9}, 1.0).ok());
  const std::vector<std::uint8_t> garbage = {0xFF, 0xFF, 0xFF};
  EXPECT_EQ(sender.onAck(garbage, 1.001), ArisAckOutcome::kMalformed);
  EXPECT_EQ(sender.onAck({}, 1.001), ArisAckOutcome::kMalformed);                                     // no fields
  EXPECT_EQ(sender.onAck(std::vector<std::uint8_t>{0x08, 0x03}, 1.001), ArisAckOutcome::kMalformed);  // no offset
  EXPECT_EQ(sender.onAck(ackBytes(3, 65537), 1.001), ArisAckOutcome::kMalformed);                     // past N
  EXPECT_EQ(sender.onAck(ackBytes(3, -1), 1.001), ArisAckOutcome::kMalformed);
  EXPECT_EQ(sender.stats().acks_malformed, 5u);
  EXPECT_EQ(sender.stats().acks, 0u);
  // The retry timer did not move and the frame is still in flight.
  EXPECT_TRUE(sender.inFlight());
  EXPECT_DOUBLE_EQ(*sender.nextDeadline(), 1.01);
  EXPECT_EQ(sender.onAck(ackBytes(3, 16384), 1.002), ArisAckOutcome::kProgress);
  EXPECT_EQ(sender.onAck(ackBytes(3, 8192), 1.003), ArisAckOutcome::kNoProgress);  // behind the retry point
  EXPECT_DOUBLE_EQ(*sender.nextDeadline(), 1.012);
  EXPECT_EQ(sender.onAck(ackBytes(3, 65536), 1.004), ArisAckOutcome::kFinished);
  EXPECT_EQ(sender.stats().acks, 3u);
  EXPECT_EQ(sender.stats().acks_malformed, 5u);
}

TEST(ArisFrameSender, DropPartialFramesSendsOnceAndOnlyCountsAcks) {
  ArisFrameSender sender({.mode = ArisPacketLossMitigation::kDropPartialFrames});
  const auto parts = sender.send(liveFrame(9, 512, 1, 6), {.ping_mode = 9}, 0.0);
  ASSERT_TRUE(parts.ok());
  EXPECT_EQ(parts->size(), 8u);
  EXPECT_FALSE(sender.inFlight());
  EXPECT_FALSE(sender.nextDeadline());
  EXPECT_TRUE(sender.poll(100.0).empty());
  EXPECT_EQ(sender.onAck(ackBytes(1, 8192), 0.001), ArisAckOutcome::kIgnored);
  EXPECT_EQ(sender.onAck(std::vector<std::uint8_t>{0xFF}, 0.001), ArisAckOutcome::kMalformed);
  const auto& st = sender.stats();
  EXPECT_EQ(st.frames_sent, 1u);
  EXPECT_EQ(st.datagrams_sent, 8u);
  EXPECT_EQ(st.acks, 1u);
  EXPECT_EQ(st.acks_malformed, 1u);
  EXPECT_EQ(st.frames_finished + st.frames_given_up + st.datagrams_resent, 0u);
}

TEST(ArisFrameSender, BadFramesAreErrorsAndKeepTheFrameInFlight) {
  ArisFrameSender sender;
  ASSERT_TRUE(sender.send(liveFrame(9, 512, 1, 7), {.ping_mode = 9}, 0.0).ok());
  const auto zero = sender.send(liveFrame(9, 512, 0, 8), {.ping_mode = 9}, 0.01);
  ASSERT_FALSE(zero.ok());
  EXPECT_TRUE(contains(zero.error().message, "frame_index")) << zero.error().message;
  const auto wrong_mode = sender.send(liveFrame(9, 512, 2, 9), {.ping_mode = 3}, 0.01);  // 96 beams, not 128
  ASSERT_FALSE(wrong_mode.ok());
  EXPECT_TRUE(contains(wrong_mode.error().message, "ARIS frame 2")) << wrong_mode.error().message;
  SonarFrame short_frame = liveFrame(9, 512, 2, 10);
  short_frame.samples.pop_back();
  EXPECT_FALSE(sender.send(short_frame, {.ping_mode = 9}, 0.01).ok());
  EXPECT_TRUE(sender.inFlight());
  EXPECT_EQ(sender.stats().frames_sent, 1u);
  EXPECT_EQ(sender.stats().frames_given_up, 0u);
  EXPECT_EQ(sender.onAck(ackBytes(1, 65536), 0.02), ArisAckOutcome::kFinished);
}

TEST(ArisFrameSender, ConfigValidationNamesTheKey) {
  EXPECT_TRUE(ArisFrameSenderConfig{}.validate().ok());
  const auto message = [](const ArisFrameSenderConfig& c) { return c.validate().error().message; };
  EXPECT_TRUE(contains(message({.part_bytes = 0}), "part_bytes: 0"));
  EXPECT_TRUE(contains(message({.part_bytes = 64001}), "part_bytes: 64001"));
  EXPECT_TRUE(contains(message({.header_bytes = 683}), "header_bytes: 683"));
  EXPECT_TRUE(contains(message({.header_bytes = 1025}), "header_bytes: 1025"));
  EXPECT_TRUE(contains(message({.retry_timeout_s = 0.0}), "retry_timeout_s: 0"));
  EXPECT_FALSE(ArisFrameSenderConfig{.retry_timeout_s = std::nan("")}.validate().ok());
  EXPECT_TRUE(contains(message({.max_retries = -1}), "max_retries: -1"));
  EXPECT_TRUE(contains(message({.ack_port = 0}), "ack_port: 0"));
  EXPECT_TRUE(contains(message({.mode = static_cast<ArisPacketLossMitigation>(2)}), "mode: 2"));
}

// ---- A seeded lossy channel, both directions ----

// What a run over the channel gave, per frame (index i for frame_index i + 1).
struct LinkRun {
  std::vector<std::optional<ArisLiveFrame>> delivered;
  std::vector<bool> part_lost;         // a datagram of the frame was lost on the way to the receiver
  std::vector<std::uint64_t> retries;  // resend rounds the sender spent on the frame
  std::uint64_t acks_lost = 0;
  ArisFrameSenderStats sender;
  sonar::ArisFrameAssemblerStats receiver;
};

// `frames` frames at 15 frames/s of simulated time; every datagram and every ack is lost with
// probability `loss` (zero latency otherwise). The sender is polled at its deadlines until the next
// frame is due (after the last frame, until it is done). The receiver drops an incomplete frame 1.5 frame periods after
// its first datagram: with DROP_PARTIAL_FRAMES such a frame can never complete, and keeping it would make the
// receiver's max_frames_in_flight refuse frames that arrived whole.
LinkRun runLink(const ArisFrameSenderConfig& config, const std::vector<SonarFrame>& frames, std::uint32_t ping_mode,
                double loss, std::uint32_t seed) {
  ArisFrameSender sender(config);
  ArisFrameAssembler assembler({.max_frame_age_s = 1.5 * kFramePeriod_s});
  std::mt19937 rng(seed);
  std::bernoulli_distribution lost(loss);
  LinkRun run;
  run.delivered.resize(frames.size());
  run.part_lost.assign(frames.size(), false);
  run.retries.assign(frames.size(), 0);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const auto deliver = [&](const std::vector<ArisFrameSender::Datagram>& datagrams, double t) {
      for (const auto& d : datagrams) {
        if (lost(rng)) {
          run.part_lost[i] = true;
          continue;
        }
        auto r = assembler.add(d, t);
        EXPECT_FALSE(r.refusal) << r.refusal_detail;
        if (r.frame) {
          const std::size_t k = r.frame->frame.frame_index - 1;
          ASSERT_LT(k, frames.size());
          EXPECT_FALSE(run.delivered[k]) << "frame " << k + 1 << " delivered twice";
          run.delivered[k] = std::move(r.frame);
        }
        if (!r.ack) continue;
        if (lost(rng)) {
          ++run.acks_lost;
          continue;
        }
        sender.onAck(sonar::encodeArisFramePartAck(*r.ack), t);
      }
    };
    const double t0 = static_cast<double>(i) * kFramePeriod_s;
    // After the last frame, the sender runs until it finishes or gives up.
    const double next_frame_s = i + 1 < frames.size() ? t0 + kFramePeriod_s : std::numeric_limits<double>::infinity();
    const std::uint64_t retries_before = sender.stats().retries;
    const auto parts = sender.send(frames[i], {.ping_mode = ping_mode, .settings_cookie = 77}, t0);
    EXPECT_TRUE(parts.ok());
    if (!parts.ok()) return run;
    deliver(*parts, t0);
    while (const auto deadline = sender.nextDeadline()) {
      if (*deadline >= next_frame_s) break;
      deliver(sender.poll(*deadline), *deadline);
    }
    run.retries[i] = sender.stats().retries - retries_before;
  }
  run.sender = sender.stats();
  run.receiver = assembler.stats();
  return run;
}

std::vector<SonarFrame> linkFrames(std::uint32_t ping_mode, int samples, int count) {
  std::vector<SonarFrame> frames;
  for (int i = 0; i < count; ++i) {
    frames.push_back(liveFrame(ping_mode, samples, static_cast<std::uint32_t>(i + 1), static_cast<std::uint32_t>(i)));
  }
  return frames;
}

TEST(ArisFrameSenderLossyLink, PessimisticRetryDeliversEveryFrameIdentical) {
  const auto frames = linkFrames(9, 512, 150);  // 128 x 512: 8 parts of 8192
  // 2 ms timeout, 20 retries: 42 ms, within the 66.7 ms frame period, so only a run of 21 lost
  // resends could lose a frame (the default's 10 ms x 4 is the bench's business).
  const ArisFrameSenderConfig config{.retry_timeout_s = 0.002, .max_retries = 20};
  for (const double loss : {0.05, 0.2}) {
    SCOPED_TRACE("loss " + std::to_string(loss));
    const LinkRun run = runLink(config, frames, 9, loss, 20261205);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      ASSERT_TRUE(run.delivered[i]) << "frame " << i + 1 << " lost";
      expectDelivered(*run.delivered[i], frames[i], 9, 77);
      EXPECT_LE(run.retries[i], static_cast<std::uint64_t>(config.max_retries)) << "frame " << i + 1;
    }
    // The channel did lose datagrams and acks, and the sender made up for it by resending.
    EXPECT_GT(std::count(run.part_lost.begin(), run.part_lost.end(), true), 10);
    EXPECT_GT(run.acks_lost, 10u);
    EXPECT_GT(run.sender.datagrams_resent, 0u);
    EXPECT_EQ(run.sender.frames_sent, frames.size());
    EXPECT_EQ(run.sender.frames_given_up, 0u);
    EXPECT_EQ(run.sender.frames_finished, frames.size());
    EXPECT_EQ(run.receiver.frames_completed, frames.size());
    EXPECT_EQ(run.receiver.refusedTotal(), 0u);
    EXPECT_EQ(run.sender.acks_malformed, 0u);
  }
}

TEST(ArisFrameSenderLossyLink, PessimisticRetryBoundsItsRetriesWhenLossIsSevere) {
  const auto frames = linkFrames(9, 512, 60);
  const ArisFrameSenderConfig config{.retry_timeout_s = 0.01, .max_retries = 2};
  const LinkRun run = runLink(config, frames, 9, 0.5, 7);
  std::uint64_t delivered = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_LE(run.retries[i], 2u) << "frame " << i + 1;
    if (run.delivered[i]) {
      ++delivered;
      expectDelivered(*run.delivered[i], frames[i], 9, 77);
    }
  }
  EXPECT_GT(run.sender.frames_given_up, 0u);
  EXPECT_LE(run.sender.retries, 2u * frames.size());
  // Each retry resends at most the whole frame.
  EXPECT_LE(run.sender.datagrams_resent, run.sender.retries * 8u);
  EXPECT_EQ(run.sender.frames_finished + run.sender.frames_given_up, frames.size());
  // The sender's finished frames all arrived (a frame can arrive and still be given up if its
  // completing ack was lost every time).
  EXPECT_LE(run.sender.frames_finished, delivered);
}

TEST(ArisFrameSenderLossyLink, DropPartialFramesDeliversAFrameIffNoneOfItsPartsWasLost) {
  const auto frames = linkFrames(9, 512, 200);
  for (const double loss : {0.05, 0.2}) {
    SCOPED_TRACE("loss " + std::to_string(loss));
    const LinkRun run = runLink({.mode = ArisPacketLossMitigation::kDropPartialFrames}, frames, 9, loss, 42);
    std::size_t whole = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      ASSERT_EQ(run.delivered[i].has_value(), !run.part_lost[i]) << "frame " << i + 1;
      if (run.delivered[i]) {
        ++whole;
        expectDelivered(*run.delivered[i], frames[i], 9, 77);
      }
    }
    // Both outcomes occur, so the equivalence was exercised both ways.
    EXPECT_GT(whole, 10u);
    EXPECT_LT(whole, frames.size() - 10);
    EXPECT_EQ(run.sender.datagrams_sent, 8u * frames.size());
    EXPECT_EQ(run.sender.datagrams_resent, 0u);
    EXPECT_EQ(run.sender.retries, 0u);
    EXPECT_EQ(run.receiver.frames_completed, whole);
  }
}

}  // namespace
}  // namespace vog::mock
