#pragma once
// PNG encoding of 8-bit RGB rasters (PNG specification, RFC 2083 / ISO 15948): one IHDR (8 bit,
// colour type 2, no interlace), one IDAT holding a zlib stream (RFC 1950) of the scanlines, each
// led by filter type 0 (None), and IEND. Used for top views (vogsim's scene preview, vogctl's map).

#include "vog/core/result.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace vog::codec {

// An 8-bit RGB raster, row-major from the top-left corner.
// Invariant after construction: rgb.size() == 3 * width * height with width, height >= 1 (the
// fields are public for drawing code; toPng re-checks the invariant and names a violation).
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // 3 * width * height

  // A w x h image (each side at least 1) filled with one colour.
  RgbImage(int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b);
  // Pixels outside the image are ignored (drawing may run over the edge).
  void set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b);
  // The pixel at (x, y), which must lie inside the image.
  std::array<std::uint8_t, 3> at(int x, int y) const;
};

// The PNG file's bytes. Errors: a buffer that does not hold 3 * width * height bytes, a side
// beyond the PNG limit of 2^31 - 1, or a zlib failure (out of memory).
Result<std::string> toPng(const RgbImage& image);
// Encodes and writes `file` (through a temporary file renamed into place, so an existing file is
// never left half-written).
Status writePng(const std::filesystem::path& file, const RgbImage& image);

}  // namespace vog::codec
