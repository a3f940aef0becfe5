#include "fskin/util/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

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

// What a killed writer leaves: a temporary named for a process that is gone.
TEST(AtomicFile, StaleTemporariesOfDeadProcessesAreRemoved) {
  const auto dir = testing::temp_dir("atomic_stale");
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);  // its pid now names no process
  const auto stale = dir / ("checkpoint-00000010.fskin.tmp-" + std::to_string(child));
  const auto mine = dir / ("frame.npz.tmp-" + std::to_string(::getpid()));
  const auto other = dir / "notes.tmp-abc";
  for (const auto& p : {stale, mine, other}) write_file_atomically(p.string(), "partial");
  EXPECT_EQ(remove_stale_temporaries(dir.string()), 1);
  EXPECT_FALSE(std::filesystem::exists(stale));
  EXPECT_TRUE(std::filesystem::exists(mine));   // a live writer's
  EXPECT_TRUE(std::filesystem::exists(other));  // not a temporary of ours
  EXPECT_EQ(remove_stale_temporaries((dir / "missing").string()), 0);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace fskin
