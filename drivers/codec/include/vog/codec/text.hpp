#pragma once
// Helpers for the ASCII protocols (PD6, Digiquartz, backseat): strict number parsing and field
// splitting without locale dependence or exceptions.

#include <charconv>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace vog::codec {

// The whole string must be a number (an optional leading '+' is accepted); no spaces.
inline std::optional<double> parseDouble(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return std::nullopt;
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || !(v == v) || v > 1e300 || v < -1e300) return std::nullopt;
  return v;
}

inline std::optional<long long> parseInt(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return std::nullopt;
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

inline std::vector<std::string_view> splitFields(std::string_view s, char sep = ',') {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t pos = s.find(sep, start);
    if (pos == std::string_view::npos) {
      out.push_back(s.substr(start));
      return out;
    }
    out.push_back(s.substr(start, pos - start));
    start = pos + 1;
  }
}

// Index of the first `c` in bytes at or after `from`, or bytes.size().
inline std::size_t findByte(std::span<const std::uint8_t> bytes, std::uint8_t c, std::size_t from = 0) {
  for (std::size_t i = from; i < bytes.size(); ++i) {
    if (bytes[i] == c) return i;
  }
  return bytes.size();
}

inline std::string_view asText(std::span<const std::uint8_t> bytes) {
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

// Printable rendering of a short piece of a line, for error messages.
inline std::string quoted(std::string_view s, std::size_t max_chars = 40) {
  std::string out = "\"";
  for (std::size_t i = 0; i < s.size() && i < max_chars; ++i) {
    const char ch = s[i];
    out += (ch >= 32 && ch < 127) ? ch : '?';
  }
  if (s.size() > max_chars) out += "...";
  return out + "\"";
}

}  // namespace vog::codec
