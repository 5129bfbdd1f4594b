// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/mat_checks.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace hdrstereo::filters {

absl::Status CheckImage(const cv::Mat& m, absl::string_view what,
                        bool float_only, std::initializer_list<int> channels) {
  if (m.empty())
    return absl::InvalidArgumentError(absl::StrCat(what, " is empty"));
  if (m.dims != 2) {
    return absl::InvalidArgumentError(absl::StrCat(what, " is not 2-D"));
  }
  const int depth = m.depth();
  if (depth != CV_32F && (float_only || depth != CV_8U)) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " has depth ", depth, "; expected CV_32F",
                     float_only ? "" : " or CV_8U"));
  }
  if (channels.size() > 0 && std::find(channels.begin(), channels.end(),
                                       m.channels()) == channels.end()) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, " has an unsupported number of channels (", m.channels(), ")"));
  }
  if (depth == CV_32F && !cv::checkRange(m, /*quiet=*/true)) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " contains NaN or Inf"));
  }
  return absl::OkStatus();
}

cv::Mat ToFloat(const cv::Mat& m) {
  if (m.depth() == CV_32F) return m;
  cv::Mat f;
  m.convertTo(f, CV_32F);
  return f;
}

}  // namespace hdrstereo::filters
