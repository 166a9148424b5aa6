#include "vog/map/octree_file.hpp"

#include "vog/core/atomic_file.hpp"

#include <octomap/OcTree.h>

#include <sstream>
#include <string>

namespace vog::map {

Status writeOcTreeFile(octomap::OcTree& tree, const std::filesystem::path& file, OcTreeFormat format) {
  std::ostringstream out(std::ios_base::out | std::ios_base::binary);
  const bool serialised = format == OcTreeFormat::kFull ? tree.write(out) : tree.writeBinary(out);
  if (!serialised || !out.good()) return Error{"cannot serialise the OcTree for " + file.string()};
  return writeFileAtomically(file, out.view());
}

Result<std::unique_ptr<octomap::OcTree>> readOcTree(std::istream& in) {
  std::string line;
  if (!std::getline(in, line) || line.rfind("# Octomap OcTree file", 0) != 0)
    return Error{"not an OctoMap .ot stream (its first line is not \"# Octomap OcTree file\")"};
  std::string id;
  double resolution = 0.0;
  std::size_t size = 0;
  bool has_size = false;
  while (std::getline(in, line) && line != "data") {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string key;
    fields >> key;
    if (key == "id") {
      fields >> id;
    } else if (key == "res") {
      fields >> resolution;
    } else if (key == "size") {
      has_size = static_cast<bool>(fields >> size);
    }
    if (fields.fail()) return Error{".ot header: cannot read the line \"" + line + "\""};
  }
  if (line != "data") return Error{".ot header: no \"data\" line"};
  if (id != "OcTree") return Error{".ot header: the tree is of type \"" + id + "\", not OcTree"};
  if (!(resolution > 0.0)) return Error{".ot header: no positive resolution"};
  auto tree = std::make_unique<octomap::OcTree>(resolution);
  if (has_size && size == 0) return tree;  // OctoMap writes no data for an empty tree
  if (!tree->readData(in) || tree->size() != size)
    return Error{".ot data: truncated or corrupt (" + std::to_string(tree->size()) + " of " + std::to_string(size) +
                 " nodes read)"};
  return tree;
}

}  // namespace vog::map
