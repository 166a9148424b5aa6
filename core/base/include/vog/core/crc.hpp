#pragma once
// The checksums of the device protocols and of our record files, each computed from one table.
// Check values are those of the CRC catalogue for "123456789" (reveng.sourceforge.io/crc-catalogue).

#include <cstdint>
#include <span>

namespace vog {

// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final xor); check("123456789") = 0x29B1.
std::uint16_t crc16CcittFalse(std::span<const std::uint8_t> data, std::uint16_t crc = 0xFFFF);
// CRC-32 as in zlib / Ethernet (reflected poly 0xEDB88320, init and final xor 0xFFFFFFFF);
// check("123456789") = 0xCBF43926.
std::uint32_t crc32Ieee(std::span<const std::uint8_t> data);
// NovAtel's 32-bit block CRC (same reflected polynomial, init 0, no final xor), OEM7 manual
// "32-Bit CRC".
std::uint32_t crc32Novatel(std::span<const std::uint8_t> data);

// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78, initial value and final xor 0xFFFFFFFF), the
// checksum of iSCSI (RFC 3720 B.4) and ext4 metadata. Check value: crc32c("123456789") = 0xE3069283.
std::uint32_t crc32c(std::span<const std::uint8_t> bytes);
// Continues a running CRC: crc32c(a ++ b) == crc32cExtend(crc32c(a), b).
std::uint32_t crc32cExtend(std::uint32_t crc, std::span<const std::uint8_t> bytes);

}  // namespace vog
