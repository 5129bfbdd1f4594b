// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/capture_io.h"

#include <algorithm>
#include <map>
#include <opencv2/imgproc.hpp>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/base/status_macros.h"
#include "processing/io/capture_layout.h"
#include "processing/io/image.h"
#include "processing/structured_light/gray_code.h"

namespace hdrstereo::structured_light {

namespace {

// "col_b03" -> column, 3; "white" -> -1.
int BitOf(const std::string& pattern, bool* column) {
  int bit = -1;
  *column = absl::StartsWith(pattern, "col_b");
  if ((*column || absl::StartsWith(pattern, "row_b")) &&
      absl::SimpleAtoi(absl::string_view(pattern).substr(5), &bit)) {
    return bit;
  }
  return -1;
}

}  // namespace

absl::StatusOr<ViewFrames> LoadCaptureView(
    const std::filesystem::path& capture_dir, const std::string& view,
    std::optional<cv::Size> projector_size) {
  const std::filesystem::path folder =
      capture_dir / view / io::FrameRoleName(io::FrameRole::kStructuredLight);
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) {
    return absl::NotFoundError(
        absl::StrCat(folder.string(), ": no structured-light folder"));
  }
  // tag -> frame id -> file
  std::map<std::string, std::map<std::string, std::filesystem::path>> files;
  int col_bits = 0, row_bits = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file()) continue;
    const std::optional<io::FrameKey> key = io::ParseFrameFileStem(
        io::FrameRole::kStructuredLight, entry.path().stem().string());
    if (!key) continue;
    bool column = false;
    const int bit = BitOf(key->pattern, &column);
    if (bit > 15) continue;
    const std::string id =
        absl::StrCat(key->pattern, key->inverse ? "_inv" : "");
    const std::string tag = io::ExposureTag(key->exposure_s);
    if (bit >= 0) {
      int& bits = column ? col_bits : row_bits;
      bits = std::max(bits, bit + 1);
    }
    files[tag][id] = entry.path();
  }
  if (ec) {
    return absl::InternalError(
        absl::StrCat(folder.string(), ": ", ec.message()));
  }
  if (files.empty() || col_bits == 0 || row_bits == 0) {
    return absl::NotFoundError(absl::StrCat(
        folder.string(),
        ": no Gray-code frames (sl_col_bNN_exp_TAG, sl_row_bNN_exp_TAG)"));
  }
  cv::Size size =
      projector_size.value_or(cv::Size(1 << col_bits, 1 << row_bits));
  if (size.width <= 0 || size.height <= 0) {
    return absl::InvalidArgumentError("projector size must be positive");
  }
  if (BitCount(size.width) != col_bits || BitCount(size.height) != row_bits) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: found %d column and %d row bit planes, but a %dx%d projector "
        "needs %d and %d",
        folder.string(), col_bits, row_bits, size.width, size.height,
        BitCount(size.width), BitCount(size.height)));
  }
  std::vector<std::pair<double, std::string>> tags;
  for (const auto& kv : files) {
    const std::optional<double> seconds = io::ParseExposureTag(kv.first);
    tags.emplace_back(seconds.value_or(0.0), kv.first);
  }
  std::sort(tags.begin(), tags.end());
  ViewFrames out;
  out.projector_size = size;
  const std::vector<Pattern> patterns = AllPatterns(size);
  for (const auto& [seconds, tag] : tags) {
    ExposureFrames e;
    e.exposure_s = seconds;
    const auto& by_id = files[tag];
    for (const Pattern& p : patterns) {
      const std::string id = FrameId(p);
      auto it = by_id.find(id);
      if (it == by_id.end()) {
        return absl::InvalidArgumentError(
            absl::StrFormat("%s: exposure %s: sl_%s_exp_%s is missing",
                            folder.string(), tag, id, tag));
      }
      ASSIGN_OR_RETURN(io::DecodedImage image, io::DecodeImageFile(it->second));
      // Decode reads luminance only: a colour frame kept as it is would
      // hold three times the memory (6 GB a view at 24 megapixels).
      if (image.pixels.channels() == 3) {
        cv::cvtColor(image.pixels, image.pixels, cv::COLOR_BGR2GRAY);
      }
      e.frames.push_back(std::move(image.pixels));
    }
    out.exposures.push_back(std::move(e));
  }
  return out;
}

}  // namespace hdrstereo::structured_light
