// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/names.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace hdrstereo::store {
namespace {

using ::testing::HasSubstr;

TEST(ValidateNameTest, AcceptsSlugs) {
  for (const char* name : {"a", "lab-1", "nightly_2026-11-23", "X9", "0abc"}) {
    EXPECT_TRUE(ValidateName(name, "session name").ok()) << name;
  }
  EXPECT_TRUE(ValidateName(std::string(64, 'a'), "session name").ok());
}

TEST(ValidateNameTest, RejectsWithAnActionableMessage) {
  struct Case {
    std::string name;
    std::string expected;
  };
  for (const Case& c : std::vector<Case>{
           {"", "is empty"},
           {std::string(65, 'a'), "65 characters; at most 64"},
           {"-lab", "must start with a letter or digit"},
           {"_lab", "must start with a letter or digit"},
           {"lab 1", "contains ' '"},
           {"../etc", "must start with a letter or digit"},
           {"lab/1", "contains '/'"},
           {"lab.1", "contains '.'"},
           {"lab\n1", "byte 0x0a"},
           {"caf\xc3\xa9", "byte 0xc3"},
       }) {
    absl::Status status = ValidateName(c.name, "session name");
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_THAT(std::string(status.message()), HasSubstr(c.expected));
    EXPECT_THAT(std::string(status.message()), HasSubstr("session name"));
  }
}

}  // namespace
}  // namespace hdrstereo::store
