#pragma once
// Top view of a merged-map copy (vogctl topview): looking down -z, north (+y) up, each pixel the
// column of voxels below it. A column with an occupied voxel takes the colour of its highest
// occupied voxel's centre height on a ramp over the map's occupied heights; a column known only
// as free is grey; a column with no known voxel is dark.

#include "vog/api/map_delta.hpp"
#include "vog/codec/png.hpp"
#include "vog/core/result.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>

namespace vog::client {

inline constexpr std::array<std::uint8_t, 3> kUnknownColour = {20, 20, 28};
inline constexpr std::array<std::uint8_t, 3> kFreeColour = {128, 128, 128};

// Height ramp, t in [0, 1] (clamped): dark blue -> teal -> green -> yellow, the viridis stops
// (van der Walt & Smith 2015), perceptually ordered; none of its colours is grey or dark.
std::array<std::uint8_t, 3> heightColour(double t);

struct TopViewConfig {
  double px_per_m = 0.0;    // 0: one pixel per voxel (1 / resolution)
  int max_side_px = 16384;  // larger images are refused (a typo in px_per_m, not a map)

  // Names the key and bad value.
  Status validate() const;
};

// The rendered image and where it lies in the world.
struct TopView {
  codec::RgbImage image{1, 1, 0, 0, 0};
  double px_per_m = 0.0;
  // World xy of the top-left corner of pixel (0, 0): x grows right, y grows up (row 0 is north).
  double x_min_m = 0.0;
  double y_max_m = 0.0;
  // Centre heights of the lowest and highest occupied voxels: the ends of the colour ramp.
  double z_min_m = 0.0;
  double z_max_m = 0.0;
  std::size_t occupied_columns = 0;

  // Pixel containing world point (x, y); may lie outside the image.
  Eigen::Vector2i pixelOf(double x_m, double y_m) const;
  // Ramp position of a height: (z - z_min) / (z_max - z_min), 1 when all occupied voxels share one height.
  double rampOf(double z_m) const;
};

// Renders every known voxel of `mirror` (enumerated through its OctoMap export, then classified by
// the mirror itself). A pixel gathers the columns whose centre lies in it (several per pixel when
// px_per_m < 1 / resolution) or else the column under its centre (one column over several pixels).
// Errors: an empty mirror, a bad config, an image over max_side_px.
Result<TopView> renderTopView(const api::MapMirror& mirror, const TopViewConfig& config);

}  // namespace vog::client
