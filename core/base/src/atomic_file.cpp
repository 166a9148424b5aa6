#include "vog/core/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <string>

namespace vog {
namespace {

std::filesystem::path temporaryName(const std::filesystem::path& file) {
  return file.string() + ".tmp." + std::to_string(::getpid());
}

// Renames the complete, synced temporary file over `file` and syncs the directory; removes the
// temporary file when `written` failed or the rename does.
Status commit(const std::filesystem::path& tmp, const std::filesystem::path& file, Status written) {
  if (written.ok() && std::rename(tmp.c_str(), file.c_str()) != 0)
    written = Error{"cannot rename " + tmp.string() + " to " + file.string() + ": " + errnoText()};
  if (!written.ok()) {
    ::unlink(tmp.c_str());
    return written;
  }
  const std::filesystem::path dir = file.parent_path();
  return syncDirectory(dir.empty() ? std::filesystem::path(".") : dir);
}

}  // namespace

Status writeFileAtomically(const std::filesystem::path& file, std::string_view bytes) {
  const std::filesystem::path tmp = temporaryName(file);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Error{"cannot write " + tmp.string() + ": " + errnoText()};
  std::string failed;
  for (std::size_t done = 0; done < bytes.size() && failed.empty();) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      failed = "error while writing " + tmp.string() + ": " + errnoText();
    else
      done += static_cast<std::size_t>(n);
  }
  if (failed.empty() && ::fsync(fd) != 0) failed = "cannot fsync " + tmp.string() + ": " + errnoText();
  if (::close(fd) != 0 && failed.empty()) failed = "error while closing " + tmp.string() + ": " + errnoText();
  return commit(tmp, file, failed.empty() ? Status::success() : Status(Error{failed}));
}

Status syncDirectory(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return Error{"cannot open directory " + dir.string() + ": " + errnoText()};
  const int rc = ::fsync(fd);
  const std::string err = rc != 0 ? errnoText() : std::string();
  ::close(fd);
  if (rc != 0) return Error{"cannot fsync directory " + dir.string() + ": " + err};
  return Status::success();
}

}  // namespace vog
