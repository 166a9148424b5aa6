#include "vog/core/bytes.hpp"
#include "vog/core/crc.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/imu/rawimus.hpp"

#include <gtest/gtest.h>

#include <cstring>

namespace vog::imu {
namespace {

ImuSample makeSample(std::uint32_t seq) {
  ImuSample s;
  s.sequence = seq;
  s.status = 0x0102;
  s.attitude = ImuAttitude{0.1234, -0.0567, 3.0};
  s.angular_rate_radps = Eigen::Vector3d(0.01, -0.2, 1.5);
  s.delta_velocity_mps = Eigen::Vector3d(0.00981, -0.00002, 0.0981);
  s.dt_s = 0.01;
  return s;
}

std::vector<std::uint8_t> encodeBytes(const ImuSample& s) {
  auto frames = encodeImuCan(s);
  EXPECT_TRUE(frames.ok()) << frames.error().message;
  return canFramesToBytes(*frames);
}

TEST(ImuCan, RoundTripWithinWireResolution) {
  const ImuSample in = makeSample(200);
  const auto bytes = encodeBytes(in);
  ASSERT_EQ(bytes.size(), 64u);
  auto r = ImuCanCodec{}.decode(bytes);
  ASSERT_TRUE(r.isFrame()) << r.reason();
  const ImuSample& out = r.frame();
  EXPECT_EQ(out.sequence, 200u);
  EXPECT_EQ(out.status, 0x0102u);
  EXPECT_NEAR(out.attitude->roll_rad, 0.1234, 0.5e-4);
  EXPECT_NEAR(out.attitude->pitch_rad, -0.0567, 0.5e-4);
  EXPECT_NEAR(out.attitude->yaw_rad, 3.0, 0.5e-4);
  EXPECT_LT((*out.angular_rate_radps - *in.angular_rate_radps).cwiseAbs().maxCoeff(), 0.5e-4 + 1e-12);
  EXPECT_LT((out.delta_velocity_mps - in.delta_velocity_mps).cwiseAbs().maxCoeff(), 0.5e-5 + 1e-12);
  EXPECT_DOUBLE_EQ(out.dt_s, 0.01);
}

TEST(ImuCan, FramesCarryTheDocumentedIdsAndCrc) {
  auto frames = encodeImuCan(makeSample(7));
  ASSERT_TRUE(frames.ok());
  for (canid_t k = 0; k < 4; ++k) {
    EXPECT_EQ((*frames)[k].can_id, 0x180u + k);
    EXPECT_EQ((*frames)[k].len, 8);
    EXPECT_EQ((*frames)[k].data[0], 7);
  }
  // README: CRC-16/CCITT-FALSE over 8 + 8 + 8 + 6 bytes, little-endian in frame 3 bytes 6-7.
  std::array<std::uint8_t, 30> covered{};
  for (std::size_t i = 0; i < covered.size(); ++i) covered[i] = (*frames)[i / 8].data[i % 8];
  const std::uint16_t crc = crc16CcittFalse(covered);
  EXPECT_EQ((*frames)[3].data[6], crc & 0xFF);
  EXPECT_EQ((*frames)[3].data[7], crc >> 8);
}

TEST(ImuCan, OutOfRangeValueIsAnErrorNamingTheField) {
  ImuSample s = makeSample(1);
  s.delta_velocity_mps.x() = 1.0;
  auto r = encodeImuCan(s);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("delta_velocity_mps"), std::string::npos);
  s = makeSample(1);
  s.attitude.reset();
  EXPECT_FALSE(encodeImuCan(s).ok());
}

TEST(ImuCan, StreamSkipsForeignFramesLostFramesAndCountsBadCrc) {
  std::vector<std::uint8_t> stream;
  auto append = [&](const std::vector<std::uint8_t>& b) { stream.insert(stream.end(), b.begin(), b.end()); };
  can_frame foreign{};
  foreign.can_id = 0x123;
  foreign.len = 2;
  append(canFramesToBytes(std::span(&foreign, 1)));  // another node on the bus
  append(encodeBytes(makeSample(1)));
  auto lost = encodeBytes(makeSample(2));
  lost.erase(lost.begin() + 32, lost.begin() + 48);  // frame 2 lost on the bus
  append(lost);
  auto damaged = encodeBytes(makeSample(3));
  damaged[16 + 8 + 3] ^= 0x40;  // a bit flip in frame 1's payload
  append(damaged);
  append(encodeBytes(makeSample(4)));
  const auto last = encodeBytes(makeSample(5));
  append(std::vector<std::uint8_t>(last.begin(), last.begin() + 40));

  const auto d = codec::decodeAll<ImuCanCodec>(stream);
  ASSERT_EQ(d.frames.size(), 2u);
  EXPECT_EQ(d.frames[0].sequence, 1u);
  EXPECT_EQ(d.frames[1].sequence, 4u);
  EXPECT_EQ(d.stats.bad_checksum, 1u);
  EXPECT_EQ(d.stats.malformed, 1u);  // sample 2's frame 0
  EXPECT_EQ(d.trailing_bytes, 40u);  // sample 5 truncated: need more
}

TEST(RawImus, RoundTripAndCrcProtectsEveryByte) {
  ImuSample in;
  in.stamp_ns = 1700000000123000000LL;
  in.status = 0x00000077;
  in.delta_velocity_mps = Eigen::Vector3d(0.0123, -0.0456, 0.0981);
  in.delta_angle_rad = Eigen::Vector3d(1e-4, -2e-4, 3e-4);
  const auto bytes = encodeRawImus(in);
  ASSERT_EQ(bytes.size(), rawimus::kRecordBytes);
  auto r = RawImusCodec{}.decode(bytes);
  ASSERT_TRUE(r.isFrame()) << r.reason();
  const RawImusConfig cfg;
  EXPECT_NEAR(static_cast<double>(r.frame().stamp_ns - in.stamp_ns), 0.0, 1000.0);
  EXPECT_EQ(r.frame().status, 0x77u);
  EXPECT_LT((r.frame().delta_velocity_mps - in.delta_velocity_mps).cwiseAbs().maxCoeff(),
            cfg.accel_scale_mps_per_count);
  EXPECT_LT((*r.frame().delta_angle_rad - *in.delta_angle_rad).cwiseAbs().maxCoeff(), cfg.gyro_scale_rad_per_count);
  EXPECT_DOUBLE_EQ(r.frame().dt_s, 0.01);
  for (std::size_t i = 3; i < bytes.size(); ++i) {
    auto damaged = bytes;
    damaged[i] ^= 0x10;
    auto bad = RawImusCodec{}.decode(damaged);
    EXPECT_TRUE(bad.isBad()) << "byte " << i;
  }
}

TEST(RawImus, ResyncAfterGarbageAndTruncation) {
  ImuSample s;
  s.stamp_ns = 1700000000000000000LL;
  const auto rec = encodeRawImus(s);
  std::vector<std::uint8_t> stream = {0x00, 0xAA, 0x44, 0x01, 0xAA};
  stream.insert(stream.end(), rec.begin(), rec.begin() + 20);  // cut short
  stream.insert(stream.end(), rec.begin(), rec.end());
  stream.insert(stream.end(), rec.begin(), rec.begin() + 30);
  const auto d = codec::decodeAll<RawImusCodec>(stream);
  EXPECT_EQ(d.frames.size(), 1u);
  EXPECT_EQ(d.trailing_bytes, 30u);
  EXPECT_EQ(d.stats.bad_checksum, 1u);  // the cut record plus the start of the next fails its CRC
}

}  // namespace
}  // namespace vog::imu
