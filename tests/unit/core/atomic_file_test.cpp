// Atomic file writing: the file appears complete under its name, replaces an older one, leaves no
// temporary file behind, and a failed write leaves the old file and no temporary file.
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

TEST(AtomicFile, ContentWrittenByNameIsCommittedTheSameWay) {
  test::TempDir dir;
  const auto file = dir.path() / "b.bin";
  std::filesystem::path seen;
  Status st = writeFileAtomically(file, [&](const std::filesystem::path& tmp) -> Status {
    seen = tmp;
    std::ofstream(tmp, std::ios::binary) << "by name";
    return Status::success();
  });
  ASSERT_TRUE(st.ok()) << st.error().message;
  EXPECT_EQ(seen.parent_path(), dir.path());
  EXPECT_NE(seen, file);
  EXPECT_EQ(test::readFile(file), "by name");
  EXPECT_EQ(entries(dir.path()), 1);
}

TEST(AtomicFile, AFailedWriteKeepsTheOldFileAndRemovesTheTemporaryOne) {
  test::TempDir dir;
  const auto file = dir.path() / "c.txt";
  ASSERT_TRUE(writeFileAtomically(file, "old").ok());
  Status st = writeFileAtomically(file, [](const std::filesystem::path& tmp) -> Status {
    std::ofstream(tmp) << "half";
    return Error{"writer failed"};
  });
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().message, "writer failed");
  EXPECT_EQ(test::readFile(file), "old");
  EXPECT_EQ(entries(dir.path()), 1);
  Status missing = writeFileAtomically(dir.path() / "no" / "such" / "dir.txt", "x");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("cannot write"), std::string::npos) << missing.error().message;
}

}  // namespace
}  // namespace vog
