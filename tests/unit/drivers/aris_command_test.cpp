// ARIS live protocol, command channel: wire bytes, the sonar-side stream decoder and checks, and the
// acoustic settings derived from a range window.
#include "vog/sonar/aris_command.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <string>
#include <vector>

namespace vog::sonar {
namespace {

using Bytes = std::vector<std::uint8_t>;
using R = ArisCommandRefusal;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// A message with its 4-byte big-endian length prefix.
Bytes framed(const Bytes& message) {
  const auto n = message.size();
  return cat({{static_cast<std::uint8_t>(n >> 24), static_cast<std::uint8_t>(n >> 16),
               static_cast<std::uint8_t>(n >> 8), static_cast<std::uint8_t>(n)},
              message});
}

ArisAcousticSettings validSettings() {
  return {.cookie = 7,
          .frame_rate_hz = 5.0f,
          .samples_per_beam = 1014,
          .sample_start_delay_us = 1351,
          .cycle_period_us = 13939,
          .sample_period_us = 12,
          .pulse_width_us = 15,
          .ping_mode = 3,
          .enable_transmit = true,
          .frequency = ArisFrequency::kHigh,
          .enable_150_volts = true,
          .receiver_gain_db = 18.0f};
}

// One valid command of every type.
std::vector<ArisCommand> everyCommand() {
  return {ArisSetDateTime{"2017-Apr-01 13:24:56"},
          ArisSetFrameStreamReceiver{"10.0.0.2", 56500},
          ArisSetFrameStreamSettings{ArisPacketLossMitigation::kPessimisticRetry, true, 150},
          validSettings(),
          ArisSetSalinity{ArisSalinity::kSaltwater},
          ArisSetFocus{5.5f},
          ArisPing{}};
}

std::vector<ArisCommand> commandsOf(const std::vector<ArisDecodedCommand>& decoded) {
  std::vector<ArisCommand> out;
  for (const auto& d : decoded) {
    EXPECT_FALSE(d.refusal) << d.refusal_detail;
    if (d.command) out.push_back(*d.command);
  }
  return out;
}

// ---- Wire bytes ----

// Hand-computed: tag = field << 3 | wire type (0 varint, 2 length-delimited, 5 fixed32).
TEST(ArisCommandWire, BytesAreTheProtocolsExactly) {
  // PING: type (1, varint) 14; ping (16, length-delimited) empty: tag 130 = varint 82 01.
  EXPECT_EQ(encodeArisCommand(ArisPing{}), (Bytes{0, 0, 0, 5, 0x08, 0x0E, 0x82, 0x01, 0x00}));
  // SET_SALINITY: type 4; salinity (6) { salinity (1) = 15 }.
  EXPECT_EQ(encodeArisCommand(ArisSetSalinity{ArisSalinity::kBrackish}),
            (Bytes{0, 0, 0, 6, 0x08, 0x04, 0x32, 0x02, 0x08, 0x0F}));
  // SET_FOCUS: type 6; focusPosition (8) { focusRange (2, fixed32) = 2.5f = 0x40200000, little-endian }.
  EXPECT_EQ(encodeArisCommand(ArisSetFocus{2.5f}),
            (Bytes{0, 0, 0, 9, 0x08, 0x06, 0x42, 0x05, 0x15, 0x00, 0x00, 0x20, 0x40}));
  // SET_FRAMESTREAM_RECEIVER: type 1; frameStreamReceiver (3) { port (1) = 56500 = varint B4 B9 03,
  // ip (2) = "10.0.0.2" }: 14 bytes inside, 18 in all.
  const Bytes receiver = {0x08, 0x01, 0x1A, 0x0E, 0x08, 0xB4, 0xB9, 0x03, 0x12,
                          0x08, '1',  '0',  '.',  '0',  '.',  '0',  '.',  '2'};
  EXPECT_EQ(encodeArisCommand(ArisSetFrameStreamReceiver{"10.0.0.2", 56500}), framed(receiver));
  ASSERT_EQ(framed(receiver)[3], 18);
}

TEST(ArisCommandWire, EveryCommandDecodesToItself) {
  EXPECT_EQ(arisCommandName(ArisSetDateTime{}), "SET_DATETIME");
  EXPECT_EQ(arisCommandName(ArisAcousticSettings{}), "SET_ACOUSTICS");
  EXPECT_EQ(arisCommandName(ArisPing{}), "PING");
  for (const auto& c : everyCommand()) {
    SCOPED_TRACE(std::string(arisCommandName(c)));
    ArisCommandDecoder decoder;
    const auto decoded = decoder.feed(encodeArisCommand(c));
    ASSERT_EQ(decoded.size(), 1u);
    ASSERT_TRUE(decoded[0].command) << decoded[0].refusal_detail;
    EXPECT_EQ(*decoded[0].command, c);
    EXPECT_FALSE(validateArisCommand(c, ArisSystemType::k1800))
        << validateArisCommand(c, ArisSystemType::k1800)->detail;
    EXPECT_EQ(decoder.buffered(), 0u);
  }
}

TEST(ArisCommandWire, DateTimeTextIsTheSonarsFormat) {
  EXPECT_EQ(arisDateTimeText(0), "1970-Jan-01 00:00:00");
  EXPECT_EQ(arisDateTimeText(1491053096), "2017-Apr-01 13:24:56");
  EXPECT_EQ(arisDateTimeText(1709168461), "2024-Feb-29 01:01:01");
  EXPECT_EQ(arisDateTimeText(-1), "1969-Dec-31 23:59:59");
  EXPECT_FALSE(validateArisCommand(ArisSetDateTime{arisDateTimeText(1709168461)}, ArisSystemType::k1800));
}

// ---- Stream decoding ----

TEST(ArisCommandDecoder, StreamSplitAtEveryByteBoundaryGivesTheSameCommands) {
  Bytes stream;
  for (const auto& c : everyCommand()) stream = cat({stream, encodeArisCommand(c)});
  const auto expected = everyCommand();
  for (std::size_t cut = 0; cut <= stream.size(); ++cut) {
    SCOPED_TRACE("cut at " + std::to_string(cut));
    ArisCommandDecoder decoder;
    auto got = commandsOf(decoder.feed(std::span(stream).first(cut)));
    const auto rest = commandsOf(decoder.feed(std::span(stream).subspan(cut)));
    got.insert(got.end(), rest.begin(), rest.end());
    EXPECT_EQ(got, expected);
    EXPECT_EQ(decoder.buffered(), 0u);
    EXPECT_EQ(decoder.stats().commands, expected.size());
  }
  // One byte at a time: a message completes only with its last byte.
  ArisCommandDecoder decoder;
  std::vector<ArisCommand> got;
  for (std::size_t i = 0; i < stream.size(); ++i) {
    const auto one = commandsOf(decoder.feed(std::span(stream).subspan(i, 1)));
    got.insert(got.end(), one.begin(), one.end());
    EXPECT_LT(decoder.buffered(), 4u + 64u);
  }
  EXPECT_EQ(got, expected);
  EXPECT_EQ(decoder.stats().bytes, stream.size());
}

TEST(ArisCommandDecoder, SeveralMessagesInOneChunkComeOutInOrder) {
  const auto ping = encodeArisCommand(ArisPing{});
  const auto focus = encodeArisCommand(ArisSetFocus{3.0f});
  ArisCommandDecoder decoder;
  // Two whole messages and the first two bytes of a third.
  const auto got = commandsOf(decoder.feed(cat({ping, focus, Bytes(focus.begin(), focus.begin() + 2)})));
  EXPECT_EQ(got, (std::vector<ArisCommand>{ArisPing{}, ArisSetFocus{3.0f}}));
  EXPECT_EQ(decoder.buffered(), 2u);
  EXPECT_EQ(commandsOf(decoder.feed(std::span(focus).subspan(2))), (std::vector<ArisCommand>{ArisSetFocus{3.0f}}));
  EXPECT_EQ(decoder.stats().messages, 3u);
}

// Each case: the message (without prefix) and the refusal it gets; the stream goes on after it.
struct StreamCase {
  const char* name;
  Bytes message;
  R reason;
  const char* detail;
};

TEST(ArisCommandDecoder, MalformedMessagesAreRefusedAndTheStreamGoesOn) {
  const std::vector<StreamCase> cases = {
      {"not protobuf", {0xFF, 0xFF, 0xFF}, R::kUndecodable, "3 bytes"},
      {"empty: type missing", {}, R::kUndecodable, "0 bytes"},
      {"type not in the enum", {0x08, 0x63}, R::kUndecodable, "2 bytes"},
      {"telephoto", {0x08, 0x05}, R::kUnsupportedType, "SET_TELEPHOTO"},
      {"acoustics without settings", {0x08, 0x03}, R::kPayloadMissing, "SET_ACOUSTICS without its settings"},
      {"receiver without payload", {0x08, 0x01}, R::kPayloadMissing, "frameStreamReceiver"},
      {"salinity payload empty", {0x08, 0x04, 0x32, 0x00}, R::kFieldMissing, "salinity"},
      // Salinity 7 is not in the enum: proto2 keeps it as an unknown field, so the field is absent.
      {"salinity not in the enum", {0x08, 0x04, 0x32, 0x02, 0x08, 0x07}, R::kFieldMissing, "salinity"},
      {"receiver without ip", {0x08, 0x01, 0x1A, 0x02, 0x08, 0x01}, R::kFieldMissing, "field ip"},
      {"focus without range", {0x08, 0x06, 0x42, 0x00}, R::kFieldMissing, "focusRange"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    ArisCommandDecoder decoder;
    const auto out = decoder.feed(cat({framed(c.message), encodeArisCommand(ArisPing{})}));
    ASSERT_EQ(out.size(), 2u);
    ASSERT_TRUE(out[0].refusal);
    EXPECT_EQ(*out[0].refusal, c.reason);
    EXPECT_FALSE(out[0].command);
    EXPECT_TRUE(test::contains(out[0].refusal_detail, c.detail)) << out[0].refusal_detail;
    EXPECT_FALSE(arisCommandRefusalClosesStream(c.reason));
    ASSERT_TRUE(out[1].command);  // the next message is read
    EXPECT_FALSE(decoder.closed());
    EXPECT_EQ(decoder.stats().refusedBy(c.reason), 1u);
    EXPECT_EQ(decoder.stats().refusedTotal(), 1u);
    EXPECT_EQ(decoder.stats().commands, 1u);
  }
}

TEST(ArisCommandDecoder, LengthAboveTheLimitClosesTheStream) {
  const auto date = encodeArisCommand(ArisSetDateTime{"2017-Apr-01 13:24:56"});  // 26-byte message
  ASSERT_EQ(date.size(), 30u);
  {
    ArisCommandDecoder decoder({.max_message_bytes = 26});  // exactly the limit: read
    EXPECT_EQ(commandsOf(decoder.feed(date)).size(), 1u);
  }
  ArisCommandDecoder decoder({.max_message_bytes = 25});
  // The prefix alone is enough to refuse: the body is never waited for.
  const auto out = decoder.feed(std::span(date).first(4));
  ASSERT_EQ(out.size(), 1u);
  ASSERT_TRUE(out[0].refusal);
  EXPECT_EQ(*out[0].refusal, R::kLengthOutOfBounds);
  EXPECT_TRUE(test::contains(out[0].refusal_detail, "length prefix 26 above max_message_bytes 25"));
  EXPECT_TRUE(arisCommandRefusalClosesStream(R::kLengthOutOfBounds));
  EXPECT_TRUE(decoder.closed());
  // Whatever follows is not read.
  EXPECT_TRUE(decoder.feed(encodeArisCommand(ArisPing{})).empty());
  EXPECT_EQ(decoder.buffered(), 0u);
  EXPECT_EQ(decoder.stats().bytes, 4u + 9u);
  EXPECT_EQ(decoder.stats().refusedBy(R::kLengthOutOfBounds), 1u);

  // The default limit is 64 KiB: a prefix of 0x00010001 is refused.
  ArisCommandDecoder by_default;
  const auto big = by_default.feed(Bytes{0x00, 0x01, 0x00, 0x01});
  ASSERT_EQ(big.size(), 1u);
  EXPECT_EQ(big[0].refusal, R::kLengthOutOfBounds);
}

TEST(ArisCommandDecoder, ConfigErrorsNameTheKey) {
  EXPECT_TRUE(ArisCommandDecoderConfig{}.validate().ok());
  const Status st = ArisCommandDecoderConfig{.max_message_bytes = 8}.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_TRUE(test::contains(st.error().message, "max_message_bytes: 8"));
}

// ---- Validation as a device would ----

struct CheckCase {
  const char* name;
  ArisCommand command;
  R reason;
  const char* detail;
};

ArisAcousticSettings with(const std::function<void(ArisAcousticSettings&)>& change) {
  auto s = validSettings();
  change(s);
  return s;
}

std::vector<CheckCase> checkCases() {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  return {
      {"not a leap year", ArisSetDateTime{"2017-Feb-29 00:00:00"}, R::kDateTimeInvalid, "2017-Feb-29"},
      {"numeric month", ArisSetDateTime{"2017-04-01 13:24:56"}, R::kDateTimeInvalid, "YYYY-Mon-DD"},
      {"hour 24", ArisSetDateTime{"2017-Apr-01 24:00:00"}, R::kDateTimeInvalid, "24:00:00"},
      {"ip part above 255", ArisSetFrameStreamReceiver{"256.0.0.1", 56500}, R::kReceiverAddressInvalid, "256.0.0.1"},
      {"ip of three parts", ArisSetFrameStreamReceiver{"10.0.2", 56500}, R::kReceiverAddressInvalid, "10.0.2"},
      {"ip with a leading zero", ArisSetFrameStreamReceiver{"10.0.0.02", 56500}, R::kReceiverAddressInvalid, "02"},
      {"ip with a control byte", ArisSetFrameStreamReceiver{std::string("10.0.0.\x01", 8), 56500},
       R::kReceiverAddressInvalid, "ip \"10.0.0.?\""},
      {"ip with a trailing dot", ArisSetFrameStreamReceiver{"10.0.0.2.", 56500}, R::kReceiverAddressInvalid, "2."},
      {"port 0", ArisSetFrameStreamReceiver{"10.0.0.2", 0}, R::kReceiverPortInvalid, "port 0"},
      {"port above 16 bits", ArisSetFrameStreamReceiver{"10.0.0.2", 65536}, R::kReceiverPortInvalid, "port 65536"},
      {"delay 20 ms", ArisSetFrameStreamSettings{ArisPacketLossMitigation::kDropPartialFrames, true, 20000},
       R::kInterpacketDelayOutOfRange, "delayPeriod 20000"},
      {"frame rate 0", with([](auto& s) { s.frame_rate_hz = 0.0f; }), R::kFrameRateOutOfRange, "frameRate 0"},
      {"frame rate NaN", with([&](auto& s) { s.frame_rate_hz = nan; }), R::kFrameRateOutOfRange, "frameRate nan"},
      {"frame rate 16", with([](auto& s) { s.frame_rate_hz = 16.0f; }), R::kFrameRateOutOfRange, "frameRate 16"},
      {"199 samples", with([](auto& s) { s.samples_per_beam = 199; }), R::kSamplesPerBeamOutOfRange,
       "samplesPerBeam 199, the ARIS 1800 takes [200, 4000]"},
      {"4001 samples", with([](auto& s) { s.samples_per_beam = 4001; }), R::kSamplesPerBeamOutOfRange, "4001"},
      {"the largest uint32", with([](auto& s) { s.samples_per_beam = UINT32_MAX; }), R::kSamplesPerBeamOutOfRange,
       "samplesPerBeam 4294967295,"},
      {"delay 929 us", with([](auto& s) { s.sample_start_delay_us = 929; }), R::kSampleStartDelayOutOfRange,
       "sampleStartDelay 929 us"},
      {"delay beyond the 1800's", with([](auto& s) { s.sample_start_delay_us = 36001; }),
       R::kSampleStartDelayOutOfRange, "[930, 36000]"},
      {"sample period 3 us", with([](auto& s) { s.sample_period_us = 3; }), R::kSamplePeriodOutOfRange,
       "samplePeriod 3 us"},
      {"sample period 21 us", with([](auto& s) { s.sample_period_us = 21; }), R::kSamplePeriodOutOfRange,
       "samplePeriod 21 us, the ARIS 1800 takes [4, 20]"},
      {"cycle shorter than the sampling", with([](auto& s) { s.cycle_period_us = 13000; }), R::kCyclePeriodOutOfRange,
       "cyclePeriod 13000 us, shorter than the 13519 us"},
      {"cycle beyond the 1800's", with([](auto& s) { s.cycle_period_us = 80001; }), R::kCyclePeriodOutOfRange,
       "cyclePeriod 80001"},
      {"pulse 25 us at high frequency", with([](auto& s) { s.pulse_width_us = 25; }), R::kPulseWidthOutOfRange,
       "pulseWidth (high frequency) 25 us, the ARIS 1800 takes [6, 24]"},
      {"pulse 5 us", with([](auto& s) { s.pulse_width_us = 5; }), R::kPulseWidthOutOfRange, "5 us"},
      {"ping mode of the 3000", with([](auto& s) { s.ping_mode = 9; }), R::kPingModeUnknown,
       "pingMode 9, the ARIS 1800 has 1, 3"},
      {"ping mode 2", with([](auto& s) { s.ping_mode = 2; }), R::kPingModeUnknown, "pingMode 2"},
      {"gain -1 dB", with([](auto& s) { s.receiver_gain_db = -1.0f; }), R::kReceiverGainOutOfRange, "receiverGain -1"},
      {"gain NaN", with([&](auto& s) { s.receiver_gain_db = nan; }), R::kReceiverGainOutOfRange, "nan"},
      {"focus negative", ArisSetFocus{-0.5f}, R::kFocusRangeOutOfRange, "focusRange -0.5 m"},
      {"focus NaN", ArisSetFocus{nan}, R::kFocusRangeOutOfRange, "nan"},
      {"focus beyond the window", ArisSetFocus{51.0f}, R::kFocusRangeOutOfRange, "[0, 50] m"},
  };
}

TEST(ArisCommandCheck, OutOfRangeValuesAreRefusedNamingFieldAndValue) {
  for (const auto& c : checkCases()) {
    SCOPED_TRACE(c.name);
    const auto r = validateArisCommand(c.command, ArisSystemType::k1800);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->reason, c.reason) << arisCommandRefusalName(r->reason);
    EXPECT_TRUE(test::contains(r->detail, c.detail)) << r->detail;
    // What the device refuses, the wire carries unchanged: the mock sees the same value.
    ArisCommandDecoder decoder;
    const auto decoded = decoder.feed(encodeArisCommand(c.command));
    ASSERT_EQ(decoded.size(), 1u);
    ASSERT_TRUE(decoded[0].command);
    EXPECT_EQ(validateArisCommand(*decoded[0].command, ArisSystemType::k1800)->reason, c.reason);
  }
}

TEST(ArisCommandCheck, LimitsAreThoseOfTheModel) {
  // 25 us is too long a pulse at high frequency for the 1800, not at low; 21 us sample period is
  // beyond the 1800, within the 1200. Ping mode 9 is the 3000's.
  EXPECT_FALSE(validateArisCommand(with([](auto& s) {
                                     s.pulse_width_us = 25;
                                     s.frequency = ArisFrequency::kLow;
                                   }),
                                   ArisSystemType::k1800));
  EXPECT_FALSE(validateArisCommand(with([](auto& s) {
                                     s.sample_period_us = 21;
                                     s.ping_mode = 1;
                                     s.cycle_period_us = 30000;
                                   }),
                                   ArisSystemType::k1200));
  EXPECT_FALSE(validateArisCommand(with([](auto& s) {
                                     s.ping_mode = 9;
                                     s.pulse_width_us = 12;
                                   }),
                                   ArisSystemType::k3000));
  EXPECT_FALSE(validateArisCommand(ArisSetFrameStreamReceiver{"0.0.0.0", 1}, ArisSystemType::k1800));  // stop
}

TEST(ArisCommandCheck, EveryRefusalReasonIsReachableAndNamed) {
  std::set<R> seen;
  for (const auto& c : checkCases()) seen.insert(c.reason);
  for (const R r :
       {R::kLengthOutOfBounds, R::kUndecodable, R::kUnsupportedType, R::kPayloadMissing, R::kFieldMissing}) {
    seen.insert(r);  // each has its decoder test above
  }
  EXPECT_EQ(seen.size(), kArisCommandRefusalCount);
  std::set<std::string_view> names;
  for (std::size_t i = 0; i < kArisCommandRefusalCount; ++i) {
    const auto name = arisCommandRefusalName(static_cast<R>(i));
    EXPECT_FALSE(name.empty());
    names.insert(name);
  }
  EXPECT_EQ(names.size(), kArisCommandRefusalCount);
}

// ---- Acoustic settings from a range window ----

struct Window {
  ArisSystemType model;
  std::uint32_t ping_mode;
  double start_m, end_m, c_mps;
  std::uint32_t samples;  // wanted, or 0 for resolution
  double resolution_m;
  double frame_rate_hz;
};

ArisSonarConfig configOf(const Window& w) {
  ArisSonarConfig c;
  c.model = w.model;
  c.ping_mode = w.ping_mode;
  c.window_start_m = w.start_m;
  c.window_end_m = w.end_m;
  c.sound_speed_mps = w.c_mps;
  c.samples_per_beam = w.samples;
  c.range_resolution_m = w.resolution_m;
  c.frame_rate_hz = w.frame_rate_hz;
  return c;
}

TEST(ArisAcousticDerivation, SettingsReproduceTheWindowWithinOneSample) {
  const std::vector<Window> windows = {
      {ArisSystemType::k1800, 3, 1.0, 10.0, 1480.0, 1000, 0.0, 5.0},
      {ArisSystemType::k1800, 1, 0.7, 5.0, 1400.0, 0, 0.005, 15.0},
      {ArisSystemType::k1800, 3, 3.0, 45.0, 1530.0, 2000, 0.0, 1.0},
      {ArisSystemType::k1800, 3, 2.0, 2.3, 1500.0, 200, 0.0, 10.0},  // short: 200 samples of 4 us
      {ArisSystemType::k3000, 9, 1.5, 8.0, 1450.0, 1500, 0.0, 5.0},
      {ArisSystemType::k3000, 6, 0.8, 20.0, 1600.0, 0, 0.01, 2.0},
      {ArisSystemType::k1200, 1, 1.0, 100.0, 1480.0, 0, 0.01, 2.0},  // long: capped at 4000 samples
      {ArisSystemType::k1200, 1, 10.0, 60.0, 1410.0, 1200, 0.0, 3.0},
  };
  for (const auto& w : windows) {
    const auto config = configOf(w);
    SCOPED_TRACE(std::string(arisModelLimits(w.model).name) + " " + std::to_string(w.start_m) + "-" +
                 std::to_string(w.end_m) + " m at " + std::to_string(w.c_mps) + " m/s");
    const auto d = deriveArisAcousticSettings(config);
    ASSERT_TRUE(d.ok()) << d.error().message;
    const auto& a = d->acoustic;
    const auto& m = arisModelLimits(w.model);
    const double m_per_us = w.c_mps * 1e-6 / 2;
    const double sample_m = a.sample_period_us * m_per_us;

    EXPECT_EQ(a.sample_start_delay_us, static_cast<std::uint32_t>(std::lround(2 * w.start_m / w.c_mps * 1e6)));
    EXPECT_NEAR(d->window_start_m, a.sample_start_delay_us * m_per_us, 1e-12);
    EXPECT_NEAR(d->window_end_m, d->window_start_m + a.samples_per_beam * sample_m, 1e-9);
    EXPECT_DOUBLE_EQ(d->sample_length_m, sample_m);
    // The achieved window covers the requested one, within one sample at each end.
    EXPECT_LE(std::abs(d->window_start_m - w.start_m), sample_m);
    EXPECT_GE(d->window_end_m, w.end_m - 1e-9);
    if (a.samples_per_beam > kArisSamplesPerBeamMin) {
      EXPECT_LT(d->window_end_m, w.end_m + sample_m);
    }
    EXPECT_GE(a.samples_per_beam, kArisSamplesPerBeamMin);
    EXPECT_LE(a.samples_per_beam, kArisSamplesPerBeamMax);
    EXPECT_GE(a.sample_period_us, m.sample_period_min_us);
    EXPECT_LE(a.sample_period_us, m.sample_period_max_us);
    // The cycle holds the sampling and the margin; the frames fit in the frame period.
    EXPECT_GE(a.cycle_period_us, a.sample_start_delay_us + a.samples_per_beam * a.sample_period_us + 420);
    EXPECT_LE(w.frame_rate_hz, d->max_frame_rate_hz);
    EXPECT_LE(*arisPingsPerFrame(w.ping_mode) * a.cycle_period_us * 1e-6, 1.0 / w.frame_rate_hz);
    // Focus in the middle of the achieved window.
    EXPECT_NEAR(d->focus.focus_range_m, (d->window_start_m + d->window_end_m) / 2, 1e-5);
    // Pulse width within the model's limits and the energy limit.
    EXPECT_GE(a.pulse_width_us, m.pulse_high.min_us);
    EXPECT_LE(a.pulse_width_us, m.pulse_high.max_us);
    EXPECT_LE(a.pulse_width_us * w.frame_rate_hz, m.max_pulse_us_per_s);
    EXPECT_EQ(a.cookie, 0u);
    // What we send, the device takes.
    for (const ArisCommand& c : {ArisCommand{a}, ArisCommand{d->focus}, ArisCommand{d->salinity}}) {
      const auto r = validateArisCommand(c, w.model);
      EXPECT_FALSE(r) << r->detail;
    }
  }
}

TEST(ArisAcousticDerivation, ThePeriodIsTheOneWantedRoundedAndTheClampsShowInTheSamples) {
  // 1-10 m at 1480 m/s, 1000 samples: 12.16 us wanted -> 12 us, 1014 samples reach 10 m.
  const auto d = deriveArisAcousticSettings(ArisSonarConfig{});
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->acoustic.sample_start_delay_us, 1351u);
  EXPECT_EQ(d->acoustic.sample_period_us, 12u);
  EXPECT_EQ(d->acoustic.samples_per_beam, 1014u);
  EXPECT_EQ(d->acoustic.cycle_period_us, 1351u + 1014u * 12u + 420u);
  EXPECT_EQ(d->acoustic.pulse_width_us, 15u);  // 1.5 us/m x 10 m
  EXPECT_EQ(d->acoustic.ping_mode, 3u);
  EXPECT_EQ(d->acoustic.frame_rate_hz, 5.0f);
  EXPECT_EQ(d->acoustic.receiver_gain_db, 18.0f);

