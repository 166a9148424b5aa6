#pragma once
// Little-endian field encoding for record payloads (layouts in daemon/mission/README.md). Doubles are
// stored as their IEEE-754 bit pattern, so every value round-trips bit for bit.
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"

#include <Eigen/Core>

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

namespace vog::mission::detail {

class ByteWriter {
 public:
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u16(std::uint16_t v) { put(v, 2); }
  void u32(std::uint32_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void i64(std::int64_t v) { put(static_cast<std::uint64_t>(v), 8); }
  void f64(double v) { put(std::bit_cast<std::uint64_t>(v), 8); }
  template <class Derived>
  void matrix(const Eigen::MatrixBase<Derived>& m) {  // column-major, as Eigen stores it
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      for (Eigen::Index r = 0; r < m.rows(); ++r) f64(m(r, c));
    }
  }
  // Rotation (column-major 3x3) then translation: 12 doubles.
  void pose(const geometry::Pose3& T) {
    matrix(T.linear());
    matrix(T.translation());
  }
  void bytes(std::span<const std::uint8_t> b) { out_.insert(out_.end(), b.begin(), b.end()); }
  void string16(const std::string& s) {
    u16(static_cast<std::uint16_t>(s.size()));
    out_.insert(out_.end(), s.begin(), s.end());
  }
  std::vector<std::uint8_t>& buffer() { return out_; }

 private:
  void put(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t> out_;
};

// Reads fields in order; the first read past the end sets an error naming the field and every later
// read returns zero, so a decoder checks `ok()` once at the end.
class ByteReader {
 public:
  explicit ByteReader(std::span<const std::uint8_t> in) : in_(in) {}

  std::uint8_t u8(const char* field) { return static_cast<std::uint8_t>(get(1, field)); }
  std::uint16_t u16(const char* field) { return static_cast<std::uint16_t>(get(2, field)); }
  std::uint32_t u32(const char* field) { return static_cast<std::uint32_t>(get(4, field)); }
  std::uint64_t u64(const char* field) { return get(8, field); }
  std::int64_t i64(const char* field) { return static_cast<std::int64_t>(get(8, field)); }
  double f64(const char* field) { return std::bit_cast<double>(get(8, field)); }
  template <class M>
  void matrix(M& m, const char* field) {
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      for (Eigen::Index r = 0; r < m.rows(); ++r) m(r, c) = f64(field);
    }
  }
  geometry::Pose3 pose(const char* field) {
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    matrix(R, field);
    matrix(t, field);
    geometry::Pose3 T = geometry::Pose3::Identity();
    T.linear() = R;
    T.translation() = t;
    return T;
  }
  std::span<const std::uint8_t> bytes(std::size_t n, const char* field) {
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

  std::span<const std::uint8_t> in_;
  std::size_t pos_ = 0;
  std::string error_;
};

}  // namespace vog::mission::detail
