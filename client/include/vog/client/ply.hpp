#pragma once
// The reconstruction cloud as a PLY file (Turk, "The PLY Polygon File Format"): binary little-endian,
// one vertex element of float x y z (metres, world frame), plus float nx ny nz when the cloud has
// normals.

#include "vog/api/domain.hpp"
#include "vog/core/result.hpp"

#include <filesystem>
#include <string>

namespace vog::client {

// A cloud carries normals when any point's normal is non-zero (the API sends none or all; a zero
// normal means "not computed", domain.hpp).
bool hasNormals(const api::Cloud& cloud);

// The PLY file's bytes.
std::string encodePly(const api::Cloud& cloud);
// Writes `file` through a temporary file renamed into place (never a half-written file).
Status writePly(const std::filesystem::path& file, const api::Cloud& cloud);

}  // namespace vog::client
