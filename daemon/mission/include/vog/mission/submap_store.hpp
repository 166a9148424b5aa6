#pragma once
// SubmapStore: the closed submaps of a mission as OctoMap files, `submaps/NNNNNN.ot` (index, six
// digits, zero-padded) under the mission directory. A file is written atomically (writeFileAtomically:
// a temporary file next to it, fsync'ed, renamed and the directory fsync'ed), so that a file under its
// final name is always complete; the journal record naming it (with its size and CRC-32C) is synced
// only after that.
//
// Lifecycle: open() creates submaps/ if needed; write() and read() may be called in any order.
// Stateless apart from the directory path, so safe to use from one thread at a time.
#include "vog/core/result.hpp"
#include "vog/map/grid_config.hpp"
#include "vog/map/local_grid.hpp"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace vog::mission {

struct StoredSubmapFile {
  std::string file_name;  // relative to the submaps directory
  std::uint64_t size_bytes = 0;
  std::uint32_t crc32c = 0;
};

class SubmapStore {
 public:
  static Result<SubmapStore> open(const std::filesystem::path& mission_dir);

  static std::string fileName(std::int64_t index);
  Result<StoredSubmapFile> write(std::int64_t index, const map::LocalGrid& grid) const;
  // Loads a stored grid after checking that the file exists and has the recorded size and CRC-32C.
  // `file_name` must be a plain file name (no directory part): it comes from a journal.
  Result<std::shared_ptr<const map::LocalGrid>> read(const map::GridConfig& grid_config,
                                                     const StoredSubmapFile& file) const;
  const std::filesystem::path& dir() const { return dir_; }

 private:
  explicit SubmapStore(std::filesystem::path dir) : dir_(std::move(dir)) {}
  std::filesystem::path dir_;  // <mission>/submaps
};

}  // namespace vog::mission
