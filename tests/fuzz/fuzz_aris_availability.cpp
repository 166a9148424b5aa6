// ARIS Availability beacon: arbitrary datagrams never crash the decoder; a refusal names what is
// wrong, and a beacon it accepts re-encodes to bytes that decode to the same beacon.
#include "fuzz_check.hpp"
#include "vog/sonar/aris_availability.hpp"

#include <cstdint>
#include <span>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto beacon = vog::sonar::decodeArisAvailability(std::span<const std::uint8_t>(data, size));
  if (!beacon.ok()) {
    VOG_FUZZ_CHECK(!beacon.error().message.empty());
    return 0;
  }
  const auto again = vog::sonar::decodeArisAvailability(vog::sonar::encodeArisAvailability(*beacon));
  VOG_FUZZ_CHECK(again.ok());
  VOG_FUZZ_CHECK(*again == *beacon);
  return 0;
}
