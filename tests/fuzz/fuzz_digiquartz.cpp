#include "vog/codec/stream_decoder.hpp"
#include "vog/depth/digiquartz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto decoded = vog::codec::decodeAll<vog::depth::DigiquartzCodec>({data, size});
  vog::depth::DepthConversionConfig config;
  for (const auto& m : decoded.frames) (void)vog::depth::toDepthSample(m, config, 0);
  return 0;
}
