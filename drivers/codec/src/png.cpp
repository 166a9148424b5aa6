// PNG writer (RFC 2083): chunk layout and CRC from the PNG specification sec. 5, the image data
// deflated by zlib (RFC 1950/1951).

#include "vog/codec/png.hpp"

#include "vog/core/atomic_file.hpp"
#include "vog/core/bytes.hpp"
#include "vog/core/crc.hpp"

#include <zlib.h>

#include <algorithm>
#include <cassert>
#include <limits>

namespace vog::codec {

namespace {

void putBe32(std::string& out, std::uint32_t v) {
  out.push_back(static_cast<char>((v >> 24) & 0xFFu));
  out.push_back(static_cast<char>((v >> 16) & 0xFFu));
  out.push_back(static_cast<char>((v >> 8) & 0xFFu));
  out.push_back(static_cast<char>(v & 0xFFu));
}

// Length, type, data, and the CRC-32 of type and data (PNG spec sec. 5.3).
void putChunk(std::string& out, const char (&type)[5], const std::string& data) {
  putBe32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t body_start = out.size();
  out.append(type, 4);
  out += data;
  const auto* body = reinterpret_cast<const std::uint8_t*>(out.data()) + body_start;
  putBe32(out, crc32Ieee(Bytes(body, out.size() - body_start)));
}

}  // namespace

RgbImage::RgbImage(int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b)
    : width(std::max(w, 1)),
      height(std::max(h, 1)),
      rgb(3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
  for (std::size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = r;
    rgb[i + 1] = g;
    rgb[i + 2] = b;
  }
}

void RgbImage::set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  const std::size_t i =
      3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
  rgb[i] = r;
  rgb[i + 1] = g;
  rgb[i + 2] = b;
}

std::array<std::uint8_t, 3> RgbImage::at(int x, int y) const {
  assert(x >= 0 && y >= 0 && x < width && y < height);
  const std::size_t i =
      3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
  return {rgb[i], rgb[i + 1], rgb[i + 2]};
}

Result<std::string> toPng(const RgbImage& image) {
  if (image.width < 1 || image.height < 1) {
    return Error{"png: image is " + std::to_string(image.width) + " x " + std::to_string(image.height) +
                 " pixels; each side must be at least 1"};
  }
  const std::size_t row = 3 * static_cast<std::size_t>(image.width);
  if (image.rgb.size() != row * static_cast<std::size_t>(image.height)) {
    return Error{"png: the pixel buffer holds " + std::to_string(image.rgb.size()) + " bytes, a " +
                 std::to_string(image.width) + " x " + std::to_string(image.height) + " RGB image needs " +
                 std::to_string(row * static_cast<std::size_t>(image.height))};
  }
  // Raw scanlines, each led by filter type 0 (None), PNG spec sec. 9.
  std::string raw;
  raw.reserve((row + 1) * static_cast<std::size_t>(image.height));
  for (int y = 0; y < image.height; ++y) {
    raw.push_back('\0');
    raw.append(reinterpret_cast<const char*>(image.rgb.data()) + static_cast<std::size_t>(y) * row, row);
  }
  static_assert(sizeof(uLong) >= sizeof(std::size_t), "zlib's lengths must hold any buffer size");
  uLongf z_len = compressBound(static_cast<uLong>(raw.size()));
  std::string z(z_len, '\0');
  // Level 6 (zlib's default): maps are large uniform areas, which deflate shrinks well and fast.
  const int rc = compress2(reinterpret_cast<Bytef*>(z.data()), &z_len, reinterpret_cast<const Bytef*>(raw.data()),
                           static_cast<uLong>(raw.size()), 6);
  if (rc != Z_OK) return Error{"png: zlib compress2 failed with code " + std::to_string(rc)};
  z.resize(z_len);
  // A chunk's length is a 31-bit number (PNG spec sec. 5.3).
  if (z.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    return Error{"png: the compressed image (" + std::to_string(z.size()) + " bytes) exceeds one chunk's 2^31 - 1"};
  }

  std::string png = "\x89PNG\r\n\x1a\n";
  std::string ihdr;
  putBe32(ihdr, static_cast<std::uint32_t>(image.width));
  putBe32(ihdr, static_cast<std::uint32_t>(image.height));
  ihdr += std::string{'\x08', '\x02', '\x00', '\x00', '\x00'};  // 8 bit, RGB, deflate, filter 0, no interlace
  putChunk(png, "IHDR", ihdr);
  putChunk(png, "IDAT", z);
  putChunk(png, "IEND", "");
  return png;
}

Status writePng(const std::filesystem::path& file, const RgbImage& image) {
  auto bytes = toPng(image);
  if (!bytes) return bytes.error();
  return writeFileAtomically(file, *bytes);
}

}  // namespace vog::codec
