#pragma once
// Independent readers of what vogctl writes, for its tests: PNG (chunks checked with zlib's CRC-32,
// image data inflated by zlib), binary little-endian PLY, and flat JSON objects (JSON Lines).
// Written from the format specifications, sharing no code with the writers.

#include <zlib.h>

#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

namespace vog::client::test {

inline std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::uint32_t be32(const std::string& s, std::size_t at) {
  return (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at])) << 24) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 1])) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 2])) << 8) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 3]));
}

// A decoded 8-bit RGB PNG, or the reason it is not one.
struct DecodedPng {
  std::string error;  // empty: valid
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::vector<std::string> chunk_types;
  std::string scanlines;  // inflated IDAT: per row a filter byte and 3 * width bytes
  std::vector<std::uint8_t> rgb;

  std::uint8_t filterOf(std::uint32_t y) const {
    return static_cast<std::uint8_t>(scanlines[static_cast<std::size_t>(y) * (1 + 3 * width)]);
  }
  std::array<std::uint8_t, 3> at(std::uint32_t x, std::uint32_t y) const {
    const std::size_t i = 3 * (static_cast<std::size_t>(y) * width + x);
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

// PNG spec: 8-byte signature; chunks of length, type, data, CRC-32 over type and data; IHDR first
// (width, height, bit depth 8, colour type 2, compression 0, filter 0, interlace 0); IEND last.
// Only filter type 0 (None) is accepted: that is what the encoder promises.
inline DecodedPng decodePng(const std::string& png) {
  DecodedPng d;
  const auto fail = [&](std::string e) {
    d.error = std::move(e);
    return d;
  };
  if (png.size() < 8 || png.substr(0, 8) != std::string("\x89PNG\r\n\x1a\n", 8)) return fail("bad signature");
  std::size_t off = 8;
  std::string idat;
  while (off < png.size()) {
    if (off + 12 > png.size()) return fail("truncated chunk header");
    const std::uint32_t len = be32(png, off);
    if (off + 12 + len > png.size()) return fail("chunk runs past the end");
    const std::string type = png.substr(off + 4, 4);
    const uLong crc = ::crc32(0L, reinterpret_cast<const Bytef*>(png.data() + off + 4), len + 4);
    if (crc != be32(png, off + 8 + len)) return fail("bad CRC in " + type);
    d.chunk_types.push_back(type);
    if (type == "IHDR") {
      if (len != 13) return fail("IHDR length");
      d.width = be32(png, off + 8);
      d.height = be32(png, off + 12);
      const std::string rest = png.substr(off + 16, 5);
      if (rest != std::string("\x08\x02\x00\x00\x00", 5)) return fail("IHDR is not 8-bit RGB, deflate, no interlace");
    }
    if (type == "IDAT") idat += png.substr(off + 8, len);
    off += 12 + len;
  }
  if (d.chunk_types.empty() || d.chunk_types.front() != "IHDR" || d.chunk_types.back() != "IEND") {
    return fail("chunks are not IHDR ... IEND");
  }
  const std::size_t row = 1 + 3 * static_cast<std::size_t>(d.width);
  d.scanlines.assign(row * d.height, '\0');
  uLongf n = d.scanlines.size();
  if (uncompress(reinterpret_cast<Bytef*>(d.scanlines.data()), &n, reinterpret_cast<const Bytef*>(idat.data()),
                 idat.size()) != Z_OK) {
    return fail("IDAT does not inflate to the scanlines' size");
  }
  if (n != d.scanlines.size()) return fail("IDAT inflates to " + std::to_string(n) + " bytes");
  for (std::uint32_t y = 0; y < d.height; ++y) {
    if (d.filterOf(y) != 0) return fail("row " + std::to_string(y) + " uses a filter other than None");
    const auto* p = reinterpret_cast<const std::uint8_t*>(d.scanlines.data()) + y * row + 1;
    d.rgb.insert(d.rgb.end(), p, p + row - 1);
  }
  return d;
}

// A binary little-endian PLY with one vertex element of float properties.
struct DecodedPly {
  std::string error;
  std::vector<std::string> properties;
  std::vector<std::vector<float>> vertices;
};

inline DecodedPly decodePly(const std::string& bytes) {
  DecodedPly d;
  const std::size_t end = bytes.find("end_header\n");
  if (bytes.rfind("ply\n", 0) != 0 || end == std::string::npos) {
    d.error = "not a PLY header";
    return d;
  }
  std::istringstream header(bytes.substr(0, end));
  std::string line;
  std::size_t n = 0;
  bool binary_le = false;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string w0, w1, w2;
    words >> w0 >> w1 >> w2;
    if (w0 == "format") binary_le = w1 == "binary_little_endian" && w2 == "1.0";
    if (w0 == "element") {
      if (w1 != "vertex") d.error = "unexpected element " + w1;
      n = std::stoul(w2);
    }
    if (w0 == "property") {
      if (w1 != "float") d.error = "property " + w2 + " is " + w1 + ", not float";
      d.properties.push_back(w2);
    }
  }
  if (!binary_le) d.error = "not binary_little_endian 1.0";
  if (!d.error.empty()) return d;
  const std::size_t data = end + std::strlen("end_header\n");
  const std::size_t stride = 4 * d.properties.size();
  if (bytes.size() != data + n * stride) {
    d.error =
        "body is " + std::to_string(bytes.size() - data) + " bytes, header promises " + std::to_string(n * stride);
    return d;
  }
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<float> v;
    for (std::size_t k = 0; k < d.properties.size(); ++k) {
      const std::size_t at = data + i * stride + 4 * k;
      std::uint32_t u = 0;
      for (int b = 3; b >= 0; --b) u = (u << 8) | static_cast<unsigned char>(bytes[at + static_cast<std::size_t>(b)]);
      float f = 0.0f;
      std::memcpy(&f, &u, 4);
      v.push_back(f);
    }
    d.vertices.push_back(std::move(v));
  }
  return d;
}

