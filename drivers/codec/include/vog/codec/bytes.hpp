#pragma once
// Little- and big-endian field access for wire formats, and the checksums the codecs share.
// Readers take a span and an offset that the caller has already bounds-checked.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string_view>
#include <vector>

namespace vog::codec {

using Bytes = std::span<const std::uint8_t>;

inline std::uint16_t readU16LE(Bytes b, std::size_t at) {
  return static_cast<std::uint16_t>(b[at] | (b[at + 1] << 8));
}
inline std::int16_t readI16LE(Bytes b, std::size_t at) { return static_cast<std::int16_t>(readU16LE(b, at)); }
inline std::uint32_t readU32LE(Bytes b, std::size_t at) {
  return static_cast<std::uint32_t>(b[at]) | (static_cast<std::uint32_t>(b[at + 1]) << 8) |
         (static_cast<std::uint32_t>(b[at + 2]) << 16) | (static_cast<std::uint32_t>(b[at + 3]) << 24);
}
inline std::int32_t readI32LE(Bytes b, std::size_t at) { return static_cast<std::int32_t>(readU32LE(b, at)); }
inline std::uint64_t readU64LE(Bytes b, std::size_t at) {
  return static_cast<std::uint64_t>(readU32LE(b, at)) | (static_cast<std::uint64_t>(readU32LE(b, at + 4)) << 32);
}
inline std::int64_t readI64LE(Bytes b, std::size_t at) { return static_cast<std::int64_t>(readU64LE(b, at)); }
inline float readF32LE(Bytes b, std::size_t at) { return std::bit_cast<float>(readU32LE(b, at)); }
inline double readF64LE(Bytes b, std::size_t at) { return std::bit_cast<double>(readU64LE(b, at)); }

// Appends little-endian fields to a byte vector.
class ByteWriter {
 public:
  explicit ByteWriter(std::vector<std::uint8_t>& out) : out_(out) {}
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u16(std::uint16_t v) {
    out_.push_back(static_cast<std::uint8_t>(v));
    out_.push_back(static_cast<std::uint8_t>(v >> 8));
  }
  void i16(std::int16_t v) { u16(static_cast<std::uint16_t>(v)); }
  void u32(std::uint32_t v) {
    u16(static_cast<std::uint16_t>(v));
    u16(static_cast<std::uint16_t>(v >> 16));
  }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void u64(std::uint64_t v) {
    u32(static_cast<std::uint32_t>(v));
    u32(static_cast<std::uint32_t>(v >> 32));
  }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  void zeros(std::size_t n) { out_.insert(out_.end(), n, 0); }
  void bytes(Bytes b) { out_.insert(out_.end(), b.begin(), b.end()); }
  std::size_t size() const { return out_.size(); }

 private:
  std::vector<std::uint8_t>& out_;
};

// Overwrites fields of an already sized buffer (headers with fixed offsets); `at` is in bounds.
inline void writeU16LE(std::span<std::uint8_t> b, std::size_t at, std::uint16_t v) {
  const std::uint8_t le[2] = {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8)};
  std::memcpy(b.subspan(at, 2).data(), le, 2);
}
inline void writeU32LE(std::span<std::uint8_t> b, std::size_t at, std::uint32_t v) {
  writeU16LE(b, at, static_cast<std::uint16_t>(v));
  writeU16LE(b, at + 2, static_cast<std::uint16_t>(v >> 16));
}
inline void writeU64LE(std::span<std::uint8_t> b, std::size_t at, std::uint64_t v) {
  writeU32LE(b, at, static_cast<std::uint32_t>(v));
  writeU32LE(b, at + 4, static_cast<std::uint32_t>(v >> 32));
}
inline void writeF32LE(std::span<std::uint8_t> b, std::size_t at, float v) {
  writeU32LE(b, at, std::bit_cast<std::uint32_t>(v));
}

inline Bytes asBytes(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final xor); check("123456789") = 0x29B1.
std::uint16_t crc16CcittFalse(Bytes data, std::uint16_t crc = 0xFFFF);
// CRC-32 as in zlib / Ethernet (reflected poly 0xEDB88320, init and final xor 0xFFFFFFFF);
// check("123456789") = 0xCBF43926.
std::uint32_t crc32Ieee(Bytes data);
// NovAtel's 32-bit block CRC (same reflected polynomial, init 0, no final xor), OEM7 manual
// "32-Bit CRC".
std::uint32_t crc32Novatel(Bytes data);

}  // namespace vog::codec
