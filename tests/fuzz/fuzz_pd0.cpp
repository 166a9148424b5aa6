// PD0: decoding arbitrary bytes never crashes; every delivered ensemble re-encodes to bytes that
// decode again to the same ensemble number and clock.
#include "fuzz_check.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd0.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto decoded = vog::codec::decodeAll<vog::dvl::Pd0Codec>({data, size});
  for (const auto& e : decoded.frames) {
    const auto bytes = vog::dvl::encodePd0(e);
    auto again = vog::dvl::Pd0Codec{}.decode(bytes);
    VOG_FUZZ_CHECK(again.isFrame());
    VOG_FUZZ_CHECK(again.consumed() == bytes.size());
    VOG_FUZZ_CHECK(again.frame().variable.ensemble_number == e.variable.ensemble_number);
    VOG_FUZZ_CHECK(again.frame().variable.clock.hundredths == e.variable.clock.hundredths);
    (void)vog::dvl::bottomVelocity(e);
  }
  return 0;
}