// One flat JSON object (RFC 8259 values: strings with escapes, numbers, true, false, null).
using JsonValue = std::variant<std::nullptr_t, bool, double, std::string>;
using JsonObject = std::map<std::string, JsonValue>;

inline std::optional<JsonObject> parseJsonObject(const std::string& text) {
  std::size_t i = 0;
  const auto ws = [&] {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  };
  const auto str = [&]() -> std::optional<std::string> {
    if (i >= text.size() || text[i] != '"') return std::nullopt;
    ++i;
    std::string s;
    while (i < text.size() && text[i] != '"') {
      char c = text[i++];
      if (static_cast<unsigned char>(c) < 0x20) return std::nullopt;  // raw control characters are invalid
      if (c == '\\') {
        if (i >= text.size()) return std::nullopt;
        const char e = text[i++];
        switch (e) {
          case '"':
          case '\\':
          case '/': c = e; break;
          case 'n': c = '\n'; break;
          case 't': c = '\t'; break;
          case 'r': c = '\r'; break;
          case 'b': c = '\b'; break;
          case 'f': c = '\f'; break;
          case 'u': {
            if (i + 4 > text.size()) return std::nullopt;
            const unsigned long code = std::stoul(text.substr(i, 4), nullptr, 16);
            if (code > 0x7F) return std::nullopt;  // enough for these tests: ASCII escapes only
            c = static_cast<char>(code);
            i += 4;
            break;
          }
          default: return std::nullopt;
        }
      }
      s += c;
    }
    if (i >= text.size()) return std::nullopt;
    ++i;
    return s;
  };
  JsonObject out;
  ws();
  if (i >= text.size() || text[i++] != '{') return std::nullopt;
  ws();
  if (i < text.size() && text[i] == '}') return out;
  for (;;) {
    ws();
    auto key = str();
    if (!key) return std::nullopt;
    ws();
    if (i >= text.size() || text[i++] != ':') return std::nullopt;
    ws();
    if (i >= text.size()) return std::nullopt;
    if (text[i] == '"') {
      auto s = str();
      if (!s) return std::nullopt;
      out[*key] = *s;
    } else if (text.compare(i, 4, "true") == 0) {
      out[*key] = true;
      i += 4;
    } else if (text.compare(i, 5, "false") == 0) {
      out[*key] = false;
      i += 5;
    } else if (text.compare(i, 4, "null") == 0) {
      out[*key] = nullptr;
      i += 4;
    } else {
      std::size_t used = 0;
      double v = 0.0;
      try {
        v = std::stod(text.substr(i), &used);
      } catch (...) {
        return std::nullopt;
      }
      if (used == 0 || !std::isfinite(v)) return std::nullopt;
      out[*key] = v;
      i += used;
    }
    ws();
    if (i < text.size() && text[i] == ',') {
      ++i;
      continue;
    }
    if (i < text.size() && text[i] == '}') {
      ++i;
      ws();
      return i == text.size() ? std::optional<JsonObject>(out) : std::nullopt;
    }
    return std::nullopt;
  }
}

// Every line of `text` as a JSON object; nullopt when any line is not one.
inline std::optional<std::vector<JsonObject>> parseJsonLines(const std::string& text) {
  std::vector<JsonObject> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    auto o = parseJsonObject(line);
    if (!o) return std::nullopt;
    out.push_back(std::move(*o));
  }
  return out;
}

}  // namespace vog::client::test
