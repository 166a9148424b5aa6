#include "vog/core/crc.hpp"

#include <array>

namespace vog {
namespace {

// Byte-at-a-time table of a reflected polynomial.
constexpr std::array<std::uint32_t, 256> makeReflectedTable32(std::uint32_t poly) {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1U) != 0 ? (c >> 1) ^ poly : c >> 1;
    table[i] = c;
  }
  return table;
}
constexpr auto kTableIeee = makeReflectedTable32(0xEDB88320U);
constexpr auto kTableCastagnoli = makeReflectedTable32(0x82F63B78U);  // RFC 3720 B.4

std::uint32_t crc32Raw(const std::array<std::uint32_t, 256>& table, std::span<const std::uint8_t> data,
                       std::uint32_t crc) {
  for (const std::uint8_t byte : data) crc = table[(crc ^ byte) & 0xFFU] ^ (crc >> 8);
  return crc;
}

}  // namespace

std::uint16_t crc16CcittFalse(std::span<const std::uint8_t> data, std::uint16_t crc) {
  for (const std::uint8_t byte : data) {
    crc = static_cast<std::uint16_t>(crc ^ (static_cast<std::uint16_t>(byte) << 8));
    for (int k = 0; k < 8; ++k) {
      crc = (crc & 0x8000U) ? static_cast<std::uint16_t>((crc << 1) ^ 0x1021U) : static_cast<std::uint16_t>(crc << 1);
    }
  }
  return crc;
}

std::uint32_t crc32Ieee(std::span<const std::uint8_t> data) {
  return crc32Raw(kTableIeee, data, 0xFFFFFFFFU) ^ 0xFFFFFFFFU;
}

std::uint32_t crc32Novatel(std::span<const std::uint8_t> data) { return crc32Raw(kTableIeee, data, 0U); }

std::uint32_t crc32cExtend(std::uint32_t crc, std::span<const std::uint8_t> bytes) {
  return ~crc32Raw(kTableCastagnoli, bytes, ~crc);
}

std::uint32_t crc32c(std::span<const std::uint8_t> bytes) { return crc32cExtend(0, bytes); }

}  // namespace vog
