#include "vog/mission/submap_store.hpp"

#include "vog/core/atomic_file.hpp"
#include "vog/core/crc.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

namespace vog::mission {
namespace {

// Size and CRC-32C of a file, streamed.
Result<StoredSubmapFile> checksum(int fd, const std::filesystem::path& path) {
  StoredSubmapFile out;
  std::vector<std::uint8_t> buffer(1 << 16);
  std::uint64_t offset = 0;
  for (;;) {
    const ssize_t n = ::pread(fd, buffer.data(), buffer.size(), static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Error{"cannot read " + path.string() + ": " + errnoText()};
    if (n == 0) break;
    out.crc32c = crc32cExtend(out.crc32c, std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)));
    offset += static_cast<std::uint64_t>(n);
  }
  out.size_bytes = offset;
  return out;
}

}  // namespace

Result<SubmapStore> SubmapStore::open(const std::filesystem::path& mission_dir) {
  const std::filesystem::path dir = mission_dir / "submaps";
  std::error_code ec;
  const bool existed = std::filesystem::is_directory(dir, ec);
  if (!existed) {
    std::filesystem::create_directory(dir, ec);
    if (ec) return Error{"cannot create submap directory " + dir.string() + ": " + ec.message()};
    if (Status s = syncDirectory(mission_dir); !s.ok()) return s.error();
  }
  return SubmapStore(dir);
}

std::string SubmapStore::fileName(std::int64_t index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06lld.ot", static_cast<long long>(index));
  return name;
}

Result<StoredSubmapFile> SubmapStore::write(std::int64_t index, const map::LocalGrid& grid) const {
  if (index < 0) return Error{"submap store: negative submap index " + std::to_string(index)};
  auto bytes = grid.serialize();
  if (!bytes) return Error{"submap store: submap " + std::to_string(index) + ": " + bytes.error().message};
  // Size and CRC of what was meant to be written; the file is read back against them, so a write that
  // was lost or cut short on the way is an error here, never a journal record naming a bad file.
  StoredSubmapFile file{fileName(index), bytes->size(),
                        crc32c(std::span(reinterpret_cast<const std::uint8_t*>(bytes->data()), bytes->size()))};
  if (Status s = writeFileAtomically(dir_ / file.file_name, *bytes); !s.ok())
    return Error{"submap store: " + s.error().message};
  if (Status s = verify(dir_ / file.file_name, file); !s.ok()) return s.error();
  return file;
}

Status SubmapStore::verify(const std::filesystem::path& path, const StoredSubmapFile& file) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Error{"submap store: cannot open submap file " + path.string() + ": " + errnoText()};
  auto sum = checksum(fd, path);
  ::close(fd);
  if (!sum) return Error{"submap store: " + sum.error().message};
  if (sum->size_bytes != file.size_bytes || sum->crc32c != file.crc32c) {
    return Error{"submap store: submap file " + path.string() + " is corrupt: " + std::to_string(sum->size_bytes) +
                 " bytes with CRC-32C " + std::to_string(sum->crc32c) + ", expected " +
                 std::to_string(file.size_bytes) + " bytes with CRC-32C " + std::to_string(file.crc32c)};
  }
  return Status::success();
}

Result<std::shared_ptr<const map::LocalGrid>> SubmapStore::read(const map::GridConfig& grid_config,
                                                                const StoredSubmapFile& file,
                                                                std::vector<Eigen::Vector3d> sensor_origins) const {
  const std::filesystem::path name(file.file_name);
  if (file.file_name.empty() || name.has_parent_path() || name.filename() != name || file.file_name == "." ||
      file.file_name == "..") {
    return Error{"submap store: '" + file.file_name + "' is not a plain file name"};
  }
  const std::filesystem::path path = dir_ / name;
  if (Status s = verify(path, file); !s.ok()) return s.error();
  auto grid = map::LocalGrid::load(grid_config, path, std::move(sensor_origins));
  if (!grid) return Error{"submap store: " + grid.error().message};
  return std::shared_ptr<const map::LocalGrid>(std::move(grid.value()));
}

}  // namespace vog::mission
