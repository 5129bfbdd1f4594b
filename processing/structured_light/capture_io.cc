// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/capture_io.h"

#include <algorithm>
#include <map>
#include <regex>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/io/image.h"
#include "processing/structured_light/gray_code.h"

namespace hdrstereo::structured_light {

std::optional<double> ParseExposureTag(const std::string& tag) {
  static const std::regex kFraction(R"(^(\d+)-(\d+)s$)");
  static const std::regex kSeconds(R"(^(\d+(\.\d*)?([eE]-?\d+)?)s$)");
  std::smatch m;
  try {
    if (std::regex_match(tag, m, kFraction)) {
      const double num = std::stod(m[1].str()), den = std::stod(m[2].str());
      if (den > 0) return num / den;
    } else if (std::regex_match(tag, m, kSeconds)) {
      return std::stod(m[1].str());
    }
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

absl::StatusOr<ViewFrames> LoadCaptureView(
    const std::filesystem::path& capture_dir, const std::string& view,
    std::optional<cv::Size> projector_size) {
  const std::filesystem::path folder = capture_dir / view / "structured_light";
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) {
    return absl::NotFoundError(
        absl::StrCat(folder.string(), ": no structured-light folder"));
  }
  static const std::regex kBit(R"(^sl_(col|row)_b(\d+)(_inv)?_exp_(.+)$)");
  static const std::regex kFlat(R"(^sl_(white|black)_exp_(.+)$)");
  // tag -> frame id -> file
  std::map<std::string, std::map<std::string, std::filesystem::path>> files;
  int col_bits = 0, row_bits = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file()) continue;
    const std::string stem = entry.path().stem().string();
    std::smatch m;
    if (std::regex_match(stem, m, kBit)) {
      const int bit = std::stoi(m[2].str());
      if (bit > 15) continue;
      int& bits = m[1].str() == "col" ? col_bits : row_bits;
      bits = std::max(bits, bit + 1);
      files[m[4].str()][absl::StrFormat("%s_b%02d%s", m[1].str(), bit,
                                        m[3].str())] = entry.path();
    } else if (std::regex_match(stem, m, kFlat)) {
      files[m[2].str()][m[1].str()] = entry.path();
    }
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
    const std::optional<double> seconds = ParseExposureTag(kv.first);
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
      absl::StatusOr<io::DecodedImage> image = io::DecodeImageFile(it->second);
      if (!image.ok()) return image.status();
      e.frames.push_back(std::move(image->pixels));
    }
    out.exposures.push_back(std::move(e));
  }
  return out;
}

}  // namespace hdrstereo::structured_light
