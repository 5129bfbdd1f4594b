// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/gphoto2/settings.h"

#include <arpa/inet.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace hdrstereo::gphoto2 {
namespace {

// A finite, positive decimal number and nothing else.
std::optional<double> ParsePositive(absl::string_view text) {
  if (text.empty()) return std::nullopt;
  for (char c : text) {
    if (!absl::ascii_isdigit(static_cast<unsigned char>(c)) && c != '.') {
      return std::nullopt;
    }
  }
  double value = 0;
  if (!absl::SimpleAtod(text, &value) || !std::isfinite(value) || value <= 0) {
    return std::nullopt;
  }
  return value;
}

std::string Lower(absl::string_view text) {
  return absl::AsciiStrToLower(absl::StripAsciiWhitespace(text));
}

// Localised gphoto2 output writes decimals with a comma ("0,0400s",
// "f/3,5"); a number with one comma and no point is read as a decimal.
std::string PointDecimal(absl::string_view text) {
  std::string out(text);
  if (out.find('.') == std::string::npos &&
      std::count(out.begin(), out.end(), ',') == 1) {
    std::replace(out.begin(), out.end(), ',', '.');
  }
  return out;
}

// PTP cameras report special shutter codes as numbers: Sony's 0xFFFFFFFx
// as the fractions "65535/65535" .. "65535/65533", Nikon's 0xFFFFFFFx
// (in 1/10000 s) as "429496.7295s". Neither is a time; no camera offers a
// timed exposure longer than an hour (Fuji: "60m").
constexpr double kSentinelFractionPart = 65533;
constexpr double kLongestTimedExposureS = 3600;

// 2^(1/2): half a stop.
const double kHalfStop = std::sqrt(2.0);

std::optional<double> ParseShutterText(absl::string_view choice) {
  std::string text = PointDecimal(Lower(choice));
  absl::string_view t = text;
  // Unit suffixes: "1/125s", "2.5 sec", "30 s"; minutes (Fuji): "60m".
  double unit = 1;
  for (absl::string_view suffix : {"sec", "s", "min", "m"}) {
    if (absl::ConsumeSuffix(&t, suffix)) {
      if (suffix == "min" || suffix == "m") unit = 60;
      break;
    }
  }
  t = absl::StripAsciiWhitespace(t);
  if (unit != 1) {
    std::optional<double> minutes = ParsePositive(t);
    if (!minutes.has_value()) return std::nullopt;
    return *minutes * unit;
  }
  // Seconds mark: 30" = 30 s, 1"3 = 1.3 s, 0"5 = 0.5 s.
  size_t quote = t.find('"');
  if (quote != absl::string_view::npos) {
    absl::string_view whole = t.substr(0, quote);
    absl::string_view tenths = t.substr(quote + 1);
    if (tenths.empty()) return ParsePositive(whole);  // 30" or 2.5"
    if (absl::StrContains(whole, '.')) return std::nullopt;
    for (char c : tenths) {
      if (!absl::ascii_isdigit(static_cast<unsigned char>(c))) {
        return std::nullopt;
      }
    }
    if (whole.empty()) return std::nullopt;
    return ParsePositive(absl::StrCat(whole, ".", tenths));  // 1"3
  }
  size_t slash = t.find('/');
  if (slash != absl::string_view::npos) {
    std::optional<double> numerator = ParsePositive(t.substr(0, slash));
    std::optional<double> denominator = ParsePositive(t.substr(slash + 1));
    if (!numerator.has_value() || !denominator.has_value() ||
        *numerator >= kSentinelFractionPart ||
        *denominator >= kSentinelFractionPart) {
      return std::nullopt;
    }
    return *numerator / *denominator;
  }
  return ParsePositive(t);
}

}  // namespace

std::optional<double> ParseShutterSpeed(absl::string_view choice) {
  std::optional<double> seconds = ParseShutterText(choice);
  if (!seconds.has_value() || *seconds > kLongestTimedExposureS) {
    return std::nullopt;
  }
  return seconds;
}

bool IsBulb(absl::string_view choice) { return Lower(choice) == "bulb"; }

