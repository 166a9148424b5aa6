#include "vog/sonar/aris_reorder.hpp"

#include "vog/sonar/sonar_files.hpp"

#include <array>
#include <cassert>
#include <cstddef>
#include <string>

namespace vog::sonar {
namespace {

constexpr std::size_t kChannelsPerPing = 16;
// Beam group of each receiver channel (ARIS Integration SDK, common/code/Reordering).
constexpr std::array<std::size_t, kChannelsPerPing> kChannelBeam = {10, 2, 14, 6, 8, 0, 12, 4,
                                                                    11, 3, 15, 7, 9, 1, 13, 5};

struct Layout {
  std::size_t beams;
  std::size_t samples;
  std::size_t pings;
};

Result<Layout> layoutFor(std::uint32_t ping_mode, std::uint32_t samples_per_beam, std::size_t in_bytes,
                         std::size_t out_bytes) {
  const auto beams = arisBeamsForPingMode(ping_mode);
  if (!beams.ok()) return beams.error();
  const Layout l{static_cast<std::size_t>(*beams), samples_per_beam,
                 static_cast<std::size_t>(*beams) / kChannelsPerPing};
  const std::size_t expected = l.beams * l.samples;
  if (in_bytes != expected || out_bytes != expected) {
    return Error{"ARIS reorder: PingMode " + std::to_string(ping_mode) + " (" + std::to_string(l.beams) + " beams) x " +
                 std::to_string(samples_per_beam) + " samples is " + std::to_string(expected) + " bytes, got " +
                 std::to_string(in_bytes) + " in and " + std::to_string(out_bytes) + " out"};
  }
  return l;
}

[[maybe_unused]] bool overlap(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b) {
  return !a.empty() && !b.empty() && a.data() < b.data() + b.size() && b.data() < a.data() + a.size();
}

}  // namespace

Status arisSonarToBeamOrder(std::uint32_t ping_mode, std::uint32_t samples_per_beam,
                            std::span<const std::uint8_t> sonar_order, std::span<std::uint8_t> beam_order) {
  const auto l = layoutFor(ping_mode, samples_per_beam, sonar_order.size(), beam_order.size());
  if (!l.ok()) return l.error();
  assert(!overlap(sonar_order, beam_order));
  const std::uint8_t* in = sonar_order.data();
  for (std::size_t p = 0; p < l->pings; ++p) {
    for (std::size_t s = 0; s < l->samples; ++s) {
      std::uint8_t* row = beam_order.data() + s * l->beams + p;
      for (std::size_t c = 0; c < kChannelsPerPing; ++c) row[kChannelBeam[c] * l->pings] = in[c];
      in += kChannelsPerPing;
    }
  }
  return {};
}

Status arisBeamToSonarOrder(std::uint32_t ping_mode, std::uint32_t samples_per_beam,
                            std::span<const std::uint8_t> beam_order, std::span<std::uint8_t> sonar_order) {
  const auto l = layoutFor(ping_mode, samples_per_beam, beam_order.size(), sonar_order.size());
  if (!l.ok()) return l.error();
  assert(!overlap(beam_order, sonar_order));
  std::uint8_t* out = sonar_order.data();
  for (std::size_t p = 0; p < l->pings; ++p) {
    for (std::size_t s = 0; s < l->samples; ++s) {
      const std::uint8_t* row = beam_order.data() + s * l->beams + p;
      for (std::size_t c = 0; c < kChannelsPerPing; ++c) out[c] = row[kChannelBeam[c] * l->pings];
      out += kChannelsPerPing;
    }
  }
  return {};
}

}  // namespace vog::sonar
