// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/gphoto2/config_dump.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"

namespace hdrstereo::gphoto2 {
namespace {

constexpr absl::string_view kReplacement = "\xEF\xBF\xBD";  // U+FFFD

// Length of the valid UTF-8 sequence at the start of `s`, 0 if invalid.
size_t Utf8SequenceLength(absl::string_view s) {
  const auto b = [&](size_t i) { return static_cast<unsigned char>(s[i]); };
  const unsigned char c = b(0);
  size_t n = c < 0x80           ? 1
             : (c >> 5) == 0x6  ? 2
             : (c >> 4) == 0xE  ? 3
             : (c >> 3) == 0x1E ? 4
                                : 0;
  if (n == 0 || n > s.size()) return 0;
  for (size_t i = 1; i < n; ++i) {
    if ((b(i) & 0xC0) != 0x80) return 0;
  }
  // Overlong forms, surrogates and code points above U+10FFFF.
  if (n == 2 && c < 0xC2) return 0;
  if (n == 3 && ((c == 0xE0 && b(1) < 0xA0) || (c == 0xED && b(1) >= 0xA0))) {
    return 0;
  }
  if (n == 4 &&
      ((c == 0xF0 && b(1) < 0x90) || c > 0xF4 || (c == 0xF4 && b(1) >= 0x90))) {
    return 0;
  }
  return n;
}

// A number as gphoto2 prints it in any locale: "655,35", "4,29497e+09".
std::optional<float> ParseNumber(absl::string_view text) {
  std::string t(absl::StripAsciiWhitespace(text));
  if (t.find('.') == std::string::npos) {
    std::replace(t.begin(), t.end(), ',', '.');
  }
  float value = 0;
  if (!absl::SimpleAtof(t, &value) || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

std::optional<WidgetType> ParseType(absl::string_view text) {
  static const std::pair<absl::string_view, WidgetType> kTypes[] = {
      {"TEXT", WidgetType::kText},     {"RANGE", WidgetType::kRange},
      {"TOGGLE", WidgetType::kToggle}, {"RADIO", WidgetType::kRadio},
      {"MENU", WidgetType::kMenu},     {"DATE", WidgetType::kDate},
      {"BUTTON", WidgetType::kButton}};
  for (const auto& [name, type] : kTypes) {
    if (text == name) return type;
  }
  return std::nullopt;
}

// "Key: value" -> key and value (the value as written, after one space).
bool SplitField(absl::string_view line, absl::string_view* key,
                absl::string_view* value) {
  const size_t colon = line.find(':');
  if (colon == absl::string_view::npos || colon == 0) return false;
  *key = line.substr(0, colon);
  for (char c : *key) {
    if (!absl::ascii_isalpha(static_cast<unsigned char>(c))) return false;
  }
  *value = line.substr(colon + 1);
  absl::ConsumePrefix(value, " ");
  return true;
}

// The summary's "Key: value" line for one of `keys`, stripped.
std::string SummaryField(absl::string_view summary,
                         std::initializer_list<absl::string_view> keys) {
  for (absl::string_view line : absl::StrSplit(summary, '\n')) {
    for (absl::string_view key : keys) {
      absl::string_view rest = line;
      if (absl::ConsumePrefix(&rest, key) && absl::ConsumePrefix(&rest, ":")) {
        return std::string(absl::StripAsciiWhitespace(rest));
      }
    }
  }
  return "";
}

struct Entry {
  ConfigWidget widget;
  int line = 0;  // of the path
  bool has_type = false;
  std::optional<float> bottom, top, step;
  std::string range_value;
};

absl::Status Finish(const std::string& source, Entry& entry) {
  const std::string where =
      absl::StrCat(source, ":", entry.line, ": ", entry.widget.path);
  if (entry.widget.type == WidgetType::kRange) {
    if (!entry.bottom || !entry.top || !entry.step) {
      return absl::InvalidArgumentError(absl::StrCat(
          where, " is a RANGE without numeric Bottom, Top and Step"));
    }
    entry.widget.min = *entry.bottom;
    entry.widget.max = *entry.top;
    entry.widget.step = *entry.step;
    // As the library gives it: the float, printed "%g".
    std::optional<float> current = ParseNumber(entry.range_value);
    entry.widget.value =
        current ? absl::StrFormat("%g", *current) : entry.range_value;
  }
  return absl::OkStatus();
}

// INVALID_ARGUMENT for a text or a line longer than the limits, checked on
// the bytes as received (before invalid UTF-8 grows into U+FFFD).
absl::Status CheckSizes(absl::string_view text, absl::string_view source) {
  if (text.size() > kMaxDumpBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": the dump is ", text.size(),
                     " bytes; the most is ", kMaxDumpBytes));
  }
  int line_no = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_no;
    if (line.size() > kMaxDumpLineBytes) {
      return absl::InvalidArgumentError(
          absl::StrCat(source, ":", line_no, ": the line is ", line.size(),
                       " bytes long; the most is ", kMaxDumpLineBytes));
    }
  }
  return absl::OkStatus();
}

}  // namespace

std::string ValidUtf8(absl::string_view text) {
  std::string out;
  out.reserve(text.size());
  while (!text.empty()) {
    const size_t n = Utf8SequenceLength(text);
    if (n == 0) {
      absl::StrAppend(&out, kReplacement);
      text.remove_prefix(1);
    } else {
      absl::StrAppend(&out, text.substr(0, n));
      text.remove_prefix(n);
    }
  }
  return out;
}