  // A 0.3 m window: 200 samples at the shortest period, so the window is longer than asked.
  auto cfg = configOf({ArisSystemType::k1800, 3, 2.0, 2.3, 1500.0, 200, 0.0, 10.0});
  const auto shortw = deriveArisAcousticSettings(cfg);
  ASSERT_TRUE(shortw.ok()) << shortw.error().message;
  EXPECT_EQ(shortw->acoustic.samples_per_beam, 200u);
  EXPECT_EQ(shortw->acoustic.sample_period_us, 4u);

  // 99 m of 1 cm samples would be ~13 400: the period rises until 4000 samples are enough.
  cfg = configOf({ArisSystemType::k1200, 1, 1.0, 100.0, 1480.0, 0, 0.01, 2.0});
  const auto longw = deriveArisAcousticSettings(cfg);
  ASSERT_TRUE(longw.ok()) << longw.error().message;
  EXPECT_EQ(longw->acoustic.sample_period_us, 34u);
  EXPECT_LE(longw->acoustic.samples_per_beam, 4000u);
}

TEST(ArisAcousticDerivation, EnergyLimitCapsThePulseAboveTheMinimum) {
  // The cap (max pulse per second / 15 frames/s) never falls below a model's shortest pulse, so
  // capping never yields a pulse the device refuses.
  for (const auto model : {ArisSystemType::k1800, ArisSystemType::k3000, ArisSystemType::k1200}) {
    const auto& m = arisModelLimits(model);
    EXPECT_GE(m.max_pulse_us_per_s / kArisFrameRateMaxHz, m.pulse_high.min_us) << m.name;
    EXPECT_GE(m.max_pulse_us_per_s / kArisFrameRateMaxHz, m.pulse_low.min_us) << m.name;
  }
  const auto d = deriveArisAcousticSettings(configOf({ArisSystemType::k1800, 1, 1.0, 14.0, 1480.0, 0, 0.03, 15.0}));
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->acoustic.pulse_width_us, 20u);  // 1.5 us/m x 14 m = 21 us, capped at 300 / 15 = 20 us
  // A small pulse stays at the model's minimum: 1 us/m x 6 m, raised to the 1200's 8 us.
  const auto small = deriveArisAcousticSettings(configOf({ArisSystemType::k1200, 1, 1.0, 6.0, 1480.0, 400, 0.0, 15.0}));
  ASSERT_TRUE(small.ok()) << small.error().message;
  EXPECT_EQ(small->acoustic.pulse_width_us, 8u);
}

