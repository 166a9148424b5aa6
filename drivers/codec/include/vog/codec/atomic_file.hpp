#pragma once
// Writing a whole file so that readers see either the old file (or none) or the complete new one:
// the bytes go to a temporary file next to it, optionally fsync'ed, then renamed over it. Used for
// every product written in one piece (PNG, PLY, the endpoints file).

#include "vog/core/result.hpp"

#include <filesystem>
#include <string_view>

namespace vog::codec {

// `sync`: fsync the file before the rename (it survives a power loss once this returns). Errors
// name the file and the failed step; the temporary file is removed on failure.
Status writeFileAtomically(const std::filesystem::path& file, std::string_view bytes, bool sync = false);

}  // namespace vog::codec
