// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/middlebury.h"

#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <system_error>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"

namespace hdrstereo::io {
namespace {

constexpr const char* kStandardKeys[] = {"cam0",  "cam1",   "doffs", "baseline",
                                         "width", "height", "ndisp"};

bool IsStandard(absl::string_view key) {
  for (const char* k : kStandardKeys) {
    if (key == k) return true;
  }
  return false;
}

// `v` in the fewest digits that read back as `v` exactly ("3997.684",
// "150", "1e-07"): a calib.txt read and written again keeps its numbers.
std::string Exact(double v) {
  char buffer[32];
  const std::to_chars_result end =
      std::to_chars(buffer, buffer + sizeof buffer, v);
  return std::string(buffer, end.ptr);
}

std::string Camera(double fx, double fy, double cx, double cy) {
  return absl::StrCat("[", Exact(fx), " 0 ", Exact(cx), "; 0 ", Exact(fy), " ",
                      Exact(cy), "; 0 0 1]");
}

bool ParseFinite(absl::string_view text, double* value) {
  return absl::SimpleAtod(text, value) && std::isfinite(*value);
}

// "[fx 0 cx; 0 fy cy; 0 0 1]" -> fx, fy, cx, cy: nine finite numbers.
bool ParseCamera(absl::string_view text, Calib* calib) {
  std::vector<double> v;
  for (absl::string_view part :
       absl::StrSplit(text, absl::ByAnyChar("[]; "), absl::SkipEmpty())) {
    double x = 0;
    if (v.size() == 9 || !ParseFinite(part, &x)) return false;
    v.push_back(x);
  }
  if (v.size() != 9 || !(v[0] > 0) || !(v[4] > 0)) return false;
  calib->fx = v[0];
  calib->cx = v[2];
  calib->fy = v[4];
  calib->cy = v[5];
  return true;
}

}  // namespace

std::string FormatCalib(const Calib& c) {
  std::string out = absl::StrFormat(
      "cam0=%s\ncam1=%s\ndoffs=%s\nbaseline=%s\nwidth=%d\nheight=%d\n"
      "ndisp=%d\n",
      Camera(c.fx, c.fy, c.cx, c.cy), Camera(c.fx, c.fy, c.cx + c.doffs, c.cy),
      Exact(c.doffs), Exact(c.baseline_mm), c.width, c.height, c.ndisp);
  for (const auto& [key, value] : c.extra) {
    absl::StrAppend(&out, key, "=", value, "\n");
  }
  return out;
}

absl::StatusOr<Calib> ParseCalib(absl::string_view text) {
  Calib c;
  std::map<std::string, std::string, std::less<>> values;
  for (absl::string_view line : absl::StrSplit(text, '\n', absl::SkipEmpty())) {
    line = absl::StripAsciiWhitespace(line);
    const size_t eq = line.find('=');
    if (line.empty() || eq == absl::string_view::npos) continue;
    const std::string key(absl::StripAsciiWhitespace(line.substr(0, eq)));
    const std::string value(absl::StripAsciiWhitespace(line.substr(eq + 1)));
    if (IsStandard(key)) {
      values[key] = value;
    } else {
      c.extra.emplace_back(key, value);
    }
  }
  // The key's value, or nullptr when the key is missing.
  auto find = [&](absl::string_view key) -> const std::string* {
    auto it = values.find(key);
    return it == values.end() ? nullptr : &it->second;
  };
  auto missing = [](absl::string_view key, const std::string* value,
                    absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calib.txt: ", key, " is missing or not ", what,
        value == nullptr ? "" : absl::StrCat(": ", QuoteInput(*value))));
  };
  const std::string* value = find("cam0");
  if (value == nullptr || !ParseCamera(*value, &c)) {
    return missing("cam0", value, "[fx 0 cx; 0 fy cy; 0 0 1]");
  }
  value = find("doffs");
  if (value != nullptr && !ParseFinite(*value, &c.doffs)) {
    return missing("doffs", value, "a number");
  }
  value = find("baseline");
  if (value == nullptr || !ParseFinite(*value, &c.baseline_mm) ||
      !(c.baseline_mm > 0)) {
    return missing("baseline", value, "a positive number (mm)");
  }
  int64_t width = 0, height = 0, ndisp = 0;
  for (auto [key, field] :
       {std::pair{"width", &width}, {"height", &height}, {"ndisp", &ndisp}}) {
    value = find(key);
    if (value == nullptr || !absl::SimpleAtoi(*value, field)) {
      return missing(key, value, "a whole number");
    }
  }
  // The size of the disparity maps the file describes; a disparity is at
  // most an image width.
  RETURN_IF_ERROR(
      ImageBytes("calib.txt", width, height, 1, sizeof(float)).status());
  RETURN_IF_ERROR(
      CheckRange("calib.txt ndisp", ndisp, 1, DecodedImageLimits().max_width));
  c.width = static_cast<int>(width);
  c.height = static_cast<int>(height);
  c.ndisp = static_cast<int>(ndisp);
  // The 2014 data sets' bounds of the disparities, kept in `extra`.
  for (const auto& [key, text] : c.extra) {
    double bound = 0;
    if ((key == "vmin" || key == "vmax") && !ParseFinite(text, &bound)) {
      return missing(key, &text, "a finite number");
    }
  }
  return c;
}

absl::Status WriteCalib(const std::filesystem::path& path, const Calib& calib) {
  return WriteFileAtomically(path, FormatCalib(calib));
}

absl::StatusOr<Calib> ReadCalib(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat(path.string(), ": no calib.txt"));
  }
  ASSIGN_OR_RETURN(const std::string text, ReadFileBytes(path));
  return WithSource(path.string(), ParseCalib(text));
}

cv::Mat MaskFromTruth(const cv::Mat& disparity, const cv::Mat& nonoccluded) {
  const cv::Mat finite =
      (disparity == disparity) &
      (cv::abs(disparity) < std::numeric_limits<float>::infinity());
  cv::Mat mask(disparity.size(), CV_8UC1, cv::Scalar(kMaskUnknown));
  mask.setTo(kMaskOccluded, finite);
  if (nonoccluded.empty()) {
    mask.setTo(kMaskNonOccluded, finite);
  } else {
    mask.setTo(kMaskNonOccluded, finite & (nonoccluded > 0));
  }
  return mask;
}

absl::Status WriteGroundTruth(const std::filesystem::path& dir,
                              const cv::Mat& disp0, const cv::Mat& mask0nocc,
                              const cv::Mat& disp1) {
  if (disp0.type() != CV_32FC1 || mask0nocc.type() != CV_8UC1 ||
      mask0nocc.size() != disp0.size() ||
      (!disp1.empty() &&
       (disp1.type() != CV_32FC1 || disp1.size() != disp0.size()))) {
    return absl::InvalidArgumentError(
        "Middlebury ground truth: disparities must be CV_32FC1 and the mask "
        "CV_8UC1, all of one size");
  }
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat("cannot create ", dir.string(), ": ", ec.message()));
  }
  RETURN_IF_ERROR(WritePfm(dir / kDisparity0File, disp0));
  if (!disp1.empty()) RETURN_IF_ERROR(WritePfm(dir / kDisparity1File, disp1));
  return WritePng(dir / kMask0File, mask0nocc);
}

}  // namespace hdrstereo::io
