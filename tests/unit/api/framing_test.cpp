#include "vog/api/convert.hpp"
#include "vog/api/framing.hpp"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <string>

namespace vog::api {
namespace {

// Every mission state crosses the wire and back under its own name (near_home was added after the
// first release, as value 7); a value the server does not know is an error naming the field.
TEST(Convert, EveryMissionStateRoundTripsUnderItsOwnName) {
  std::set<std::string> names;
  std::set<int> wire;
  for (int i = 0; i <= static_cast<int>(MissionState::kNearHome); ++i) {
    const auto state = static_cast<MissionState>(i);
    const v1::MissionState w = toProto(state);
    EXPECT_NE(w, v1::MISSION_STATE_UNSPECIFIED);
    EXPECT_EQ(fromProto(w).value(), state);
    names.insert(toString(state));
    wire.insert(static_cast<int>(w));
  }
  EXPECT_EQ(names.size(), 7u);
  EXPECT_EQ(wire.size(), 7u);
  EXPECT_EQ(std::string(toString(MissionState::kNearHome)), "near_home");
  EXPECT_EQ(toProto(MissionState::kNearHome), v1::MISSION_STATE_NEAR_HOME);
  const auto unknown = fromProto(static_cast<v1::MissionState>(42));
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().message.find("mission_state"), std::string::npos) << unknown.error().message;
}

std::vector<v1::Envelope> sampleEnvelopes() {
  std::vector<v1::Envelope> out;
  v1::Envelope hello;
  hello.set_request_id(1);
  hello.mutable_hello()->set_client_name("topside");
  hello.mutable_hello()->set_protocol_version(1);
  out.push_back(hello);
  v1::Envelope empty;  // a zero-length payload is a valid (empty) Envelope
  out.push_back(empty);
  v1::Envelope chunk;
  chunk.set_request_id(0xFFFFFFFFFFFFull);
  auto* block = chunk.mutable_map_chunk()->mutable_delta()->add_changed();
  block->set_origin_x(-8);
  block->set_log_odds(std::string(2048, '\x7f'));
  block->set_known(std::string(64, '\xff'));
  out.push_back(chunk);
  v1::Envelope error;
  error.set_request_id(9);
  error.mutable_error()->set_code(v1::ERROR_CODE_REJECTED);
  error.mutable_error()->set_message("start while exploring");
  out.push_back(error);
  return out;
}

std::vector<std::string> drain(FrameDecoder& decoder) {
  std::vector<std::string> out;
  for (;;) {
    FrameResult r = decoder.next();
    if (std::holds_alternative<FrameNeedMore>(r)) return out;
    EXPECT_TRUE(std::holds_alternative<v1::Envelope>(r));
    if (!std::holds_alternative<v1::Envelope>(r)) return out;
    out.push_back(std::get<v1::Envelope>(r).SerializeAsString());
  }
}

TEST(Framing, HeaderIsBigEndianPayloadLength) {
  v1::Envelope e;
  e.set_request_id(300);
  const std::string frame = encodeFrame(e).value();
  const std::string payload = e.SerializeAsString();
  ASSERT_EQ(frame.size(), 4 + payload.size());
  EXPECT_EQ(frame.substr(0, 4), std::string("\0\0\0", 3) + static_cast<char>(payload.size()));
  EXPECT_EQ(frame.substr(4), payload);
}

// The worked examples of proto/README.md "Framing", byte for byte.
TEST(Framing, ReadmeExamples) {
  v1::Envelope status;
  status.set_request_id(1);
  status.mutable_get_status();
  EXPECT_EQ(encodeFrame(status).value(), std::string("\x00\x00\x00\x04\x08\x01\x62\x00", 8));
  v1::Envelope hello;
  hello.set_request_id(1);
  hello.mutable_hello()->set_client_name("py");
  hello.mutable_hello()->set_protocol_version(1);
  EXPECT_EQ(encodeFrame(hello).value(), std::string("\x00\x00\x00\x0a\x08\x01\x52\x06\x0a\x02py\x10\x01", 14));
}

TEST(Framing, ByteByByteDecodingEqualsOnePiece) {
  std::string stream;
  const auto envelopes = sampleEnvelopes();
  for (const auto& e : envelopes) stream += encodeFrame(e).value();

  FrameDecoder whole(1 << 20);
  whole.feed(stream);
  const auto a = drain(whole);

  FrameDecoder bytewise(1 << 20);
  std::vector<std::string> b;
  for (const char c : stream) {
    bytewise.feed(std::string_view(&c, 1));
    for (auto& s : drain(bytewise)) b.push_back(std::move(s));
  }
  // Random split points too.
  std::mt19937_64 rng(3);
  FrameDecoder pieces(1 << 20);
  std::vector<std::string> c;
  for (std::size_t at = 0; at < stream.size();) {
    const std::size_t n = std::min<std::size_t>(stream.size() - at, 1 + rng() % 700);
    pieces.feed(std::string_view(stream).substr(at, n));
    at += n;
    for (auto& s : drain(pieces)) c.push_back(std::move(s));
  }
  ASSERT_EQ(a.size(), envelopes.size());
  for (std::size_t i = 0; i < envelopes.size(); ++i) EXPECT_EQ(a[i], envelopes[i].SerializeAsString());
  EXPECT_EQ(a, b);
  EXPECT_EQ(a, c);
  EXPECT_EQ(whole.buffered(), 0u);
  EXPECT_EQ(bytewise.buffered(), 0u);
}

TEST(Framing, OversizeLengthIsAnErrorBeforeThePayloadArrives) {
  FrameDecoder decoder(65536);
  decoder.feed(std::string("\xff\xff\xff\xf0", 4));  // 4 GiB announced, nothing else sent
  const FrameResult r = decoder.next();
  ASSERT_TRUE(std::holds_alternative<FrameError>(r));
  const auto& err = std::get<FrameError>(r);
  EXPECT_EQ(err.kind, FrameError::Kind::kTooLarge);
  EXPECT_NE(err.message.find("4294967280"), std::string::npos) << err.message;
  EXPECT_NE(err.message.find("65536"), std::string::npos) << err.message;
  EXPECT_TRUE(decoder.failed());
  EXPECT_EQ(decoder.buffered(), 0u);
  // Failed for good: later bytes are ignored, the error repeats.
  decoder.feed(encodeFrame(sampleEnvelopes()[0]).value());
  EXPECT_TRUE(std::holds_alternative<FrameError>(decoder.next()));

  // Exactly at the limit is fine.
  v1::Envelope e;
  e.mutable_config_text()->set_text(std::string(1000, 'x'));
  const std::string frame = encodeFrame(e).value();
  FrameDecoder exact(static_cast<std::uint32_t>(frame.size() - 4));
  exact.feed(frame);
  EXPECT_TRUE(std::holds_alternative<v1::Envelope>(exact.next()));
  FrameDecoder one_less(static_cast<std::uint32_t>(frame.size() - 5));
  one_less.feed(std::string_view(frame).substr(0, 4));
  EXPECT_TRUE(std::holds_alternative<FrameError>(one_less.next()));
}

TEST(Framing, PayloadThatDoesNotParseIsAnErrorNamingIt) {
  FrameDecoder decoder(1024);
  // Field 1 (request_id) with wire type 7, which protobuf does not define.
  decoder.feed(std::string("\0\0\0\3\x0f\x01\x02", 7));
  const FrameResult r = decoder.next();
  ASSERT_TRUE(std::holds_alternative<FrameError>(r));
  EXPECT_EQ(std::get<FrameError>(r).kind, FrameError::Kind::kMalformed);
  EXPECT_NE(std::get<FrameError>(r).message.find("3 bytes is not a valid vog.v1.Envelope"), std::string::npos);

  // A truncated nested message.
  FrameDecoder truncated(1024);
  truncated.feed(std::string("\0\0\0\2\x52\x05", 6));
  EXPECT_TRUE(std::holds_alternative<FrameError>(truncated.next()));
}

TEST(Framing, EncoderRefusesAnEnvelopeLargerThanTheMaximum) {
  v1::Envelope e;
  e.mutable_config_text()->set_text(std::string(5000, 'x'));
  const auto r = encodeFrame(e, 4096);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("4096"), std::string::npos);
  std::string out = "keep";
  EXPECT_FALSE(appendFrame(e, 4096, out).ok());
  EXPECT_EQ(out, "keep");  // nothing half-written
}

}  // namespace
}  // namespace vog::api
