// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/middlebury.h"

#include <cmath>
#include <limits>
#include <map>
#include <system_error>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
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

std::string Camera(double fx, double fy, double cx, double cy) {
  return absl::StrFormat("[%.6f 0 %.6f; 0 %.6f %.6f; 0 0 1]", fx, cx, fy, cy);
}

// "[fx 0 cx; 0 fy cy; 0 0 1]" -> fx, fy, cx, cy.
bool ParseCamera(absl::string_view text, Calib* calib) {
  std::vector<double> v;
  for (absl::string_view part :
       absl::StrSplit(text, absl::ByAnyChar("[]; "), absl::SkipEmpty())) {
    double x = 0;
    if (!absl::SimpleAtod(part, &x)) return false;
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
      "cam0=%s\ncam1=%s\ndoffs=%g\nbaseline=%.6f\nwidth=%d\nheight=%d\n"
      "ndisp=%d\n",
      Camera(c.fx, c.fy, c.cx, c.cy), Camera(c.fx, c.fy, c.cx + c.doffs, c.cy),
      c.doffs, c.baseline_mm, c.width, c.height, c.ndisp);
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
  auto missing = [](absl::string_view key, absl::string_view what) {
    return absl::InvalidArgumentError(
        absl::StrCat("calib.txt: ", key, " is missing or not ", what));
  };
  auto it = values.find("cam0");
  if (it == values.end() || !ParseCamera(it->second, &c)) {
    return missing("cam0", "[fx 0 cx; 0 fy cy; 0 0 1]");
  }
  if (auto d = values.find("doffs");
      d != values.end() && !absl::SimpleAtod(d->second, &c.doffs)) {
    return missing("doffs", "a number");
  }
  it = values.find("baseline");
  if (it == values.end() || !absl::SimpleAtod(it->second, &c.baseline_mm) ||
      !(c.baseline_mm > 0)) {
    return missing("baseline", "a positive number (mm)");
  }
  for (auto [key, field] : {std::pair{"width", &c.width},
                            {"height", &c.height},
                            {"ndisp", &c.ndisp}}) {
    it = values.find(key);
    if (it == values.end() || !absl::SimpleAtoi(it->second, field) ||
        *field <= 0) {
      return missing(key, "a positive whole number");
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
  absl::StatusOr<Calib> calib = ParseCalib(text);
  if (!calib.ok()) {
    return absl::Status(
        calib.status().code(),
        absl::StrCat(path.string(), ": ", calib.status().message()));
  }
  return calib;
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
