// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/atomic_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>

#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"
#include "tests/support/tmpfs.h"

namespace hdrstereo::io {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::TempDir;
using ::hdrstereo::testing::TmpfsMount;

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

// A write that finds its filesystem full (a 64 kB tmpfs): a disk-full error
// naming the target and the space left, the old content kept, no temporary
// file, and the space the failed write had taken free again.
TEST(AtomicFileTest, AFullDiskIsDiskFullNamingThePathAndLeavesNoTempFile) {
  TempDir dir;
  TmpfsMount small(dir / "small", 64 << 10);
  if (!small.mounted()) GTEST_SKIP() << small.error();
  const std::filesystem::path target = dir / "small" / "frame.png";
  ASSERT_OK(WriteFileAtomically(target, "old frame"));
  const absl::Status full =
      WriteFileAtomically(target, std::string(1 << 20, 'x'));
  EXPECT_THAT(full, StatusIs(absl::StatusCode::kResourceExhausted,
                             HasSubstr("disk full (ENOSPC): cannot write " +
                                       target.string() +
                                       ": No space left on device; ")));
  EXPECT_THAT(std::string(full.message()),
              HasSubstr(" bytes free on its filesystem"));
  EXPECT_TRUE(IsDiskFull(full));
  EXPECT_EQ(CountTempFiles(dir / "small"), 0);
  EXPECT_EQ(ReadFileOrDie(target), "old frame");
  EXPECT_OK(WriteFileAtomically(target, std::string(32 << 10, 'y')));
}

// The writer is spent by the failed Append and its temporary file gone at
// once, not only when the writer is destroyed.
TEST(AtomicFileTest, AnAppendThatFindsTheDiskFullRemovesTheTempFileAtOnce) {
  TempDir dir;
  TmpfsMount small(dir / "small", 64 << 10);
  if (!small.mounted()) GTEST_SKIP() << small.error();
  ASSERT_OK_AND_ASSIGN(AtomicFileWriter writer,
                       AtomicFileWriter::Open(dir / "small" / "f"));
  EXPECT_TRUE(IsDiskFull(writer.Append(std::string(1 << 20, 'x'))));
  EXPECT_EQ(CountTempFiles(dir / "small"), 0);
  EXPECT_THAT(writer.Commit(), StatusIs(absl::StatusCode::kFailedPrecondition,
                                        HasSubstr("already spent")));
  EXPECT_FALSE(std::filesystem::exists(dir / "small" / "f"));
}

// Only no space and a full quota are a full disk; other exhausted resources
// keep their code but are not mistaken for it, nor is a message alone.
TEST(AtomicFileTest, OnlyNoSpaceAndAFullQuotaAreDiskFull) {
  TempDir dir;
  const std::filesystem::path path = dir / "f";
  const absl::Status quota = FileError(EDQUOT, "cannot write", path);
  EXPECT_TRUE(IsDiskFull(quota));
  EXPECT_THAT(quota, StatusIs(absl::StatusCode::kResourceExhausted,
                              HasSubstr("disk full (EDQUOT): cannot write " +
                                        path.string())));
  const absl::Status files = FileError(EMFILE, "cannot create", path);
  EXPECT_THAT(files, StatusIs(absl::StatusCode::kResourceExhausted,
                              HasSubstr("cannot create " + path.string())));
  EXPECT_FALSE(IsDiskFull(files));
  EXPECT_FALSE(IsDiskFull(absl::ResourceExhaustedError(
      "disk full (ENOSPC): cannot write " + path.string())));
  EXPECT_THAT(FileError(ENOENT, "cannot open", path),
              StatusIs(absl::StatusCode::kNotFound,
                       HasSubstr("No such file or directory")));
}

TEST(ReadFileBytesTest, ReadsAFileUpToTheLimit) {
  TempDir dir;
  ASSERT_OK(WriteFileAtomically(dir / "f", "12345"));
  ASSERT_OK_AND_ASSIGN(const std::string bytes,
                       ReadFileBytes(dir / "f", 5, "test file"));
  EXPECT_EQ(bytes, "12345");
  ASSERT_OK(WriteFileAtomically(dir / "empty", ""));
  ASSERT_OK_AND_ASSIGN(const std::string none,
                       ReadFileBytes(dir / "empty", 0, "test file"));
  EXPECT_EQ(none, "");
  EXPECT_THAT(ReadFileBytes(dir / "f", 4, "test file"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       (dir / "f").string() +
                           ": test file of 5 bytes, more than the limit of 4; "
                           "not read"));
}

// The size is refused before anything is read or allocated: a sparse file
// of 1 TiB takes no disk and would take 1 TiB of memory.
TEST(ReadFileBytesTest, AHugeFileIsRefusedUnread) {
  TempDir dir;
  const std::filesystem::path file = dir / "huge";
  ASSERT_OK(WriteFileAtomically(file, ""));
  std::filesystem::resize_file(file, uint64_t{1} << 40);
  EXPECT_THAT(ReadFileBytes(file, 1 << 20, "test file"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       file.string() +
                           ": test file of 1099511627776 bytes, more than the "
                           "limit of 1048576; not read"));
}

TEST(ReadFileBytesTest, WhatIsNotARegularFileIsNotRead) {
  TempDir dir;
  EXPECT_THAT(ReadFileBytes(dir / "none", 10, "test file"),
              StatusIs(absl::StatusCode::kNotFound,
                       "cannot open " + (dir / "none").string() +
                           ": No such file or directory"));
  EXPECT_THAT(ReadFileBytes(dir.path(), 10, "test file"),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       dir.path().string() + " is not a regular file"));
  // A FIFO without a writer would block an open for reading.
  const std::filesystem::path fifo = dir / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  EXPECT_THAT(ReadFileBytes(fifo, 10, "test file"),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       fifo.string() + " is not a regular file"));
}

}  // namespace
}  // namespace hdrstereo::io
