#include "vog/client/ply.hpp"

#include "vog/core/atomic_file.hpp"

#include <bit>
#include <cstdint>

namespace vog::client {

namespace {

// Little-endian whatever the host's byte order ("binary_little_endian 1.0").
void putF32Le(std::string& out, float v) {
  const auto u = std::bit_cast<std::uint32_t>(v);
  for (int shift = 0; shift < 32; shift += 8) out.push_back(static_cast<char>((u >> shift) & 0xFFu));
}

}  // namespace

bool hasNormals(const api::Cloud& cloud) {
  for (const auto& p : cloud) {
    if (!p.normal_world.isZero(0.0f)) return true;
  }
  return false;
}

std::string encodePly(const api::Cloud& cloud) {
  const bool normals = hasNormals(cloud);
  std::string out =
      "ply\nformat binary_little_endian 1.0\ncomment vog reconstruction, metres, world frame (z up)\nelement vertex " +
      std::to_string(cloud.size()) + "\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
  out += "end_header\n";
  out.reserve(out.size() + cloud.size() * (normals ? 24u : 12u));
  for (const auto& p : cloud) {
    for (int i = 0; i < 3; ++i) putF32Le(out, p.p_world_m[i]);
    if (normals) {
      for (int i = 0; i < 3; ++i) putF32Le(out, p.normal_world[i]);
    }
  }
  return out;
}

Status writePly(const std::filesystem::path& file, const api::Cloud& cloud) {
  const std::string bytes = encodePly(cloud);
  return writeFileAtomically(file, bytes);
}

}  // namespace vog::client
