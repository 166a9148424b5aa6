// Atomic file writing: the file appears complete under its name, replaces an older one, leaves no
// temporary file behind, and a failed write leaves the old file and no temporary file.
#include "small_tmpfs.hpp"
#include "test_support.hpp"
#include "vog/core/atomic_file.hpp"

#include <gtest/gtest.h>

#include <fstream>

namespace vog {
namespace {

int entries(const std::filesystem::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++n;
  return n;
}

TEST(AtomicFile, WritesAndReplacesLeavingNoTemporaryFile) {
  test::TempDir dir;
  const auto file = dir.path() / "a.txt";
  ASSERT_TRUE(writeFileAtomically(file, "first").ok());
  EXPECT_EQ(test::readFile(file), "first");
  ASSERT_TRUE(writeFileAtomically(file, "second").ok());
  EXPECT_EQ(test::readFile(file), "second");
  EXPECT_EQ(entries(dir.path()), 1);
}

TEST(AtomicFile, AFullDiskKeepsTheOldFileAndRemovesTheTemporaryOne) {
  test::SmallTmpfs disk(256 * 1024);
  if (!disk.mounted()) GTEST_SKIP() << disk.error();
  const auto file = disk.path() / "c.txt";
  ASSERT_TRUE(writeFileAtomically(file, "old").ok());
  ASSERT_TRUE(disk.fill());
  Status st = writeFileAtomically(file, std::string(64 * 1024, 'n'));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("No space left"), std::string::npos) << st.error().message;
  EXPECT_EQ(test::readFile(file), "old");
  EXPECT_EQ(entries(disk.path()), 2);  // the file and the filler, no temporary file
  Status missing = writeFileAtomically(disk.path() / "no" / "such" / "dir.txt", "x");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("cannot write"), std::string::npos) << missing.error().message;
}

}  // namespace
}  // namespace vog
