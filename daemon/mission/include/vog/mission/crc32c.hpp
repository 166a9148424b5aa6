#pragma once
// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78, initial value and final xor 0xFFFFFFFF), the
// checksum of iSCSI (RFC 3720 B.4) and ext4 metadata. Check value: crc32c("123456789") = 0xE3069283.
#include <cstddef>
#include <cstdint>
#include <span>

namespace vog::mission {

std::uint32_t crc32c(std::span<const std::uint8_t> bytes);
// Continues a running CRC: crc32c(a ++ b) == crc32cExtend(crc32c(a), b).
std::uint32_t crc32cExtend(std::uint32_t crc, std::span<const std::uint8_t> bytes);

}  // namespace vog::mission
