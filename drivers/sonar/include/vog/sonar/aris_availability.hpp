#pragma once
// ARIS live protocol, discovery (PROTOCOLS.md "ARIS live protocol"; the message in
// proto/vog/sonar/aris_availability.proto): every ARIS broadcasts an aris.Availability beacon on UDP
// port 56124 saying who it is (serial number, model, software version) and whether a client
// controls it. Pure: the caller moves the datagrams.

#include "vog/core/result.hpp"
#include "vog/sonar/aris_command.hpp"

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace vog::sonar {

struct ArisAvailability {
  std::uint32_t serial_number = 0;
  ArisSystemType system_type = ArisSystemType::k1800;
  std::uint32_t version_major = 0;
  std::uint32_t version_minor = 0;
  std::uint32_t version_build = 0;
  bool busy = false;  // connectionState BUSY: a client controls the sonar
  std::vector<std::string> capabilities;
  bool operator==(const ArisAvailability&) const = default;
};

// The serialized aris.Availability (every field written).
std::vector<std::uint8_t> encodeArisAvailability(const ArisAvailability& availability);
// Error naming what is wrong: bytes that are not an Availability, a systemType or connectionState
// outside the protocol's values. Unknown fields (cpuTemp, ...) are ignored; absent fields read as
// the protocol's defaults (proto3).
Result<ArisAvailability> decodeArisAvailability(std::span<const std::uint8_t> datagram);

}  // namespace vog::sonar
