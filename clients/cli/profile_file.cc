// SPDX-License-Identifier: GPL-3.0-or-later
#include "clients/cli/profile_file.h"

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "processing/base/input_limits.h"
#include "processing/io/atomic_file.h"

namespace hdrstereo::cli {
namespace {

constexpr absl::string_view kProfileSection = "profile.";

// A TOML basic string ("..." with \" and \\ escapes), the whole value.
absl::StatusOr<std::string> ParseString(absl::string_view value) {
  if (value.size() < 2 || value.front() != '"' || value.back() != '"') {
    return absl::InvalidArgumentError("the value must be a \"quoted string\"");
  }
  std::string out;
  for (size_t i = 1; i + 1 < value.size(); ++i) {
    char c = value[i];
    if (c == '"') {
      return absl::InvalidArgumentError("unexpected '\"' inside the string");
    }
    if (c == '\\') {
      if (i + 2 >= value.size() ||
          (value[i + 1] != '"' && value[i + 1] != '\\')) {
        return absl::InvalidArgumentError(
            "only \\\" and \\\\ escapes are supported");
      }
      c = value[++i];
    }
    out.push_back(c);
  }
  return out;
}

// The line without a comment ('#' outside a string).
absl::string_view StripComment(absl::string_view line) {
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    if (line[i] == '\\' && quoted) {
      ++i;
    } else if (line[i] == '"') {
      quoted = !quoted;
    } else if (line[i] == '#' && !quoted) {
      return line.substr(0, i);
    }
  }
  return line;
}

std::string* ProfileField(Profile& profile, absl::string_view key) {
  if (key == "server") return &profile.server;
  if (key == "tls_ca") return &profile.tls_ca;
  if (key == "tls_cert") return &profile.tls_cert;
  if (key == "tls_key") return &profile.tls_key;
  if (key == "api_key_file") return &profile.api_key_file;
  return nullptr;
}

}  // namespace

absl::StatusOr<ProfileFile> ParseProfileFile(const std::string& path,
                                             absl::string_view text) {
  if (text.size() > kMaxProfileFileBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": the file is ", text.size(),
                     " bytes; the most is ", kMaxProfileFileBytes));
  }
  ProfileFile file;
  Profile* section = nullptr;  // nullptr: the top level
  std::string section_name;
  int number = 0;
  for (absl::string_view raw : absl::StrSplit(text, '\n')) {
    ++number;
    auto error = [&](absl::string_view message) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ":", number, ": ", message));
    };
    // Every line's parts that a message repeats are within this limit.
    if (raw.size() > kMaxProfileLineBytes) {
      return error(absl::StrCat("the line is ", raw.size(),
                                " bytes long; the most is ",
                                kMaxProfileLineBytes));
    }
    const absl::string_view line =
        absl::StripAsciiWhitespace(StripComment(raw));
    if (line.empty()) continue;
    if (line.front() == '[') {
      if (line.back() != ']') return error("a section header ends with ']'");
      section_name = std::string(
          absl::StripAsciiWhitespace(line.substr(1, line.size() - 2)));
      const std::string name = absl::StartsWith(section_name, kProfileSection)
                                   ? section_name.substr(kProfileSection.size())
                                   : "";
      if (name.empty()) {
        return error(absl::StrCat("unknown section ", QuoteInput(section_name),
                                  "; profiles are [profile.NAME]"));
      }
      if (file.profiles.count(name) != 0) {
        return error(absl::StrCat("section ", QuoteInput(section_name),
                                  " appears twice"));
      }
      section = &file.profiles[name];
      continue;
    }
    const size_t equals = line.find('=');
    if (equals == absl::string_view::npos) {
      return error("expected key = \"value\"");
    }
    const std::string key(absl::StripAsciiWhitespace(line.substr(0, equals)));
    absl::StatusOr<std::string> value =
        ParseString(absl::StripAsciiWhitespace(line.substr(equals + 1)));
    if (!value.ok())
      return error(
          absl::StrCat(QuoteInput(key), ": ", value.status().message()));
    std::string* field = nullptr;
    if (section == nullptr) {
      if (key != "default_profile") {
        return error(absl::StrCat("unknown key ", QuoteInput(key),
                                  " (the top level knows default_profile; "
                                  "settings go in a [profile.NAME] section)"));
      }
      field = &file.default_profile;
    } else {
      field = ProfileField(*section, key);
      if (field == nullptr) {
        return error(absl::StrCat("unknown key ", QuoteInput(key),
                                  " in section ", QuoteInput(section_name),
                                  "; known: server, tls_ca, tls_cert, "
                                  "tls_key, api_key_file"));
      }
    }
    if (!field->empty()) return error(absl::StrCat(key, " is set twice"));
    *field = *std::move(value);
  }
  if (!file.default_profile.empty() &&
      file.profiles.count(file.default_profile) == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": default_profile ", QuoteInput(file.default_profile),
        " has no section ",
        QuoteInput(absl::StrCat(kProfileSection, file.default_profile))));
  }
  return file;
}

absl::StatusOr<ProfileFile> LoadProfileFile(const std::filesystem::path& path) {
  absl::StatusOr<std::string> text =
      io::ReadFileBytes(path, kMaxProfileFileBytes, "profile file");
  if (!text.ok()) return absl::InvalidArgumentError(text.status().message());
  return ParseProfileFile(path.string(), *text);
}

}  // namespace hdrstereo::cli
