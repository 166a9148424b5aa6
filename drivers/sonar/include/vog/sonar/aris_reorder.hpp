#pragma once
// ARIS frame data reordering. An ARIS sends a frame's data in the order its receiver boards sample
// it, not in beam/sample order; a receiver reorders it according to the frame header's PingMode
// (then the header's ReorderedSamples flag is set). Sound Metrics ARIS Integration SDK,
// common/code/Reordering, checked bit-exact against its test vectors (data/aris-sdk/reorder):
//   a frame of B beams is fired as P = B / 16 pings of 16 beams each; the data holds, ping after
//   ping and within a ping sample after sample, the 16 channels of that ping; channel c of ping p
//   is beam kChannelBeam[c] * P + p, kChannelBeam = {10, 2, 14, 6, 8, 0, 12, 4, 11, 3, 15, 7, 9,
//   1, 13, 5}.
// The SDK defines P for PingMode 1, 3, 6 and 9 (48, 96, 64, 128 beams); every PingMode that
// arisBeamsForPingMode knows is reordered here by the same rule with P = beams / 16.

#include "vog/core/result.hpp"

#include <cstdint>
#include <span>

namespace vog::sonar {

// sonar_order (as received) -> beam_order (samples[s * beams + b], as SonarFrame holds them).
// Both spans hold beams x samples_per_beam bytes and must not overlap. Error, naming the value, if
// the PingMode is unknown or a size is not beams x samples_per_beam.
Status arisSonarToBeamOrder(std::uint32_t ping_mode, std::uint32_t samples_per_beam,
                            std::span<const std::uint8_t> sonar_order, std::span<std::uint8_t> beam_order);

// The exact inverse of arisSonarToBeamOrder (what a sonar sends for a frame in beam order).
Status arisBeamToSonarOrder(std::uint32_t ping_mode, std::uint32_t samples_per_beam,
                            std::span<const std::uint8_t> beam_order, std::span<std::uint8_t> sonar_order);

}  // namespace vog::sonar
