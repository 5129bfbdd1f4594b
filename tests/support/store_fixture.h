// SPDX-License-Identifier: GPL-3.0-or-later
//
// A real store (SQLite file and data root) in a temporary folder, with
// helpers that make the rows repositories refer to.
#ifndef HDRSTEREO_TESTS_SUPPORT_STORE_FIXTURE_H_
#define HDRSTEREO_TESTS_SUPPORT_STORE_FIXTURE_H_

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "daemon/store/job_repository.h"
#include "daemon/store/session_repository.h"
#include "daemon/store/store.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::testing {

class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_OK_AND_ASSIGN(store_, store::Store::Open(dir_.path()));
  }

  // A session named `name`.
  absl::StatusOr<store::SessionRecord> Session(const std::string& name) {
    return store::SessionRepository(*store_).Create(name, "");
  }
  // A queued job of `kind` in `session`.
  absl::StatusOr<store::JobRecord> Job(
      const std::string& session,
      store::JobKind kind = store::JobKind::kCapture) {
    return store::JobRepository(*store_).Create(kind, session, "request", 1,
                                                "queued", "tester");
  }

  TempDir dir_;
  std::unique_ptr<store::Store> store_;
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_STORE_FIXTURE_H_
