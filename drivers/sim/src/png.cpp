// Minimal PNG writer (RFC 2083) with stored deflate blocks (RFC 1950 zlib wrapper, RFC 1951 sec. 3.2.4).

#include "vog/sim/render.hpp"

#include <algorithm>
#include <array>
#include <fstream>

namespace vog::sim {

namespace {

// CRC-32 (ISO 3309, polynomial 0xEDB88320), as the PNG spec's sample code defines it.
std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc = 0xFFFFFFFFu) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  for (std::size_t i = 0; i < n; ++i) crc = table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
  return crc;
}

std::uint32_t adler32(const std::uint8_t* data, std::size_t n) {
  std::uint32_t a = 1, b = 0;
  for (std::size_t i = 0; i < n; ++i) {
    a = (a + data[i]) % 65521u;
    b = (b + a) % 65521u;
  }
  return (b << 16) | a;
}

void putBe32(std::string& out, std::uint32_t v) {
  out.push_back(static_cast<char>((v >> 24) & 0xFFu));
  out.push_back(static_cast<char>((v >> 16) & 0xFFu));
  out.push_back(static_cast<char>((v >> 8) & 0xFFu));
  out.push_back(static_cast<char>(v & 0xFFu));
}

void chunk(std::string& out, const char type[4], const std::string& data) {
  putBe32(out, static_cast<std::uint32_t>(data.size()));
  std::string body(type, 4);
  body += data;
  out += body;
  putBe32(out, crc32(reinterpret_cast<const std::uint8_t*>(body.data()), body.size()) ^ 0xFFFFFFFFu);
}

}  // namespace

RgbImage::RgbImage(int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b)
    : width(std::max(w, 1)), height(std::max(h, 1)), rgb(3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
  for (std::size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = r;
    rgb[i + 1] = g;
    rgb[i + 2] = b;
  }
}

void RgbImage::set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  const std::size_t i = 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
  rgb[i] = r;
  rgb[i + 1] = g;
  rgb[i + 2] = b;
}

std::string encodePng(const RgbImage& image) {
  // Raw scanlines, each led by filter type 0 (None).
  const std::size_t row = 3 * static_cast<std::size_t>(image.width);
  std::string raw;
  raw.reserve((row + 1) * static_cast<std::size_t>(image.height));
  for (int y = 0; y < image.height; ++y) {
    raw.push_back('\0');
    raw.append(reinterpret_cast<const char*>(image.rgb.data()) + static_cast<std::size_t>(y) * row, row);
  }
  // zlib stream: CMF/FLG (deflate, 32K window, no dictionary; 0x7801 is divisible by 31), stored
  // blocks of at most 65535 bytes, Adler-32 of the raw data.
  std::string z = {'\x78', '\x01'};
  std::size_t off = 0;
  do {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - off);
    const bool last = off + n == raw.size();
    z.push_back(last ? '\x01' : '\x00');
    z.push_back(static_cast<char>(n & 0xFFu));
    z.push_back(static_cast<char>((n >> 8) & 0xFFu));
    z.push_back(static_cast<char>(~n & 0xFFu));
    z.push_back(static_cast<char>((~n >> 8) & 0xFFu));
    z.append(raw, off, n);
    off += n;
  } while (off < raw.size());
  putBe32(z, adler32(reinterpret_cast<const std::uint8_t*>(raw.data()), raw.size()));

  std::string png = "\x89PNG\r\n\x1a\n";
  std::string ihdr;
  putBe32(ihdr, static_cast<std::uint32_t>(image.width));
  putBe32(ihdr, static_cast<std::uint32_t>(image.height));
  ihdr += std::string{'\x08', '\x02', '\x00', '\x00', '\x00'};  // 8 bit, RGB, deflate, filter 0, no interlace
  chunk(png, "IHDR", ihdr);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", "");
  return png;
}

Status writePng(const std::filesystem::path& file, const RgbImage& image) {
  const std::string bytes = encodePng(image);
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) return Error{"cannot write " + file.string()};
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) return Error{"error while writing " + file.string()};
  return {};
}

}  // namespace vog::sim
