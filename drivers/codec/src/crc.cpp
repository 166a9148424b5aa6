#include "vog/codec/bytes.hpp"

#include <array>

namespace vog::codec {
namespace {

constexpr std::array<std::uint32_t, 256> makeReflectedTable32() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? (0xEDB88320U ^ (c >> 1)) : (c >> 1);
    table[i] = c;
  }
  return table;
}
constexpr auto kTable32 = makeReflectedTable32();

std::uint32_t crc32Raw(Bytes data, std::uint32_t crc) {
  for (const std::uint8_t byte : data) crc = kTable32[(crc ^ byte) & 0xFFU] ^ (crc >> 8);
  return crc;
}

}  // namespace

std::uint16_t crc16CcittFalse(Bytes data, std::uint16_t crc) {
  for (const std::uint8_t byte : data) {
    crc = static_cast<std::uint16_t>(crc ^ (static_cast<std::uint16_t>(byte) << 8));
    for (int k = 0; k < 8; ++k) {
      crc = (crc & 0x8000U) ? static_cast<std::uint16_t>((crc << 1) ^ 0x1021U) : static_cast<std::uint16_t>(crc << 1);
    }
  }
  return crc;
}

std::uint32_t crc32Ieee(Bytes data) { return crc32Raw(data, 0xFFFFFFFFU) ^ 0xFFFFFFFFU; }

std::uint32_t crc32Novatel(Bytes data) { return crc32Raw(data, 0U); }

}  // namespace vog::codec
