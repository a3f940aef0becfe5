#include "fskin/util/atomic_file.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "test_util.h"

namespace fskin {
namespace {

TEST(AtomicFile, WritesCreatesDirectoriesAndReplaces) {
  const auto dir = testing::temp_dir("atomic");
  const auto path = (dir / "a" / "b" / "file.bin").string();
  write_file_atomically(path, std::string("first"));
  write_file_atomically(path, std::string("second\0x", 8));
  EXPECT_EQ(read_file(path), std::string("second\0x", 8));
  size_t files = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1u);  // no temporary left behind
}

TEST(AtomicFile, FailedWriteLeavesOldContent) {
  const auto dir = testing::temp_dir("atomic_fail");
  const auto path = (dir / "keep.txt").string();
  write_file_atomically(path, std::string("old"));
  EXPECT_THROW(write_file_atomically(path, [](std::ostream&) { throw std::runtime_error("killed"); }),
               std::runtime_error);
  EXPECT_EQ(read_file(path), "old");
  size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1u);  // the partial temporary was removed
}

TEST(AtomicFile, UnwritableTargetThrowsAndKeepsNothing) {
  const auto dir = testing::temp_dir("atomic_unwritable");
  write_file_atomically((dir / "file").string(), std::string("x"));
  // A regular file cannot be a parent directory.
  EXPECT_THROW(write_file_atomically((dir / "file" / "child").string(), std::string("y")),
               std::exception);
  EXPECT_EQ(testing::directory_listing(dir), std::vector<std::string>{"file"});
}

TEST(AtomicFile, ReadMissingFileNamesIt) {
  testing::expect_error([] { read_file("/nonexistent/x.bin"); }, {"/nonexistent/x.bin", "no such file"});
}

}  // namespace
}  // namespace fskin
