#pragma once
// SubmapStore: the closed submaps of a mission as OctoMap files, `submaps/NNNNNN.ot` (index, six
// digits, zero-padded) under the mission directory. A file is serialised in memory, written atomically
// (writeFileAtomically: a temporary file next to it, every write checked, fsync'ed, renamed and the
// directory fsync'ed) and read back against the size and CRC-32C of the bytes meant to be written, so
// that write() succeeds only for a complete file; the journal record naming it (with that size and
// CRC-32C) is synced only after that.
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
#include <vector>

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
  // `file_name` must be a plain file name (no directory part): it comes from a journal, as do the
  // grid's sensor origins (LocalGrid::fromTree), which the .ot file does not hold.
  Result<std::shared_ptr<const map::LocalGrid>> read(const map::GridConfig& grid_config, const StoredSubmapFile& file,
                                                     std::vector<Eigen::Vector3d> sensor_origins = {}) const;
  const std::filesystem::path& dir() const { return dir_; }

 private:
  // The file at `path` has the size and CRC-32C of `file` (an error naming what differs otherwise).
  static Status verify(const std::filesystem::path& path, const StoredSubmapFile& file);
  explicit SubmapStore(std::filesystem::path dir) : dir_(std::move(dir)) {}
  std::filesystem::path dir_;  // <mission>/submaps
};

}  // namespace vog::mission