std::string FormatSeconds(double seconds) {
  if (seconds > 0 && seconds < 0.25) {
    double denominator = 1.0 / seconds;
    if (std::abs(denominator - std::round(denominator)) < 0.01 * denominator) {
      return absl::StrCat("1/", std::llround(denominator), " s");
    }
  }
  return absl::StrCat(absl::StrFormat("%g", seconds), " s");
}

std::vector<ShutterChoice> TimedShutterChoices(
    const std::vector<std::string>& choices) {
  std::vector<ShutterChoice> timed;
  for (const std::string& choice : choices) {
    if (IsBulb(choice)) continue;
    std::optional<double> seconds = ParseShutterSpeed(choice);
    if (seconds.has_value()) timed.push_back({choice, *seconds});
  }
  return timed;
}

absl::StatusOr<ShutterChoice> NearestShutterSpeed(
    const std::vector<std::string>& choices, double seconds) {
  if (!(seconds > 0) || !std::isfinite(seconds)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "exposure must be a positive number of seconds, not ", seconds));
  }
  std::vector<ShutterChoice> timed = TimedShutterChoices(choices);
  if (timed.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("the camera offers no timed shutter speed (choices: ",
                     JoinChoices(choices), ")"));
  }
  double shortest = std::numeric_limits<double>::infinity();
  double longest = 0;
  const ShutterChoice* best = nullptr;
  double best_distance = std::numeric_limits<double>::infinity();
  for (const ShutterChoice& choice : timed) {
    shortest = std::min(shortest, choice.seconds);
    longest = std::max(longest, choice.seconds);
    double distance = std::abs(std::log2(choice.seconds / seconds));
    if (best == nullptr || distance < best_distance - 1e-9 ||
        (std::abs(distance - best_distance) <= 1e-9 &&
         choice.seconds < best->seconds)) {
      best = &choice;
      best_distance = distance;
    }
  }
  if (seconds < shortest / kHalfStop || seconds > longest * kHalfStop) {
    return absl::InvalidArgumentError(
        absl::StrCat("exposure ", FormatSeconds(seconds),
                     " is outside the camera's range ", FormatSeconds(shortest),
                     " .. ", FormatSeconds(longest), " (bulb is not used)"));
  }
  return *best;
}

std::optional<int> ParseIso(absl::string_view choice) {
  std::string text = Lower(choice);
  absl::string_view t = text;
  absl::ConsumePrefix(&t, "iso");
  absl::ConsumeSuffix(&t, "iso");
  t = absl::StripAsciiWhitespace(t);
  int iso = 0;
  if (t.empty() || !absl::ascii_isdigit(static_cast<unsigned char>(t[0])) ||
      !absl::SimpleAtoi(t, &iso) || iso <= 0) {
    return std::nullopt;
  }
  return iso;
}

absl::StatusOr<std::string> MatchIso(const std::vector<std::string>& choices,
                                     int iso) {
  for (const std::string& choice : choices) {
    if (ParseIso(choice) == iso) return choice;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("the camera does not offer ISO ", iso,
                   "; choices: ", JoinChoices(choices)));
}

std::optional<double> ParseAperture(absl::string_view choice) {
  std::string text = PointDecimal(Lower(choice));
  absl::string_view t = text;
  if (!absl::ConsumePrefix(&t, "f/")) absl::ConsumePrefix(&t, "f");
  return ParsePositive(absl::StripAsciiWhitespace(t));
}

absl::StatusOr<std::string> MatchAperture(
    const std::vector<std::string>& choices, double f_number) {
  const std::string* best = nullptr;
  double best_error = 0.03;
  for (const std::string& choice : choices) {
    std::optional<double> value = ParseAperture(choice);
    if (!value.has_value()) continue;
    double error = std::abs(*value - f_number) / f_number;
    if (error <= best_error) {
      best = &choice;
      best_error = error;
    }
  }
  if (best == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("the camera (lens) does not offer f/", f_number,
                     "; choices: ", JoinChoices(choices)));
  }
  return *best;
}

