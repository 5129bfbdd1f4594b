// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/session_repository.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/temp_dir.h"

namespace hdrstereo::store {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::TempDir;
using ::testing::HasSubstr;

class SessionRepositoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    absl::StatusOr<std::unique_ptr<Store>> store = Store::Open(dir_.path());
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = *std::move(store);
    sessions_ = std::make_unique<SessionRepository>(*store_);
  }

  TempDir dir_;
  std::unique_ptr<Store> store_;
  std::unique_ptr<SessionRepository> sessions_;
};

TEST_F(SessionRepositoryTest, CreateGetAndFolder) {
  absl::StatusOr<SessionRecord> created = sessions_->Create("lab-1", "note");
  ASSERT_TRUE(created.ok()) << created.status();
  EXPECT_EQ(created->name, "lab-1");
  EXPECT_GT(created->create_time_ms, 0);
  EXPECT_TRUE(fs::is_directory(store_->files().SessionDir("lab-1")));

  absl::StatusOr<SessionRecord> got = sessions_->Get("lab-1");
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(got->id, created->id);
  EXPECT_EQ(got->note, "note");
  EXPECT_EQ(got->frame_count, 0);
}

TEST_F(SessionRepositoryTest, DuplicateAndBadInputChangeNothing) {
  ASSERT_TRUE(sessions_->Create("lab-1", "first").ok());
  absl::StatusOr<SessionRecord> dup = sessions_->Create("lab-1", "second");
  EXPECT_EQ(dup.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(sessions_->Get("lab-1")->note, "first");

  EXPECT_EQ(sessions_->Create("bad name", "").status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(sessions_->Create("ok", std::string(5000, 'n')).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(sessions_->List("", 10)->sessions.size(), 1u);
  EXPECT_FALSE(fs::exists(store_->files().SessionDir("ok")));
}

TEST_F(SessionRepositoryTest, ListPagesInNameOrder) {
  for (const char* name : {"c", "a", "e", "b", "d"}) {
    ASSERT_TRUE(sessions_->Create(name, "").ok());
  }
  std::vector<std::string> seen;
  std::string after;
  int pages = 0;
  do {
    absl::StatusOr<SessionPage> page = sessions_->List(after, 2);
    ASSERT_TRUE(page.ok());
    for (const SessionRecord& s : page->sessions) seen.push_back(s.name);
    after = page->next_after;
    ++pages;
  } while (!after.empty());
  EXPECT_EQ(seen, (std::vector<std::string>{"a", "b", "c", "d", "e"}));
  EXPECT_EQ(pages, 3);
}

TEST_F(SessionRepositoryTest, DeleteRemovesRowsAndFolder) {
  ASSERT_TRUE(sessions_->Create("gone", "").ok());
  ASSERT_TRUE(store_->files().WriteSessionFile("gone", "x/y.png", "px").ok());
  absl::StatusOr<DeletedSession> deleted = sessions_->Delete("gone");
  ASSERT_TRUE(deleted.ok()) << deleted.status();
  EXPECT_EQ(sessions_->Get("gone").status().code(),
            absl::StatusCode::kNotFound);
  EXPECT_FALSE(fs::exists(store_->files().SessionDir("gone")));
  EXPECT_EQ(sessions_->Delete("gone").status().code(),
            absl::StatusCode::kNotFound);
}

TEST_F(SessionRepositoryTest, DeleteIsRefusedWhileAJobIsActive) {
  absl::StatusOr<SessionRecord> s = sessions_->Create("busy", "");
  ASSERT_TRUE(s.ok());
  {
    absl::MutexLock lock(&store_->db().mutex());
    absl::StatusOr<Statement> insert = store_->db().Prepare(
        "INSERT INTO jobs (kind, session_id, state, request, create_time_ms) "
        "VALUES ('capture', ?1, 'running', x'', 0)");
    ASSERT_TRUE(insert.ok());
    ASSERT_TRUE(insert->Bind(1, s->id).Run().ok());
  }
  absl::StatusOr<DeletedSession> deleted = sessions_->Delete("busy");
  EXPECT_EQ(deleted.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(deleted.status().message()),
              HasSubstr("cancel them first"));
  EXPECT_TRUE(sessions_->Get("busy").ok());
  EXPECT_TRUE(fs::is_directory(store_->files().SessionDir("busy")));
}

}  // namespace
}  // namespace hdrstereo::store
