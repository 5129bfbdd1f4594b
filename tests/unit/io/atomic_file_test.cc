// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/atomic_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>

#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::io {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::TempDir;

int CountTempFiles(const std::filesystem::path& dir) {
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().filename().string().find(".tmp-") != std::string::npos)
      ++n;
  }
  return n;
}

TEST(AtomicFileTest, WritesAndReplacesContent) {
  TempDir dir;
  ASSERT_TRUE(WriteFileAtomically(dir / "f.txt", "old").ok());
  EXPECT_EQ(ReadFileOrDie(dir / "f.txt"), "old");
  ASSERT_TRUE(WriteFileAtomically(dir / "f.txt", "new content").ok());
  EXPECT_EQ(ReadFileOrDie(dir / "f.txt"), "new content");
  EXPECT_EQ(CountTempFiles(dir.path()), 0);
}

TEST(AtomicFileTest, UncommittedWriterLeavesOldContentAndNoTempFile) {
  TempDir dir;
  ASSERT_TRUE(WriteFileAtomically(dir / "f.txt", "old").ok());
  {
    absl::StatusOr<AtomicFileWriter> writer =
        AtomicFileWriter::Open(dir / "f.txt");
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE(writer->Append("half of the new").ok());
    EXPECT_EQ(ReadFileOrDie(dir / "f.txt"), "old");
  }  // destroyed without Commit
  EXPECT_EQ(ReadFileOrDie(dir / "f.txt"), "old");
  EXPECT_EQ(CountTempFiles(dir.path()), 0);
}

// A real crash: the child process dies (no destructors, no cleanup) after
// writing but before the rename.
TEST(AtomicFileTest, WriterKilledBeforeRenameLeavesOldContent) {
  TempDir dir;
  const std::filesystem::path target = dir / "frame.tiff";
  ASSERT_TRUE(WriteFileAtomically(target, "old frame").ok());
  pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    absl::StatusOr<AtomicFileWriter> writer = AtomicFileWriter::Open(target);
    if (!writer.ok() || !writer->Append(std::string(1 << 20, 'x')).ok()) {
      _exit(1);
    }
    _exit(0);  // crash: skip Commit and every destructor
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 0);

  EXPECT_EQ(ReadFileOrDie(target), "old frame");
  EXPECT_EQ(CountTempFiles(dir.path()), 1);  // the crashed writer's leftover
  absl::StatusOr<int> removed = RemoveStaleTempFiles(dir.path());
  ASSERT_TRUE(removed.ok());
  EXPECT_EQ(*removed, 1);
  EXPECT_EQ(CountTempFiles(dir.path()), 0);
  EXPECT_EQ(ReadFileOrDie(target), "old frame");
}

TEST(AtomicFileTest, CommitTwiceFails) {
  TempDir dir;
  absl::StatusOr<AtomicFileWriter> writer = AtomicFileWriter::Open(dir / "a");
  ASSERT_TRUE(writer.ok());
  ASSERT_TRUE(writer->Append("x").ok());
  ASSERT_TRUE(writer->Commit().ok());
  EXPECT_EQ(writer->Commit().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(writer->Append("y").code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(ReadFileOrDie(dir / "a"), "x");
}

TEST(AtomicFileTest, MissingFolderIsAClearError) {
  TempDir dir;
  absl::Status status = WriteFileAtomically(dir / "no/such/dir/f", "x");
  EXPECT_THAT(status, StatusIs(absl::StatusCode::kNotFound,
                               HasSubstr("No such file or directory")));
  EXPECT_NE(status.message().find("no/such/dir"), absl::string_view::npos)
      << status;
}

}  // namespace
}  // namespace hdrstereo::io
