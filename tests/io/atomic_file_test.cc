#include "shape_slam_io/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <stdexcept>
#include <string>

#include "io/test_files.h"

namespace shape_slam::io {
namespace {

using testing::ReadFile;
using testing::TempDir;

TEST(AtomicFileTest, ReplacesContentAndLeavesNoTemporaryFiles) {
  TempDir dir;
  const std::string path = dir.Write("out.txt", "old results");
  WriteFileAtomically(path, "new results");
  EXPECT_EQ(ReadFile(path), "new results");
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0644u);
}

TEST(AtomicFileTest, FailureKeepsTheOldFile) {
  TempDir dir;
  const std::string path = dir.Write("out.txt", "old results");
  // A directory where the file should go: the write must fail and change nothing.
  std::filesystem::create_directory(dir.Path("blocked"));
  EXPECT_THROW(WriteFileAtomically(dir.Path("blocked"), "x"), OutputError);
  // An unwritable directory: the temporary file cannot be created.
  EXPECT_THROW(WriteFileAtomically(dir.Path("no/such/dir/out.txt"), "x"), OutputError);
  EXPECT_EQ(ReadFile(path), "old results");
}

int CountFiles(const std::string& dir) {
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    (void)entry;
    ++files;
  }
  return files;
}

// Staged files replace their targets only at Commit; until then (and after a failure) the
// targets are as they were, and no temporary file outlives the StagedFiles.
TEST(AtomicFileTest, StagedFilesReplaceTheirTargetsTogether) {
  TempDir dir;
  const std::string a = dir.Write("a.txt", "old a");
  const std::string b = dir.Path("b.txt");
  {
    StagedFiles files;
    files.Stage(a, "new a");
    files.Stage(b, "new b");
    EXPECT_EQ(ReadFile(a), "old a");
    EXPECT_FALSE(std::filesystem::exists(b));
  }  // not committed: both temporaries removed
  EXPECT_EQ(ReadFile(a), "old a");
  EXPECT_FALSE(std::filesystem::exists(b));
  EXPECT_EQ(CountFiles(dir.path()), 1);
  {
    StagedFiles files;
    files.Stage(a, "new a");
    // The second output cannot be written: the first target must stay as it was.
    std::filesystem::create_directory(dir.Path("blocked"));
    EXPECT_THROW(files.Stage(dir.Path("blocked"), "x"), OutputError);
  }
  EXPECT_EQ(ReadFile(a), "old a");
  EXPECT_EQ(CountFiles(dir.path()), 2);  // a.txt and the directory
  StagedFiles files;
  files.Stage(a, "new a");
  files.Stage(b, "new b");
  files.Commit();
  EXPECT_EQ(ReadFile(a), "new a");
  EXPECT_EQ(ReadFile(b), "new b");
  EXPECT_EQ(CountFiles(dir.path()), 3);
  struct stat st {};
  ASSERT_EQ(::stat(b.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0644u);
}

// A file staged piece by piece holds every piece in order (pieces smaller and larger than the
// writer's buffer), can be read back before Commit, and a writer that throws leaves nothing.
TEST(AtomicFileTest, StagedStreamHoldsEveryPieceAndFailsCleanly) {
  TempDir dir;
  const std::string target = dir.Write("big.bin", "old");
  std::string expected;
  StagedFiles files;
  const std::string staged = files.Stage(target, [&](const ByteWriter& write) {
    for (int i = 0; i < 300; ++i) {
      const std::string piece(static_cast<std::size_t>(i * i % 70001), static_cast<char>('a' + i % 26));
      write(piece);
      expected += piece;
    }
  });
  EXPECT_GT(expected.size(), std::size_t{1} << 16);
  EXPECT_EQ(ReadFile(staged), expected);
  EXPECT_EQ(ReadFile(target), "old");
  const auto failing = [](const ByteWriter& write) {
    write(std::string(100000, 'x'));
    throw std::runtime_error("renderer failed");
  };
  EXPECT_THROW(files.Stage(dir.Path("other.bin"), failing), std::runtime_error);
  EXPECT_EQ(CountFiles(dir.path()), 2);  // big.bin and its staged file, nothing of other.bin
  files.Commit();
  EXPECT_EQ(ReadFile(target), expected);
  EXPECT_EQ(CountFiles(dir.path()), 1);
}

TEST(AtomicFileTest, EnsureDirectoryCreatesParentsAndRejectsFiles) {
  TempDir dir;
  EnsureDirectory(dir.Path("a/b/c"));
  EXPECT_TRUE(std::filesystem::is_directory(dir.Path("a/b/c")));
  EnsureDirectory(dir.Path("a/b/c"));  // idempotent
  const std::string file = dir.Write("file", "x");
  EXPECT_THROW(EnsureDirectory(file), OutputError);
}

}  // namespace
}  // namespace shape_slam::io
