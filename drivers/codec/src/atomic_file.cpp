#include "vog/codec/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <string>

namespace vog::codec {

Status writeFileAtomically(const std::filesystem::path& file, std::string_view bytes, bool sync) {
  const std::filesystem::path tmp = file.string() + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Error{"cannot write " + tmp.string() + ": " + errnoText()};
  std::string failed;
  for (std::size_t done = 0; done < bytes.size() && failed.empty();) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) failed = "error while writing " + tmp.string() + ": " + errnoText();
    else done += static_cast<std::size_t>(n);
  }
  if (failed.empty() && sync && ::fsync(fd) != 0) failed = "cannot fsync " + tmp.string() + ": " + errnoText();
  if (::close(fd) != 0 && failed.empty()) failed = "error while closing " + tmp.string() + ": " + errnoText();
  if (failed.empty() && std::rename(tmp.c_str(), file.c_str()) != 0)
    failed = "cannot rename " + tmp.string() + " to " + file.string() + ": " + errnoText();
  if (!failed.empty()) {
    ::unlink(tmp.c_str());
    return Error{failed};
  }
  return {};
}

}  // namespace vog::codec
