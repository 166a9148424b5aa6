#pragma once
// Writing a whole file so that readers see either the old file (or none) or the complete new one, and
// the new one survives a power loss once the call returns: the content goes to a temporary file next
// to it (`<name>.tmp.<pid>`), which is fsync'ed and renamed over the file; then the directory is
// fsync'ed so that the rename itself is durable. Errors name the file and the failed step; the
// temporary file is removed on failure. Used for every file written in one piece (PNG, PLY, the
// endpoints file, the mission's submap files, map exports). Libraries that write by file name (OctoMap)
// are given a memory stream instead: their writers do not report a failed write.

#include "vog/core/result.hpp"

#include <filesystem>
#include <string_view>

namespace vog {

Status writeFileAtomically(const std::filesystem::path& file, std::string_view bytes);

// fsync of a directory, so that a created or renamed entry in it is durable.
Status syncDirectory(const std::filesystem::path& dir);

}  // namespace vog
