#include "fuzz_check.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/imu/rawimus.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto decoded = vog::codec::decodeAll<vog::imu::RawImusCodec>({data, size});
  for (const auto& s : decoded.frames) {
    const auto bytes = vog::imu::encodeRawImus(s);
    auto again = vog::imu::RawImusCodec{}.decode(bytes);
    VOG_FUZZ_CHECK(again.isFrame());
    VOG_FUZZ_CHECK(again.frame().status == s.status);
  }
  return 0;
}
