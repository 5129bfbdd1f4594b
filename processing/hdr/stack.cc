// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/hdr/stack.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numeric>
#include <optional>
#include <sstream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "processing/base/status_macros.h"
#include "processing/io/image.h"

namespace hdrstereo::hdr {
namespace {

std::string SizeText(const cv::Mat& m) {
  return absl::StrCat(m.cols, "x", m.rows, "x", m.channels(), " depth ",
                      m.depth());
}

bool IsImageFile(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  static const char* const kExt[] = {".png",  ".jpg", ".jpeg", ".tif",
                                     ".tiff", ".pfm", ".exr",  ".hdr"};
  return io::IsRawExtension(p) ||
         std::find(std::begin(kExt), std::end(kExt), ext) != std::end(kExt);
}

}  // namespace

std::string ExposureStack::Name(size_t i) const {
  if (i < names.size() && !names[i].empty()) return names[i];
  return absl::StrCat("exposure #", i);
}

absl::StatusOr<double> ParseSeconds(const std::string& text) {
  std::string t(absl::StripAsciiWhitespace(text));
  double value = 0;
  std::vector<std::string> parts = absl::StrSplit(t, '/');
  if (parts.size() == 2) {
    double num = 0, den = 0;
    if (!absl::SimpleAtod(parts[0], &num) ||
        !absl::SimpleAtod(parts[1], &den) || den == 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("bad exposure time '", t, "'"));
    }
    value = num / den;
  } else if (parts.size() != 1 || !absl::SimpleAtod(t, &value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("bad exposure time '", t, "'"));
  }
  if (!std::isfinite(value) || value <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("exposure time must be > 0 seconds, got '", t, "'"));
  }
  return value;
}

absl::Status ValidateStack(const ExposureStack& stack) {
  const size_t n = stack.images.size();
  if (n < 2) {
    return absl::InvalidArgumentError(
        absl::StrCat("an exposure stack needs at least 2 exposures, got ", n,
                     n == 1 ? absl::StrCat(" (", stack.Name(0), ")") : ""));
  }
  if (stack.exposure_s.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("stack has ", n, " images but ", stack.exposure_s.size(),
                     " exposure times"));
  }
  const cv::Mat& first = stack.images[0];
  for (size_t i = 0; i < n; ++i) {
    const cv::Mat& m = stack.images[i];
    if (m.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("empty image: ", stack.Name(i)));
    }
    if (m.channels() != 1 && m.channels() != 3) {
      return absl::InvalidArgumentError(absl::StrCat(
          stack.Name(i), " has ", m.channels(), " channels; need 1 or 3"));
    }
    if (m.size() != first.size() || m.type() != first.type()) {
      return absl::InvalidArgumentError(
          absl::StrCat("mismatched image: ", stack.Name(i), " is ", SizeText(m),
                       " but ", stack.Name(0), " is ", SizeText(first)));
    }
    const double t = stack.exposure_s[i];
    if (!std::isfinite(t) || t <= 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("missing or non-positive exposure time for ",
                       stack.Name(i), ": ", t));
    }
  }
  return absl::OkStatus();
}

