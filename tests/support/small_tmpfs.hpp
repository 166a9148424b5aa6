#pragma once
// A small tmpfs mounted on a fresh temporary directory, for tests of what a full disk does (needs
// root; mounted() says whether it worked and error() why not). fill() takes every free byte with one
// file, release() deletes it.

#include "test_support.hpp"

#include <fcntl.h>
#include <sys/mount.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace vog::test {

class SmallTmpfs {
 public:
  explicit SmallTmpfs(std::size_t size_bytes) : dir_("vog-tmpfs") {
    const std::string options = "size=" + std::to_string(size_bytes);
    if (::mount("tmpfs", dir_.path().c_str(), "tmpfs", 0, options.c_str()) == 0) {
      mounted_ = true;
    } else {
      error_ =
          std::string("mount -t tmpfs -o ") + options + " on " + dir_.path().string() + ": " + std::strerror(errno);
    }
  }
  ~SmallTmpfs() {
    if (mounted_) ::umount2(dir_.path().c_str(), MNT_DETACH);
  }
  SmallTmpfs(const SmallTmpfs&) = delete;
  SmallTmpfs& operator=(const SmallTmpfs&) = delete;

  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }
  const std::filesystem::path& path() const { return dir_.path(); }

  // Writes a filler file until the file system reports no space; returns whether it did.
  bool fill() {
    const int fd = ::open(filler().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return false;
    const std::vector<char> block(4096, 'x');
    int err = 0;
    for (;;) {
      const ssize_t n = ::write(fd, block.data(), block.size());
      if (n > 0) continue;
      err = n < 0 ? errno : ENOSPC;
      if (err == EINTR) continue;
      break;
    }
    ::close(fd);
    return err == ENOSPC;
  }
  void release() { std::filesystem::remove(filler()); }

 private:
  std::filesystem::path filler() const { return dir_.path() / "filler"; }

  TempDir dir_;
  bool mounted_ = false;
  std::string error_;
};

}  // namespace vog::test
