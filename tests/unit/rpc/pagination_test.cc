// SPDX-License-Identifier: GPL-3.0-or-later
//
// PageRequest parsing and the token round trip every List method uses: a
// client that pages with next_page_token sees each row exactly once.
#include "daemon/rpc/pagination.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "tests/support/status_matchers.h"

namespace hdrstereo::rpc {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

v1::PageRequest Request(int size, const std::string& token = "") {
  v1::PageRequest request;
  request.set_page_size(size);
  request.set_page_token(token);
  return request;
}

TEST(ParsePageTest, ZeroSizeMeansTheDefault) {
  ASSERT_OK_AND_ASSIGN(Page page, ParsePage(Request(0)));
  EXPECT_EQ(page.size, kDefaultPageSize);
  EXPECT_EQ(page.after, "");
}

TEST(ParsePageTest, SizeOutsideTheRangeNamesTheField) {
  EXPECT_THAT(ParsePage(Request(-1)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("page.page_size is -1")));
  EXPECT_THAT(ParsePage(Request(kMaxPageSize + 1)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("page.page_size is 1001")));
  ASSERT_OK_AND_ASSIGN(Page largest, ParsePage(Request(kMaxPageSize)));
  EXPECT_EQ(largest.size, kMaxPageSize);
}

TEST(ParsePageTest, TokenRoundTripsAndForgedTokensAreRefused) {
  ASSERT_OK_AND_ASSIGN(Page page,
                       ParsePage(Request(5, EncodePageToken("lab-1"))));
  EXPECT_EQ(page.after, "lab-1");
  EXPECT_EQ(EncodePageToken(""), "");
  // Not base64, and base64 of something this server never issues.
  for (const std::string& forged :
       {std::string("!!"), std::string("bGFiLTE")}) {
    EXPECT_THAT(ParsePage(Request(5, forged)),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("page.page_token was not issued")))
        << forged;
  }
}

TEST(ParseIdPageTest, TokenMustHoldAPositiveKey) {
  ASSERT_OK_AND_ASSIGN(IdPage first, ParseIdPage(Request(3)));
  EXPECT_EQ(first.after, 0);
  ASSERT_OK_AND_ASSIGN(IdPage next,
                       ParseIdPage(Request(3, EncodePageToken("42"))));
  EXPECT_EQ(next.after, 42);
  for (const char* key : {"x", "0", "-7", "4.5"}) {
    EXPECT_THAT(ParseIdPage(Request(3, EncodePageToken(key))),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("page.page_token was not issued")))
        << key;
  }
  EXPECT_THAT(ParseIdPage(Request(-2)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("page.page_size")));
}

struct Row {
  int64_t id;
};

// What a repository does with IdPage: rows with key > after, at most limit.
std::vector<Row> Fetch(const std::vector<int64_t>& table, int64_t after,
                       int limit) {
  std::vector<Row> rows;
  for (int64_t id : table) {
    if (id > after && static_cast<int>(rows.size()) < limit)
      rows.push_back({id});
  }
  return rows;
}

TEST(FinishIdPageTest, PagingVisitsEveryRowOnce) {
  const std::vector<int64_t> table = {3, 4, 9, 10, 11, 20, 21};
  for (int size : {1, 2, 3, 7, 8}) {
    std::vector<int64_t> seen;
    std::string token;
    int pages = 0;
    do {
      ASSERT_OK_AND_ASSIGN(IdPage page, ParseIdPage(Request(size, token)));
      std::vector<Row> rows = Fetch(table, page.after, page.size + 1);
      token = FinishIdPage(page, rows, [](const Row& r) { return r.id; });
      EXPECT_LE(static_cast<int>(rows.size()), size);
      for (const Row& r : rows) seen.push_back(r.id);
      ASSERT_LT(++pages, 20) << "paging does not end at size " << size;
    } while (!token.empty());
    EXPECT_EQ(seen, table) << "size " << size;
    // A page that holds the rest exactly ends without a token.
    EXPECT_EQ(pages, (static_cast<int>(table.size()) + size - 1) / size)
        << "size " << size;
  }
}

TEST(FinishIdPageTest, LastPageHasNoToken) {
  IdPage page{.size = 2};
  std::vector<Row> rows = {{5}, {6}};
  EXPECT_EQ(FinishIdPage(page, rows, [](const Row& r) { return r.id; }), "");
  EXPECT_EQ(rows.size(), 2u);
  rows.push_back({7});
  const std::string token =
      FinishIdPage(page, rows, [](const Row& r) { return r.id; });
  ASSERT_EQ(rows.size(), 2u);
  ASSERT_OK_AND_ASSIGN(IdPage next, ParseIdPage(Request(2, token)));
  EXPECT_EQ(next.after, 6);
}

}  // namespace
}  // namespace hdrstereo::rpc
