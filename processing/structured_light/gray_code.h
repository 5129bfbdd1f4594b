// SPDX-License-Identifier: GPL-3.0-or-later
//
// Gray-code structured-light patterns (Scharstein & Szeliski 2003; thesis
// 4.2). The one generator used both to project patterns during capture and
// to decode them afterwards.
#ifndef HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_GRAY_CODE_H_
#define HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_GRAY_CODE_H_

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace hdrstereo::structured_light {

enum class Axis {
  kColumns,  // vertical stripes coding the projector column
  kRows,     // horizontal stripes coding the projector row
};

// ceil(log2(n)) bits code n columns or rows (10 for 1024, 10 for 768).
int BitCount(int n);

// Binary-reflected Gray code of `value`, and its inverse.
inline int ToGray(int value) { return value ^ (value >> 1); }
int FromGray(int gray);

// One projected pattern.
struct Pattern {
  enum class Kind { kBitPlane, kWhite, kBlack };
  Kind kind = Kind::kBitPlane;
  Axis axis = Axis::kColumns;
  int bit = 0;  // 0 = most significant
  bool inverse = false;

  // Stable identifier used in file names and frame rows: "col_b03",
  // "row_b00" (add "_inv" for the inverse via `inverse`), "white", "black".
  std::string Id() const;
};

// Every pattern of a structured-light capture for a projector of `size`:
// columns then rows, each bit followed by its inverse, then white and black.
// 1024x768 gives 2 * (10 + 10) + 2 = 42 patterns.
std::vector<Pattern> AllPatterns(cv::Size size);
// The same for codes of `column_bits` and `row_bits` bits.
std::vector<Pattern> AllPatterns(int column_bits, int row_bits);

// The CV_8UC1 image of `pattern` (0 or 255) at projector resolution `size`.
// INVALID_ARGUMENT for a bit outside [0, BitCount) or an empty size.
absl::StatusOr<cv::Mat> Render(const Pattern& pattern, cv::Size size);

}  // namespace hdrstereo::structured_light

#endif  // HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_GRAY_CODE_H_
