// SPDX-License-Identifier: GPL-3.0-or-later
#include "clients/cli/exposure.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/status_matchers.h"

namespace hdrstereo::cli {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

TEST(ExposureTest, ParsesPhotographersNotation) {
  EXPECT_DOUBLE_EQ(*ParseExposure("1/125"), 1.0 / 125);
  EXPECT_DOUBLE_EQ(*ParseExposure(" 1/2000s "), 1.0 / 2000);
  EXPECT_DOUBLE_EQ(*ParseExposure("0.5"), 0.5);
  EXPECT_DOUBLE_EQ(*ParseExposure("2s"), 2.0);
  EXPECT_DOUBLE_EQ(*ParseExposure("30"), 30.0);
}

TEST(ExposureTest, RejectsNonsense) {
  for (const char* bad :
       {"", "0", "-1/125", "1/0", "fast", "1/abc", "nan", "inf", "1/125/2"}) {
    EXPECT_EQ(ParseExposure(bad).status().code(),
              absl::StatusCode::kInvalidArgument)
        << bad;
  }
}

TEST(ExposureTest, ListsAndFormatting) {
  absl::StatusOr<std::vector<double>> list = ParseExposureList("1/15,1/30,0.5");
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list->size(), 3u);
  EXPECT_DOUBLE_EQ((*list)[1], 1.0 / 30);
  EXPECT_THAT(
      ParseExposureList("1/15,,1/30"),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr(
              "exposure \"\" is not a positive time like 1/125, 0.5 or 2")));
  EXPECT_EQ(FormatExposure(1.0 / 125), "1/125 s");
  EXPECT_EQ(FormatExposure(0.5), "0.5 s");
  EXPECT_EQ(FormatExposure(2), "2 s");
}

}  // namespace
}  // namespace hdrstereo::cli
