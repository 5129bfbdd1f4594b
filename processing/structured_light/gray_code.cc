// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/gray_code.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace hdrstereo::structured_light {

int BitCount(int n) {
  int bits = 0;
  while ((1 << bits) < n) ++bits;
  return bits;
}

int FromGray(int gray) {
  int value = gray;
  for (int shift = gray >> 1; shift != 0; shift >>= 1) value ^= shift;
  return value;
}

std::string Pattern::Id() const {
  switch (kind) {
    case Kind::kWhite:
      return "white";
    case Kind::kBlack:
      return "black";
    case Kind::kBitPlane:
      break;
  }
  return absl::StrFormat("%s_b%02d", axis == Axis::kColumns ? "col" : "row",
                         bit);
}

std::vector<Pattern> AllPatterns(cv::Size size) {
  return AllPatterns(BitCount(size.width), BitCount(size.height));
}

std::vector<Pattern> AllPatterns(int column_bits, int row_bits) {
  std::vector<Pattern> patterns;
  for (Axis axis : {Axis::kColumns, Axis::kRows}) {
    const int bits = axis == Axis::kColumns ? column_bits : row_bits;
    for (int bit = 0; bit < bits; ++bit) {
      for (bool inverse : {false, true}) {
        patterns.push_back({.kind = Pattern::Kind::kBitPlane,
                            .axis = axis,
                            .bit = bit,
                            .inverse = inverse});
      }
    }
  }
  patterns.push_back({.kind = Pattern::Kind::kWhite});
  patterns.push_back({.kind = Pattern::Kind::kBlack});
  return patterns;
}

absl::StatusOr<cv::Mat> Render(const Pattern& pattern, cv::Size size) {
  if (size.width <= 0 || size.height <= 0) {
    return absl::InvalidArgumentError("pattern size must be positive");
  }
  switch (pattern.kind) {
    case Pattern::Kind::kWhite:
      return cv::Mat(size, CV_8UC1, cv::Scalar(255));
    case Pattern::Kind::kBlack:
      return cv::Mat(size, CV_8UC1, cv::Scalar(0));
    case Pattern::Kind::kBitPlane:
      break;
  }
  const bool columns = pattern.axis == Axis::kColumns;
  const int n = columns ? size.width : size.height;
  const int bits = BitCount(n);
  if (pattern.bit < 0 || pattern.bit >= bits) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "Gray-code bit %d is outside [0, %d) for %d projector %s", pattern.bit,
        bits, n, columns ? "columns" : "rows"));
  }
  // One line of stripes, then replicated.
  cv::Mat line(1, n, CV_8UC1);
  for (int i = 0; i < n; ++i) {
    const bool on = (ToGray(i) >> (bits - 1 - pattern.bit)) & 1;
    line.at<uchar>(0, i) = (on != pattern.inverse) ? 255 : 0;
  }
  cv::Mat image;
  if (columns) {
    cv::repeat(line, size.height, 1, image);
  } else {
    cv::repeat(line.t(), 1, size.width, image);
  }
  return image;
}

}  // namespace hdrstereo::structured_light
