#pragma once
// Writing an OcTree to a file so that a failed write is an error: OctoMap's writers by file name
// report success when the file's writes failed (a full disk), so the tree is written to memory (whose
// stream state is checked) and the bytes through writeFileAtomically (each write, fsync, rename).

#include "vog/core/result.hpp"

#include <filesystem>
#include <istream>
#include <memory>

namespace octomap {
class OcTree;
}

namespace vog::map {

enum class OcTreeFormat {
  kFull,    // .ot: values and the tree's parameters (AbstractOcTree::read)
  kBinary,  // .bt: occupied/free only (OcTree::readBinary), for octovis and most tools
};

// kBinary turns `tree` into its maximum-likelihood form and prunes it first (OcTree::writeBinary).
Status writeOcTreeFile(octomap::OcTree& tree, const std::filesystem::path& file, OcTreeFormat format);

// Reads an .ot stream of an OcTree (header, then the tree's data), with an error that names what was
// wrong (OctoMap's own reader prints its progress to stderr and returns null on any failure).
Result<std::unique_ptr<octomap::OcTree>> readOcTree(std::istream& in);

}  // namespace vog::map
