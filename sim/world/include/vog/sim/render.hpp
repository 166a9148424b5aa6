#pragma once
// Ground-truth export: PLY point clouds and a top-view PNG of a scene.

#include "vog/codec/png.hpp"
#include "vog/geometry/point_cloud.hpp"
#include "vog/core/result.hpp"
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

// The RGB raster and PNG writer live in drivers/codec (vogctl renders map top views with them too).
using codec::RgbImage;
using codec::writePng;
// The PNG file's bytes (codec::toPng); empty when the image is malformed (its buffer does not
// hold 3 * width * height bytes), an error writePng names.
std::string encodePng(const RgbImage& image);

// Top view (looking down -z) of the surface points coloured by height (dark blue low, yellow high),
// the exploration box (grey) and the start pose (red, with a heading tick), `px_per_m` pixels per
// metre over the box plus a 1 m border.
RgbImage renderTopView(const World& world, const geometry::PointCloud& surface, double px_per_m);

}  // namespace vog::sim
