#include "vog/map/octree_file.hpp"

#include "vog/core/atomic_file.hpp"

#include <octomap/OcTree.h>

#include <sstream>

namespace vog::map {

Status writeOcTreeFile(octomap::OcTree& tree, const std::filesystem::path& file, OcTreeFormat format) {
  std::ostringstream out(std::ios_base::out | std::ios_base::binary);
  const bool serialised = format == OcTreeFormat::kFull ? tree.write(out) : tree.writeBinary(out);
  if (!serialised || !out.good()) return Error{"cannot serialise the OcTree for " + file.string()};
  return writeFileAtomically(file, out.view());
}

}  // namespace vog::map
