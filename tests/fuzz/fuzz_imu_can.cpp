// IMU CAN: arbitrary records never crash the decoder; a delivered sample re-encodes (its values
// came from the wire, so they are in range) to frames that decode to the same sample.
#include "fuzz_check.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/imu/imu_can.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto decoded = vog::codec::decodeAll<vog::imu::ImuCanCodec>({data, size});
  for (const auto& s : decoded.frames) {
    const auto frames = vog::imu::encodeImuCan(s);
    VOG_FUZZ_CHECK(frames.ok());
    const auto bytes = vog::imu::canFramesToBytes(*frames);
    auto again = vog::imu::ImuCanCodec{}.decode(bytes);
    VOG_FUZZ_CHECK(again.isFrame());
    VOG_FUZZ_CHECK(again.frame().sequence == s.sequence);
    VOG_FUZZ_CHECK(again.frame().status == s.status);
    VOG_FUZZ_CHECK(again.frame().delta_velocity_mps == s.delta_velocity_mps);
  }
  return 0;
}
