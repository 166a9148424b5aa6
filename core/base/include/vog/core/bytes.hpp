#pragma once
// Little-endian field access for wire formats and record files. The read/write functions take
// a span and an offset that the caller has already bounds-checked; ByteReader checks bounds itself and
// names the field that did not fit.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace vog {

using Bytes = std::span<const std::uint8_t>;

inline std::uint16_t readU16LE(Bytes b, std::size_t at) { return static_cast<std::uint16_t>(b[at] | (b[at + 1] << 8)); }
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

// Appends little-endian fields to a byte vector it borrows (the caller owns the vector).
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
  // A string of at most 65535 bytes, after its u16 length.
  void string16(const std::string& s) {
    u16(static_cast<std::uint16_t>(s.size()));
    out_.insert(out_.end(), s.begin(), s.end());
  }
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

inline Bytes asBytes(std::string_view s) { return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}; }

// Reads fields in order; the first read past the end sets an error naming the field and every later
// read returns zero, so a decoder checks `ok()` once at the end.
class ByteReader {
 public:
  explicit ByteReader(Bytes in) : in_(in) {}

  std::uint8_t u8(const char* field) { return static_cast<std::uint8_t>(get(1, field)); }
  std::uint16_t u16(const char* field) { return static_cast<std::uint16_t>(get(2, field)); }
  std::uint32_t u32(const char* field) { return static_cast<std::uint32_t>(get(4, field)); }
  std::uint64_t u64(const char* field) { return get(8, field); }
  std::int64_t i64(const char* field) { return static_cast<std::int64_t>(get(8, field)); }
  double f64(const char* field) { return std::bit_cast<double>(get(8, field)); }
  Bytes bytes(std::size_t n, const char* field) {
    if (!need(n, field)) return {};
    auto s = in_.subspan(pos_, n);
    pos_ += n;
    return s;
  }
  std::string string16(const char* field) {
    const std::size_t n = u16(field);
    auto s = bytes(n, field);
    return std::string(s.begin(), s.end());
  }

  std::size_t remaining() const { return in_.size() - pos_; }
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }

 private:
  bool need(std::size_t n, const char* field) {
    if (!error_.empty()) return false;
    if (in_.size() - pos_ < n) {
      error_ = std::string("payload ends inside field '") + field + "' (" + std::to_string(n) + " bytes needed, " +
               std::to_string(in_.size() - pos_) + " left)";
      return false;
    }
    return true;
  }
  std::uint64_t get(int n, const char* field) {
    if (!need(static_cast<std::size_t>(n), field)) return 0;
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(in_[pos_ + static_cast<std::size_t>(i)]) << (8 * i);
    pos_ += static_cast<std::size_t>(n);
    return v;
  }

  Bytes in_;
  std::size_t pos_ = 0;
  std::string error_;
};

}  // namespace vog
