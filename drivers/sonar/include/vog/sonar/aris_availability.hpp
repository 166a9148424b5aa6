#pragma once
// ARIS live protocol, discovery: the aris.Availability beacon each ARIS broadcasts on UDP port 56124
// (PROTOCOLS.md "ARIS live protocol"; message in proto/vog/sonar/aris_availability.proto). The
// mock sonar encodes it, a client decodes it to find a sonar (its serial number and model) and to
// see whether another client controls it (busy). Pure: the caller moves the datagrams.

#include "vog/core/result.hpp"
#include "vog/sonar/aris_command.hpp"

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace vog::sonar {

// UDP port the ARIS sends its Availability beacon to (Sound Metrics ARIS Integration SDK 2.x).
inline constexpr std::uint16_t kArisAvailabilityPort = 56124;

struct ArisAvailability {
  std::uint32_t serial_number = 0;
  ArisSystemType system_type = ArisSystemType::k1800;
  std::uint32_t version_major = 0;
  std::uint32_t version_minor = 0;
  std::uint32_t version_build = 0;
  bool busy = false;                      // connectionState BUSY: a client controls the sonar
  std::vector<std::string> capabilities;  // capabilities.enabled, in order
  bool operator==(const ArisAvailability&) const = default;
};

// The serialized aris.Availability (every field written, so decode(encode(a)) == a).
std::vector<std::uint8_t> encodeArisAvailability(const ArisAvailability& availability);

// Error, naming what is wrong, if the bytes are not an aris.Availability or carry a systemType or
// connectionState value the protocol does not define. Unknown fields (6-13: link preference,
// cpuTemp, ...) are ignored; absent fields read as their proto3 defaults.
Result<ArisAvailability> decodeArisAvailability(std::span<const std::uint8_t> datagram);

}  // namespace vog::sonar