absl::StatusOr<CameraDump> ParseCameraDump(absl::string_view raw_text,
                                           absl::string_view source) {
  RETURN_IF_ERROR(CheckSizes(raw_text, source));
  const std::string text = ValidUtf8(raw_text);
  CameraDump dump;
  dump.source = std::string(source);
  std::set<std::string> seen;
  std::optional<Entry> entry;
  bool in_tree = false;
  int line_no = 0;
  int64_t entries = 0;
  auto close = [&]() -> absl::Status {
    if (!entry.has_value()) return absl::OkStatus();
    if (!entry->has_type) {
      // A path-only listing (`--list-config`) or a truncated entry.
      dump.skipped.push_back(
          absl::StrCat(entry->widget.path, " (line ", entry->line, ")"));
      entry.reset();
      return absl::OkStatus();
    }
    absl::Status status = Finish(dump.source, *entry);
    if (status.ok() && seen.insert(entry->widget.path).second) {
      dump.widgets.push_back(std::move(entry->widget));
    }
    entry.reset();
    return status;
  };
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_no;
    absl::ConsumeSuffix(&line, "\r");
    if (absl::StartsWith(line, "/main/")) {
      RETURN_IF_ERROR(close());
      if (++entries > kMaxDumpEntries) {
        return absl::InvalidArgumentError(
            absl::StrCat(dump.source, ":", line_no, ": more than ",
                         kMaxDumpEntries, " config entries"));
      }
      // The path ends at the first blank (some dumps pad it with U+00A0).
      const absl::string_view path =
          line.substr(0, line.find_first_of(" \t\xC2"));
      if (path.size() > kMaxWidgetPathBytes) {
        return absl::InvalidArgumentError(absl::StrCat(
            dump.source, ":", line_no, ": the path ", QuoteInput(path), " is ",
            path.size(), " bytes long; the most is ", kMaxWidgetPathBytes));
      }
      in_tree = true;
      entry.emplace();
      entry->line = line_no;
      entry->widget.path = std::string(path);
      entry->widget.name =
          entry->widget.path.substr(entry->widget.path.rfind('/') + 1);
      continue;
    }
    if (!in_tree) {
      absl::StrAppend(&dump.summary, line, "\n");
      continue;
    }
    if (!entry.has_value()) continue;
    // Older gphoto2 versions indent the fields with a tab; some dumps have
    // a blank line between the path and its fields.
    line = absl::StripLeadingAsciiWhitespace(line);
    if (line.empty() && !entry->has_type && entry->widget.label.empty()) {
      continue;
    }
    absl::string_view key, value;
    if (line == "END" || !SplitField(line, &key, &value)) {
      RETURN_IF_ERROR(close());
      continue;
    }
    ConfigWidget& w = entry->widget;
    const std::string where =
        absl::StrCat(dump.source, ":", line_no, ": ", w.path);
    if (key == "Label") {
      w.label = std::string(value);
    } else if (key == "Readonly") {
      w.read_only = absl::StripAsciiWhitespace(value) == "1";
    } else if (key == "Type") {
      std::optional<WidgetType> type =
          ParseType(absl::StripAsciiWhitespace(value));
      if (!type.has_value()) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": unknown widget Type ", QuoteInput(value),
                         " (expected RADIO, MENU, RANGE, TEXT, TOGGLE, "
                         "DATE or BUTTON)"));
      }
      w.type = *type;
      entry->has_type = true;
    } else if (key == "Current") {
      w.value = value == "(null)" ? "" : std::string(value);
      entry->range_value = w.value;
    } else if (key == "Choice") {
      const size_t space = value.find(' ');
      int index = 0;
      if (!absl::SimpleAtoi(value.substr(0, space), &index)) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": malformed Choice line ", QuoteInput(line),
                         " (expected \"Choice: <number> <text>\")"));
      }
      if (static_cast<int64_t>(w.choices.size()) >= kMaxWidgetChoices) {
        return absl::InvalidArgumentError(absl::StrCat(
            where, ": more than ", kMaxWidgetChoices, " Choice lines"));
      }
      w.choices.push_back(space == absl::string_view::npos
                              ? std::string()
                              : std::string(value.substr(space + 1)));
    } else if (key == "Bottom") {
      entry->bottom = ParseNumber(value);
    } else if (key == "Top") {
      entry->top = ParseNumber(value);
    } else if (key == "Step") {
      entry->step = ParseNumber(value);
    }
    // Printable, Help and other informational lines are skipped.
  }
  RETURN_IF_ERROR(close());
  if (dump.widgets.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        dump.source,
        dump.skipped.empty() ? ": no --list-all-config tree (no /main/... "
                               "entries)"
                             : ": only paths, no widget types or values (a "
                               "`--list-config` listing?)",
        "; record one with `gphoto2 --summary --list-all-config`"));
  }
  const std::string maker =
      SummaryField(dump.summary, {"Manufacturer", "Hersteller"});
  const std::string model = SummaryField(dump.summary, {"Model", "Modell"});
  if (!model.empty()) {
    dump.model = maker.empty() || absl::StartsWith(model, maker)
                     ? model
                     : absl::StrCat(maker, " ", model);
  } else {
    for (const ConfigWidget& w : dump.widgets) {
      if (w.name == "cameramodel" && !w.value.empty()) dump.model = w.value;
    }
  }
  if (dump.model.empty()) {
    dump.model = std::filesystem::path(dump.source).stem().string();
  }
  return dump;
}

absl::StatusOr<CameraDump> LoadCameraDump(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(const std::string text,
                   io::ReadFileBytes(path, kMaxDumpBytes, "camera dump"));
  return ParseCameraDump(text, path.string());
}

}  // namespace hdrstereo::gphoto2