namespace {

// A stack folder's files in exposures.txt's order, each with its time from
// there; without exposures.txt, its image files sorted by name, times
// unknown until decoded.
using StackEntries =
    std::vector<std::pair<std::filesystem::path, std::optional<double>>>;
absl::StatusOr<StackEntries> ListStack(const std::filesystem::path& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) {
    return absl::NotFoundError(
        absl::StrCat("stack folder not found: ", dir.string()));
  }
  StackEntries entries;
  const std::filesystem::path list = dir / "exposures.txt";
  if (std::filesystem::exists(list, ec)) {
    ASSIGN_OR_RETURN(std::string text, io::ReadFileBytes(list));
    int line_no = 0;
    for (absl::string_view line : absl::StrSplit(text, '\n')) {
      ++line_no;
      line = line.substr(0, line.find('#'));
      std::vector<std::string> fields =
          absl::StrSplit(line, absl::ByAnyChar(" \t\r"), absl::SkipEmpty());
      if (fields.empty()) continue;
      if (fields.size() != 2) {
        return absl::InvalidArgumentError(
            absl::StrCat(list.string(), ":", line_no,
                         ": expected '<file> <seconds>', got '", line, "'"));
      }
      absl::StatusOr<double> t = ParseSeconds(fields[1]);
      if (!t.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat(list.string(), ":", line_no, " (", fields[0],
                         "): ", t.status().message()));
      }
      entries.emplace_back(dir / fields[0], *t);
    }
  } else {
    for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
      if (e.is_regular_file() && IsImageFile(e.path())) {
        entries.emplace_back(e.path(), std::nullopt);
      }
    }
    if (ec) {
      return absl::InternalError(
          absl::StrCat("cannot list ", dir.string(), ": ", ec.message()));
    }
    std::sort(entries.begin(), entries.end());
  }
  return entries;
}

}  // namespace

absl::StatusOr<ExposureStack> LoadStack(const std::filesystem::path& dir) {
  ASSIGN_OR_RETURN(const StackEntries entries, ListStack(dir));
  ExposureStack stack;
  for (const auto& [path, time] : entries) {
    ASSIGN_OR_RETURN(io::DecodedImage img, io::DecodeImageFile(path));
    std::optional<double> t = time ? time : img.metadata.exposure_s;
    if (!t || *t <= 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "missing exposure time for ", path.string(), ": no exposures.txt in ",
          dir.string(), " and no ExposureTime in the file's metadata"));
    }
    if (stack.camera.empty()) stack.camera = img.metadata.camera;
    stack.images.push_back(std::move(img.pixels));
    stack.exposure_s.push_back(*t);
    stack.names.push_back(path.string());
  }
  if (stack.images.size() < 2) {
    return absl::InvalidArgumentError(
        absl::StrCat("an exposure stack needs at least 2 exposures, found ",
                     stack.images.size(), " in ", dir.string()));
  }
  // Longest exposure first.
  std::vector<size_t> order(stack.images.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return stack.exposure_s[a] > stack.exposure_s[b];
  });
  ExposureStack sorted;
  sorted.camera = stack.camera;
  for (size_t i : order) {
    sorted.images.push_back(stack.images[i]);
    sorted.exposure_s.push_back(stack.exposure_s[i]);
    sorted.names.push_back(stack.names[i]);
  }
  RETURN_IF_ERROR(ValidateStack(sorted));
  return sorted;
}

absl::StatusOr<StackImage> LoadStackImage(const std::filesystem::path& dir,
                                          size_t index) {
  ASSIGN_OR_RETURN(StackEntries entries, ListStack(dir));
  const bool timed = std::all_of(entries.begin(), entries.end(),
                                 [](const auto& e) { return e.second; });
  if (!timed) {
    // The times are in the files' metadata: the whole stack it is.
    ASSIGN_OR_RETURN(ExposureStack stack, LoadStack(dir));
    if (index >= stack.images.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("no exposure #", index, " in ", dir.string(),
                       ": it has ", stack.images.size()));
    }
    return StackImage{std::move(stack.images[index]), stack.exposure_s[index]};
  }
  // LoadStack's order: longest exposure first, ties as listed.
  std::stable_sort(
      entries.begin(), entries.end(),
      [](const auto& a, const auto& b) { return *a.second > *b.second; });
  if (index >= entries.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("no exposure #", index, " in ", dir.string(), ": it has ",
                     entries.size()));
  }
  // ParseSeconds took only positive times.
  const auto& [path, time] = entries[index];
  ASSIGN_OR_RETURN(io::DecodedImage img, io::DecodeImageFile(path));
  return StackImage{std::move(img.pixels), *time};
}

}  // namespace hdrstereo::hdr
