// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/file_store.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "tests/support/temp_dir.h"

namespace hdrstereo::store {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::TempDir;
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

}  // namespace
}  // namespace hdrstereo::store
