#include "vog/client/top_view.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <unordered_map>
#include <vector>

namespace vog::client {

namespace {

// What is known of one voxel column (x, y key) or of one pixel.
struct ColumnInfo {
  int top_occupied_z = INT_MIN;  // z key of the highest occupied voxel; INT_MIN: none
  bool free = false;             // some voxel is known free
  bool known = false;

  void merge(const ColumnInfo& o) {
    top_occupied_z = std::max(top_occupied_z, o.top_occupied_z);
    free = free || o.free;
    known = known || o.known;
  }
};

std::uint64_t columnId(int kx, int ky) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(kx)) << 32) | static_cast<std::uint32_t>(ky);
}

// OctoMap keys are the global voxel keys + 2^15 (vog/map/voxel_key.hpp).
constexpr int kOctoKeyOffset = 32768;
constexpr unsigned kOctoDepth = 16;

}  // namespace

std::array<std::uint8_t, 3> heightColour(double t) {
  static constexpr double kStops[4][3] = {{68, 1, 84}, {49, 104, 142}, {53, 183, 121}, {253, 231, 37}};
  t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) * 3.0 : 0.0;
  const int i = std::min(2, static_cast<int>(t));
  const double f = t - i;
  std::array<std::uint8_t, 3> c{};
  for (std::size_t k = 0; k < 3; ++k) {
    const auto ii = static_cast<std::size_t>(i);
    c[k] = static_cast<std::uint8_t>(std::lround(kStops[ii][k] + f * (kStops[ii + 1][k] - kStops[ii][k])));
  }
  return c;
}

Status TopViewConfig::validate() const {
  if (!(px_per_m >= 0.0) || px_per_m > 1000.0) {
    return Error{"px_per_m: " + std::to_string(px_per_m) + " is outside [0, 1000] (0: one pixel per voxel)"};
  }
  if (max_side_px < 1) return Error{"max_side_px: " + std::to_string(max_side_px) + " must be at least 1"};
  return {};
}

Eigen::Vector2i TopView::pixelOf(double x_m, double y_m) const {
  return {static_cast<int>(std::floor((x_m - x_min_m) * px_per_m)),
          static_cast<int>(std::floor((y_max_m - y_m) * px_per_m))};
}

double TopView::rampOf(double z_m) const { return z_max_m > z_min_m ? (z_m - z_min_m) / (z_max_m - z_min_m) : 1.0; }

