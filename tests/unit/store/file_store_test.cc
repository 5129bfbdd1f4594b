// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/file_store.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "processing/io/atomic_file.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"
#include "tests/support/tmpfs.h"

namespace hdrstereo::store {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::TempDir;
using ::hdrstereo::testing::TmpfsMount;
using ::testing::HasSubstr;

TEST(FileStoreTest, DataRootThatIsAFileIsRefused) {
  TempDir dir;
  std::ofstream(dir / "root") << "not a folder";
  absl::StatusOr<FileStore> store = FileStore::Open(dir / "root");
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(store.status().message()), HasSubstr("not a folder"));
  EXPECT_EQ(ReadFileOrDie(dir / "root"), "not a folder");
}

TEST(FileStoreTest, SessionFilesStayInsideTheSession) {
  TempDir dir;
  absl::StatusOr<FileStore> store = FileStore::Open(dir.path());
  ASSERT_TRUE(store.ok());
  ASSERT_TRUE(store->CreateSessionDir("s1").ok());
  ASSERT_TRUE(
      store->WriteSessionFile("s1", "captures/1/left/exp.tiff", "data").ok());
  EXPECT_EQ(ReadFileOrDie(store->SessionDir("s1") / "captures/1/left/exp.tiff"),
            "data");
  for (const char* bad : {"../s2/x", "/etc/passwd", "a/../../x", "", "./x"}) {
    EXPECT_EQ(store->WriteSessionFile("s1", bad, "x").code(),
              absl::StatusCode::kInvalidArgument)
        << bad;
  }
}

TEST(FileStoreTest, SweepKeepsKnownSessionsAndMovesOrphansAside) {
  TempDir dir;
  absl::StatusOr<FileStore> store = FileStore::Open(dir.path());
  ASSERT_TRUE(store.ok());
  ASSERT_TRUE(store->CreateSessionDir("known").ok());
  ASSERT_TRUE(store->WriteSessionFile("known", "a/frame.png", "ok").ok());
  std::ofstream(store->SessionDir("known") / "a/frame.png.tmp-0123") << "half";
  ASSERT_TRUE(store->CreateSessionDir("orphan").ok());
  std::ofstream(store->SessionDir("orphan") / "precious.txt") << "keep me";
  fs::create_directories(dir / "trash/old-session/x");

  absl::StatusOr<int> moved = store->Sweep({"known"});
  ASSERT_TRUE(moved.ok()) << moved.status();
  EXPECT_EQ(*moved, 1);
  EXPECT_EQ(ReadFileOrDie(store->SessionDir("known") / "a/frame.png"), "ok");
  EXPECT_FALSE(fs::exists(store->SessionDir("known") / "a/frame.png.tmp-0123"));
  EXPECT_FALSE(fs::exists(store->SessionDir("orphan")));
  EXPECT_TRUE(fs::is_empty(dir / "trash"));
  // The orphan's content is kept for a person to look at.
  int kept = 0;
  for (const auto& entry : fs::directory_iterator(dir / "orphaned")) {
    EXPECT_EQ(ReadFileOrDie(entry.path() / "precious.txt"), "keep me");
    ++kept;
  }
  EXPECT_EQ(kept, 1);
}

// A session file that does not fit on the data root's filesystem (a 256 kB
// tmpfs): io::IsDiskFull, naming the file; neither it nor a temporary file
// is left, and a file that fits is written afterwards.
TEST(FileStoreTest, AFileThatDoesNotFitIsDiskFullAndLeavesNothing) {
  TempDir dir;
  TmpfsMount small(dir / "root", 256 << 10);
  if (!small.mounted()) GTEST_SKIP() << small.error();
  ASSERT_OK_AND_ASSIGN(FileStore store, FileStore::Open(dir / "root"));
  ASSERT_OK(store.CreateSessionDir("s1"));
  const absl::Status full = store.WriteSessionFile(
      "s1", "captures/1/left/f.png", std::string(1 << 20, 'x'));
  EXPECT_TRUE(io::IsDiskFull(full)) << full;
  EXPECT_THAT(
      full,
      StatusIs(
          absl::StatusCode::kResourceExhausted,
          HasSubstr(
              "cannot write " +
              (store.SessionDir("s1") / "captures/1/left/f.png").string())));
  for (const auto& entry :
       fs::recursive_directory_iterator(store.SessionDir("s1"))) {
    EXPECT_FALSE(entry.is_regular_file()) << entry.path();
  }
  EXPECT_OK(store.WriteSessionFile("s1", "captures/1/left/f.png",
                                   std::string(64 << 10, 'y')));
}

}  // namespace
}  // namespace hdrstereo::store
