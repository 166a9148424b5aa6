#pragma once
// Shared helpers for the unit tests: data paths, temporary directories, file contents.

#include <filesystem>
#include <string>

namespace vog::test {

// ../shared/data of the source tree (public datasets read by tests).
std::filesystem::path sharedDataDir();
// The project source tree.
std::filesystem::path sourceDir();

// Every byte of a file (empty when it cannot be read).
std::string readFile(const std::filesystem::path& file);

// Whether text contains what (error messages that must name a value).
inline bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// A fresh directory under the system temp dir, removed with its content on destruction.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "vog-test");
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace vog::test
