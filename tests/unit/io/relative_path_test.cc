// SPDX-License-Identifier: GPL-3.0-or-later
//
// Paths named inside a folder by others (the daemon's writers, a cluster
// node's result files): only those that stay inside it pass, and the
// refusal quotes a bounded, escaped prefix of the path.
#include "processing/io/relative_path.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "tests/support/status_matchers.h"

namespace hdrstereo::io {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

TEST(RelativePathTest, PathsInsideTheFolderPass) {
  EXPECT_OK(ValidateRelativePath("captures/1/left/stereo/exp_1-125s.png"));
  EXPECT_OK(ValidateRelativePath("report.html"));
  EXPECT_OK(ValidateRelativePath("a/..b/c.."));  // dots inside a name
  EXPECT_OK(ValidateRelativePath(std::string(kMaxRelativePathBytes, 'a')));
}

TEST(RelativePathTest, PathsThatLeaveTheFolderAreRefusedNamingThePath) {
  const std::pair<std::string, std::string> bad[] = {
      {"../../etc/passwd", "path \"../../etc/passwd\" has a \"..\" component"},
      {"a/../../b", "path \"a/../../b\" has a \"..\" component"},
      {"a/..", "path \"a/..\" has a \"..\" component"},
      {"/etc/passwd", "path \"/etc/passwd\" is absolute (it must be relative)"},
      {"./x", "path \"./x\" has a \".\" component"},
      {"a//b", "path \"a//b\" has an empty component"},
      {"a/", "path \"a/\" has an empty component"},
      {"", "path \"\" is empty"},
      {std::string("a\0/../b", 7), "path \"a\\x00/../b\" has a NUL byte"},
  };
  for (const auto& [path, message] : bad) {
    EXPECT_THAT(ValidateRelativePath(path),
                StatusIs(absl::StatusCode::kInvalidArgument, message))
        << path;
  }
}

TEST(RelativePathTest, ALongPathIsRefusedWithABoundedQuote) {
  const std::string path(kMaxRelativePathBytes + 1, 'a');
  const absl::Status status = ValidateRelativePath(path);
  EXPECT_THAT(status, StatusIs(absl::StatusCode::kInvalidArgument,
                               HasSubstr("(4097 bytes) is longer than the "
                                         "limit of 4096 bytes")));
  EXPECT_LT(status.message().size(), 200u);
}

}  // namespace
}  // namespace hdrstereo::io