std::optional<hardware::ImageFormat> ClassifyFormatChoice(
    absl::string_view choice) {
  std::string text = Lower(choice);
  const bool raw = absl::StrContains(text, "raw") ||
                   absl::StrContains(text, "nef") ||
                   absl::StrContains(text, "dng");
  const bool jpeg =
      absl::StrContains(text, "jpeg") || absl::StrContains(text, "jpg") ||
      absl::StrContains(text, "fine") || absl::StrContains(text, "fein") ||
      absl::StrContains(text, "normal") || absl::StrContains(text, "basic") ||
      absl::StrContains(text, "standard");
  if (raw && jpeg) return hardware::ImageFormat::kRawAndJpeg;
  if (raw) return hardware::ImageFormat::kRaw;
  if (jpeg) return hardware::ImageFormat::kJpeg;
  return std::nullopt;
}

namespace {

// Higher is better: full-size RAW ("RAW", "NEF (Raw)", "RAW + ...") before
// reduced ones ("mRAW", "sRAW") and compressed ones ("cRAW").
int RawScore(const std::string& lower) {
  if (lower == "raw") return 3;
  if (absl::StartsWith(lower, "raw") || absl::StartsWith(lower, "nef")) {
    return 2;
  }
  if (absl::StartsWith(lower, "craw")) return 1;
  return 0;
}

// Higher is better: the largest size, then the finest quality.
int JpegScore(const std::string& lower) {
  int size = 2;  // no size word: full size
  if (absl::StrContains(lower, "medium")) size = 1;
  if (absl::StrContains(lower, "small") || absl::StrContains(lower, "tiny")) {
    size = 0;
  }
  int quality = 1;
  if (absl::StrContains(lower, "basic")) quality = 0;
  if (absl::StrContains(lower, "fine") || absl::StrContains(lower, "fein")) {
    quality = 2;
  }
  if (absl::StrContains(lower, "extra fine")) quality = 3;
  return size * 10 + quality;
}

}  // namespace

absl::StatusOr<std::string> MatchFormatChoice(
    const std::vector<std::string>& choices, hardware::ImageFormat format) {
  if (format != hardware::ImageFormat::kJpeg &&
      format != hardware::ImageFormat::kRaw &&
      format != hardware::ImageFormat::kRawAndJpeg) {
    return absl::InvalidArgumentError(
        absl::StrCat("a camera cannot produce ", ImageFormatName(format),
                     "; use raw, jpeg or raw+jpeg"));
  }
  const std::string* best = nullptr;
  int best_score = -1;
  for (const std::string& choice : choices) {
    if (ClassifyFormatChoice(choice) != format) continue;
    std::string lower = Lower(choice);
    int score = 0;
    if (format == hardware::ImageFormat::kRaw) score = RawScore(lower);
    if (format == hardware::ImageFormat::kJpeg) score = JpegScore(lower);
    if (format == hardware::ImageFormat::kRawAndJpeg) {
      score = RawScore(lower) * 100 + JpegScore(lower);
    }
    if (score > best_score) {
      best = &choice;
      best_score = score;
    }
  }
  if (best == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("the camera offers no ", ImageFormatName(format),
                     " image format; choices: ", JoinChoices(choices)));
  }
  return *best;
}

std::string FileExtension(absl::string_view name) {
  size_t dot = name.rfind('.');
  if (dot == absl::string_view::npos || dot + 1 == name.size()) return "";
  return absl::AsciiStrToLower(name.substr(dot + 1));
}

std::optional<hardware::ImageFormat> FormatFromFileName(
    absl::string_view name) {
  std::string extension = FileExtension(name);
  if (extension == "jpg" || extension == "jpeg") {
    return hardware::ImageFormat::kJpeg;
  }
  // What the simulated network camera sends (hardware/sim/ptpip_camera.h);
  // the capture job checks each frame's depth when it decodes it.
  if (extension == "png") return hardware::ImageFormat::kPng8;
  if (extension == "tif" || extension == "tiff") {
    return hardware::ImageFormat::kTiff16;
  }
  for (absl::string_view raw :
       {"cr2", "cr3", "crw", "nef", "nrw", "arw", "srf", "sr2",
        "dng", "raf", "orf", "rw2", "pef", "srw", "3fr", "iiq",
        "erf", "kdc", "dcr", "mrw", "x3f", "raw"}) {
    if (extension == raw) return hardware::ImageFormat::kRaw;
  }
  return std::nullopt;
}