Result<TopView> renderTopView(const api::MapMirror& mirror, const TopViewConfig& config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  // The mirror has no voxel iteration of its own; its OctoMap export holds exactly its known voxels.
  auto tree = mirror.toOcTree();
  if (!tree) return tree.error();
  const double res = mirror.resolution();

  std::unordered_map<std::uint64_t, ColumnInfo> columns;
  int kx_min = INT_MAX, kx_max = INT_MIN, ky_min = INT_MAX, ky_max = INT_MIN;
  int kz_min = INT_MAX, kz_max = INT_MIN;
  for (auto it = (*tree)->begin_leafs(); it != (*tree)->end_leafs(); ++it) {
    // A leaf above the finest depth covers size^3 voxels (an aligned cube: its key with the low bits
    // cleared is the lowest corner).
    const int size = 1 << (kOctoDepth - it.getDepth());
    const octomap::OcTreeKey key = it.getKey();
    int base[3];
    for (unsigned a = 0; a < 3; ++a) base[a] = (static_cast<int>(key[a]) & ~(size - 1)) - kOctoKeyOffset;
    for (int dz = 0; dz < size; ++dz) {
      for (int dy = 0; dy < size; ++dy) {
        for (int dx = 0; dx < size; ++dx) {
          const map::VoxelKey k(base[0] + dx, base[1] + dy, base[2] + dz);
          const map::VoxelValue v = mirror.at(k);
          if (v.status == map::Occupancy::kUnknown) continue;
          ColumnInfo& c = columns[columnId(k.x(), k.y())];
          c.known = true;
          if (v.status == map::Occupancy::kOccupied) {
            c.top_occupied_z = std::max(c.top_occupied_z, k.z());
            kz_min = std::min(kz_min, k.z());
            kz_max = std::max(kz_max, k.z());
          } else {
            c.free = true;
          }
          kx_min = std::min(kx_min, k.x());
          kx_max = std::max(kx_max, k.x());
          ky_min = std::min(ky_min, k.y());
          ky_max = std::max(ky_max, k.y());
        }
      }
    }
  }
  if (columns.empty()) return Error{"the map has no known voxel"};

  TopView view;
  view.px_per_m = config.px_per_m > 0.0 ? config.px_per_m : 1.0 / res;
  view.x_min_m = kx_min * res;
  view.y_max_m = (ky_max + 1) * res;
  if (kz_max >= kz_min) {
    view.z_min_m = (kz_min + 0.5) * res;
    view.z_max_m = (kz_max + 0.5) * res;
  }
  // The map's extent in pixels; the small slack keeps an exact fit (one pixel per voxel) from
  // growing a pixel through rounding of res * (1 / res).
  const double w = std::ceil((kx_max + 1 - kx_min) * res * view.px_per_m - 1e-6);
  const double h = std::ceil((ky_max + 1 - ky_min) * res * view.px_per_m - 1e-6);
  if (w > config.max_side_px || h > config.max_side_px) {
    return Error{"the map is " + std::to_string(static_cast<long long>(w)) + " x " +
                 std::to_string(static_cast<long long>(h)) + " pixels at px_per_m " + std::to_string(view.px_per_m) +
                 ", more than " + std::to_string(config.max_side_px) + " per side; lower px_per_m"};
  }
  const int width = std::max(1, static_cast<int>(w));
  const int height = std::max(1, static_cast<int>(h));
  const auto n_px = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  std::vector<ColumnInfo> pixels(n_px);
  std::vector<bool> gathered(n_px, false);
  const auto index = [&](const Eigen::Vector2i& q) {
    return static_cast<std::size_t>(q.y()) * static_cast<std::size_t>(width) + static_cast<std::size_t>(q.x());
  };
  const auto inside = [&](const Eigen::Vector2i& q) {
    return q.x() >= 0 && q.y() >= 0 && q.x() < width && q.y() < height;
  };
  // Columns whose centre lies in a pixel.
  for (const auto& [id, c] : columns) {
    const int kx = static_cast<int>(static_cast<std::uint32_t>(id >> 32));
    const int ky = static_cast<int>(static_cast<std::uint32_t>(id & 0xFFFFFFFFu));
    const Eigen::Vector2i q = view.pixelOf((kx + 0.5) * res, (ky + 0.5) * res);
    if (!inside(q)) continue;
    pixels[index(q)].merge(c);
    gathered[index(q)] = true;
  }
  // Pixels holding no column centre show the column under their own centre.
  const double inv_res = 1.0 / res;
  for (int py = 0; py < height; ++py) {
    for (int px = 0; px < width; ++px) {
      const Eigen::Vector2i q(px, py);
      if (gathered[index(q)]) continue;
      const double x = view.x_min_m + (px + 0.5) / view.px_per_m;
      const double y = view.y_max_m - (py + 0.5) / view.px_per_m;
      const auto found = columns.find(columnId(map::coordToIndex(x, inv_res), map::coordToIndex(y, inv_res)));
      if (found != columns.end()) pixels[index(q)] = found->second;
    }
  }
  view.image = codec::RgbImage(width, height, kUnknownColour[0], kUnknownColour[1], kUnknownColour[2]);
  for (int py = 0; py < height; ++py) {
    for (int px = 0; px < width; ++px) {
      const ColumnInfo& c = pixels[index({px, py})];
      std::array<std::uint8_t, 3> colour = kUnknownColour;
      if (c.top_occupied_z != INT_MIN) {
        ++view.occupied_columns;
        colour = heightColour(view.rampOf((c.top_occupied_z + 0.5) * res));
      } else if (c.free) {
        colour = kFreeColour;
      }
      view.image.set(px, py, colour[0], colour[1], colour[2]);
    }
  }
  return view;
}

}  // namespace vog::client
