// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/capture_io.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_replace.h"
#include "processing/io/image.h"
#include "processing/structured_light/gray_code.h"

namespace hdrstereo::structured_light {

namespace {

// "sl_col_b03_inv_exp_1-30s" -> id "col_b03_inv", tag "1-30s";
// "sl_white_exp_1-30s" -> id "white". False for other names.
bool ParseFrameName(const std::string& stem, std::string* id, std::string* tag,
                    bool* column, int* bit) {
  if (!absl::StartsWith(stem, "sl_")) return false;
  const std::string rest = stem.substr(3);
  for (const char* flat : {"white", "black"}) {
    const std::string prefix = absl::StrCat(flat, "_exp_");
    if (absl::StartsWith(rest, prefix) && rest.size() > prefix.size()) {
      *id = flat;
      *tag = rest.substr(prefix.size());
      *bit = -1;
      return true;
    }
  }
  if (!absl::StartsWith(rest, "col_b") && !absl::StartsWith(rest, "row_b")) {
    return false;
  }
  *column = rest[0] == 'c';
  size_t i = 5;
  int value = 0;
  while (i < rest.size() && absl::ascii_isdigit(rest[i]) && i < 8) {
    value = value * 10 + (rest[i] - '0');
    ++i;
  }
  if (i == 5) return false;
  bool inverse = false;
  if (absl::StartsWith(absl::string_view(rest).substr(i), "_inv")) {
    inverse = true;
    i += 4;
  }
  const absl::string_view exp = absl::string_view(rest).substr(i);
  if (!absl::StartsWith(exp, "_exp_") || exp.size() <= 5) return false;
  *bit = value;
  *tag = std::string(exp.substr(5));
  *id = absl::StrFormat("%s_b%02d%s", *column ? "col" : "row", value,
                        inverse ? "_inv" : "");
  return true;
}

}  // namespace

std::string ExposureTag(double seconds) {
  if (seconds < 0.4) {
    const double denominator = 1.0 / seconds;
    if (std::abs(denominator - std::round(denominator)) < 1e-6 * denominator) {
      return absl::StrFormat("1-%.0fs", denominator);
    }
  }
  return absl::StrReplaceAll(absl::StrFormat("%gs", seconds), {{"+", ""}});
}

std::optional<double> ParseExposureTag(const std::string& tag) {
  if (!absl::EndsWith(tag, "s") || tag.size() < 2) return std::nullopt;
  const absl::string_view body =
      absl::string_view(tag).substr(0, tag.size() - 1);
  double value = 0;
  const size_t dash = body.find('-');
  if (dash != absl::string_view::npos) {
    int num = 0, den = 0;
    if (!absl::SimpleAtoi(body.substr(0, dash), &num) ||
        !absl::SimpleAtoi(body.substr(dash + 1), &den) || num <= 0 ||
        den <= 0) {
      return std::nullopt;
    }
    value = static_cast<double>(num) / den;
  } else if (!absl::SimpleAtod(body, &value)) {
    return std::nullopt;
  }
  if (!std::isfinite(value) || value <= 0) return std::nullopt;
  return value;
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
  // tag -> frame id -> file
  std::map<std::string, std::map<std::string, std::filesystem::path>> files;
  int col_bits = 0, row_bits = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file()) continue;
    std::string id, tag;
    bool column = false;
    int bit = -1;
    if (!ParseFrameName(entry.path().stem().string(), &id, &tag, &column,
                        &bit)) {
      continue;
    }
    if (bit > 15) continue;
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