TEST(ArisAcousticDerivation, CookieChangesExactlyWhenTheSettingsChange) {
  ArisSettingsCookies cookies;
  EXPECT_EQ(cookies.last(), 0u);
  auto a = deriveArisAcousticSettings(ArisSonarConfig{})->acoustic;
  cookies.stamp(a);
  EXPECT_EQ(a.cookie, 1u);
  auto again = deriveArisAcousticSettings(ArisSonarConfig{})->acoustic;
  cookies.stamp(again);
  EXPECT_EQ(again.cookie, 1u);  // the same settings: the same cookie
  ArisSonarConfig farther;
  farther.window_end_m = 12.0;
  auto b = deriveArisAcousticSettings(farther)->acoustic;
  cookies.stamp(b);
  EXPECT_EQ(b.cookie, 2u);
  auto back = deriveArisAcousticSettings(ArisSonarConfig{})->acoustic;
  cookies.stamp(back);
  EXPECT_EQ(back.cookie, 3u);  // a change back is a change
  EXPECT_EQ(cookies.last(), 3u);

  // A client started again counts from elsewhere, so the settings the sonar kept from the one
  // before (cookie 1 to 3 here) are not taken for its own; the count wraps past 0.
  ArisSettingsCookies restarted(arisFirstCookie(1'764'900'000));
  auto c = deriveArisAcousticSettings(ArisSonarConfig{})->acoustic;
  restarted.stamp(c);
  EXPECT_EQ(c.cookie, arisFirstCookie(1'764'900'000));
  EXPECT_NE(arisFirstCookie(1'764'900'000), arisFirstCookie(1'764'900'001));
  EXPECT_GE(arisFirstCookie(0), 1u);
  EXPECT_GE(arisFirstCookie(-5), 1u);
  ArisSettingsCookies at_end(UINT32_MAX);
  auto d = deriveArisAcousticSettings(ArisSonarConfig{})->acoustic;
  at_end.stamp(d);
  EXPECT_EQ(d.cookie, UINT32_MAX);
  at_end.stamp(b);
  EXPECT_EQ(b.cookie, 1u);
}

struct BadConfig {
  const char* name;
  std::function<void(ArisSonarConfig&)> change;
  const char* error;
};

TEST(ArisAcousticDerivation, BadInputsAreErrorsNamingTheKeyAndValue) {
  const std::vector<BadConfig> cases = {
      {"start NaN", [](auto& c) { c.window_start_m = kNaN; }, "window_start_m: nan"},
      {"start negative", [](auto& c) { c.window_start_m = -1.0; }, "window_start_m: -1, outside the ARIS 1800's"},
      {"start at end", [](auto& c) { c.window_start_m = c.window_end_m = 5.0; }, "window_end_m: 5, must be beyond"},
      {"start after end",
       [](auto& c) {
         c.window_start_m = 8.0;
         c.window_end_m = 4.0;
       },
       "window_end_m: 4"},
      {"end NaN", [](auto& c) { c.window_end_m = kNaN; }, "window_end_m: nan"},
      {"end beyond the model", [](auto& c) { c.window_end_m = 60.0; },
       "window_end_m: 60, outside the ARIS 1800's [1.3, 50] m"},
      {"end beyond the 3000",
       [](auto& c) {
         c.model = ArisSystemType::k3000;
         c.ping_mode = 9;
         c.window_end_m = 25.0;
       },
       "window_end_m: 25, outside the ARIS 3000's [1.3, 20] m"},
      {"ping mode unknown", [](auto& c) { c.ping_mode = 9; }, "ping_mode: 9, the ARIS 1800's are 1, 3"},
      {"ping mode 0", [](auto& c) { c.ping_mode = 0; }, "ping_mode: 0"},
      {"model unknown", [](auto& c) { c.model = static_cast<ArisSystemType>(7); }, "model: 7"},
      {"sound speed NaN", [](auto& c) { c.sound_speed_mps = kNaN; }, "sound_speed_mps: nan"},
      {"sound speed of air", [](auto& c) { c.sound_speed_mps = 343.0; }, "sound_speed_mps: 343"},
      {"frame rate 0", [](auto& c) { c.frame_rate_hz = 0.0; }, "frame_rate_hz: 0, must be in [1, 15]"},
      {"frame rate NaN", [](auto& c) { c.frame_rate_hz = kNaN; }, "frame_rate_hz: nan"},
      {"frame rate too high for the window",
       [](auto& c) {
         c.window_end_m = 45.0;
         c.frame_rate_hz = 10.0;
       },
       "frame_rate_hz: 10, above the"},
      {"salinity unknown", [](auto& c) { c.salinity = static_cast<ArisSalinity>(3); }, "salinity: 3"},
      {"frequency unknown", [](auto& c) { c.frequency = static_cast<ArisFrequency>(2); }, "frequency: 2"},
      {"samples and resolution", [](auto& c) { c.range_resolution_m = 0.01; }, "exactly one must be non-zero"},
      {"neither samples nor resolution", [](auto& c) { c.samples_per_beam = 0; }, "exactly one must be non-zero"},
      {"too few samples", [](auto& c) { c.samples_per_beam = 100; }, "samples_per_beam: 100, must be in [200, 4000]"},
      {"resolution NaN",
       [](auto& c) {
         c.samples_per_beam = 0;
         c.range_resolution_m = kNaN;
       },
       "range_resolution_m: nan"},
      {"resolution negative",
       [](auto& c) {
         c.samples_per_beam = 0;
         c.range_resolution_m = -0.01;
       },
       "range_resolution_m: -0.01"},
      {"gain 30 dB", [](auto& c) { c.receiver_gain_db = 30.0; }, "receiver_gain_db: 30"},
      {"delay below the device's",
       [](auto& c) {
         c.window_start_m = 0.7;
         c.sound_speed_mps = 1600.0;
       },
       "window_start_m: 0.7 at 1600 m/s is a sample start delay of 875 us, outside the ARIS 1800's [930, 36000] us"},
  };
  for (const auto& b : cases) {
    SCOPED_TRACE(b.name);
    ArisSonarConfig config;
    b.change(config);
    const auto d = deriveArisAcousticSettings(config);
    ASSERT_FALSE(d.ok());
    EXPECT_TRUE(test::contains(d.error().message, b.error)) << d.error().message;
  }
}

}  // namespace
}  // namespace vog::sonar
