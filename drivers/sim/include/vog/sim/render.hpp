#pragma once
// Ground-truth export: PLY point clouds and a top-view PNG of a scene.

#include "vog/geometry/point_cloud.hpp"
#include "vog/geometry/result.hpp"
#include "vog/sim/world.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace vog::sim {

// ASCII PLY: "x y z" per vertex, plus "nx ny nz" when the cloud has normals.
Status writePly(const std::filesystem::path& file, const geometry::PointCloud& cloud);
// Reads what writePly writes (ASCII, float/double x y z [nx ny nz]); errors name file and line.
Result<geometry::PointCloud> readPly(const std::filesystem::path& file);

// An 8-bit RGB raster, row-major from the top-left corner.
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // 3 * width * height

  RgbImage(int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b);
  void set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b);
};

// PNG encoding of our own (PNG spec, RFC 2083): one IHDR, one IDAT holding a zlib stream of
// stored (uncompressed) deflate blocks (RFC 1950/1951), one IEND. No compression library needed;
// files are larger than compressed ones, which is acceptable for scene previews.
std::string encodePng(const RgbImage& image);
Status writePng(const std::filesystem::path& file, const RgbImage& image);

// Top view (looking down -z) of the surface points coloured by height (dark blue low, yellow high),
// the exploration box (grey) and the start pose (red, with a heading tick), `px_per_m` pixels per
// metre over the box plus a 1 m border.
RgbImage renderTopView(const World& world, const geometry::PointCloud& surface, double px_per_m);

}  // namespace vog::sim
