#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd6.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto decoded = vog::codec::decodeAll<vog::dvl::Pd6Codec>({data, size});
  for (const auto& s : decoded.frames) {
    (void)vog::dvl::encodePd6(s);
    if (const auto* v = std::get_if<vog::dvl::Pd6Velocity>(&s)) (void)vog::dvl::bottomVelocity(*v, 0);
  }
  return 0;
}