bool IsNetworkPort(absl::string_view port) {
  return absl::StartsWith(port, "ptpip:");
}

absl::StatusOr<std::string> NormalizeCameraPort(absl::string_view port) {
  if (!absl::StartsWith(port, "ptpip:")) return std::string(port);
  const std::vector<absl::string_view> parts =
      absl::StrSplit(port.substr(6), ':');
  in_addr address{};
  if (parts.size() > 3 ||
      inet_pton(AF_INET, std::string(parts[0]).c_str(), &address) != 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "camera port \"", port,
        "\": a PTP/IP camera is ptpip:ADDRESS[:PORT], ADDRESS an IPv4 "
        "address (libgphoto2 looks up no host names)"));
  }
  for (size_t i = 1; i < parts.size(); ++i) {
    int number = 0;
    if (!absl::SimpleAtoi(parts[i], &number) || number < 1 || number > 65535) {
      return absl::InvalidArgumentError(
          absl::StrCat("camera port \"", port, "\": \"", parts[i],
                       "\" is not a TCP port (1-65535)"));
    }
  }
  if (parts.size() == 2) return absl::StrCat(port, ":", parts[1]);
  return std::string(port);
}

absl::StatusOr<CaptureTarget> ParseCaptureTarget(absl::string_view text) {
  std::string lower = Lower(text);
  if (lower.empty()) return CaptureTarget::kLeaveAsIs;
  if (lower == "ram") return CaptureTarget::kInternalRam;
  if (lower == "card") return CaptureTarget::kMemoryCard;
  return absl::InvalidArgumentError(absl::StrCat(
      "capture target must be \"ram\", \"card\" or empty, not \"", text, "\""));
}

namespace {

// Words of capture-target choices, English and German ("Internal RAM",
// "sdram", "interner Speicher"; "Memory card", "Speicherkarte").
bool MeansRam(const std::string& lower) {
  return absl::StrContains(lower, "ram") || absl::StrContains(lower, "intern");
}
bool MeansCard(const std::string& lower) {
  return absl::StrContains(lower, "card") || absl::StrContains(lower, "karte");
}

}  // namespace

absl::StatusOr<std::string> MatchCaptureTarget(
    const std::vector<std::string>& choices, CaptureTarget target) {
  const bool ram = target == CaptureTarget::kInternalRam;
  absl::string_view wanted = ram ? "ram" : "card";
  // "card+sdram" is both; a choice that is only the one wanted comes first.
  const std::string* both = nullptr;
  for (const std::string& choice : choices) {
    const std::string lower = Lower(choice);
    const bool is_ram = MeansRam(lower), is_card = MeansCard(lower);
    if (ram ? !is_ram : !is_card) continue;
    if (is_ram != is_card) return choice;
    if (both == nullptr) both = &choice;
  }
  if (both != nullptr) return *both;
  return absl::InvalidArgumentError(
      absl::StrCat("the camera offers no capture target like \"", wanted,
                   "\"; choices: ", JoinChoices(choices)));
}

bool CaptureTargetIsRam(absl::string_view choice) {
  const std::string lower = Lower(choice);
  return MeansRam(lower) && !MeansCard(lower);
}

int ParseBatteryPercent(absl::string_view value) {
  std::string text = Lower(value);
  absl::string_view t = text;
  if (absl::ConsumeSuffix(&t, "%")) {
    int percent = 0;
    if (absl::SimpleAtoi(absl::StripAsciiWhitespace(t), &percent) &&
        percent >= 0 && percent <= 100) {
      return percent;
    }
    return -1;
  }
  if (t == "full") return 100;
  if (t == "half") return 50;
  if (t == "low") return 10;
  if (t == "empty") return 0;
  return -1;
}

std::string JoinChoices(const std::vector<std::string>& choices) {
  if (choices.empty()) return "(none)";
  return absl::StrCat("\"", absl::StrJoin(choices, "\", \""), "\"");
}

}  // namespace hdrstereo::gphoto2
