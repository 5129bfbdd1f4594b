// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/zaber/protocol.h"

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "processing/base/input_limits.h"

namespace hdrstereo::zaber {

std::string FormatCommand(int device, int axis, absl::string_view command) {
  if (command.empty()) return absl::StrCat("/", device, " ", axis, "\n");
  return absl::StrCat("/", device, " ", axis, " ", command, "\n");
}

absl::StatusOr<Reply> ParseReply(absl::string_view line) {
  const absl::string_view received = absl::StripTrailingAsciiWhitespace(line);
  auto bad = [&](absl::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat(
        "malformed Zaber reply ", QuoteInput(received), ": ", why));
  };
  if (received.size() > kMaxReplyBytes) {
    return bad(absl::StrCat("the reply is ", received.size(),
                            " bytes long; the most is ", kMaxReplyBytes));
  }
  absl::string_view text = received;
  if (!absl::ConsumePrefix(&text, "@")) return bad("does not start with @");
  std::vector<absl::string_view> fields =
      absl::StrSplit(text, ' ', absl::SkipEmpty());
  if (fields.size() < 5) return bad("fewer than 5 fields");
  Reply reply;
  if (!absl::SimpleAtoi(fields[0], &reply.device) ||
      !absl::SimpleAtoi(fields[1], &reply.axis)) {
    return bad("device or axis is not a number");
  }
  if (reply.device < 1 || reply.device > kMaxDevice) {
    return bad(absl::StrCat("device ", reply.device, " is outside [1, ",
                            kMaxDevice, "]"));
  }
  if (reply.axis < 0 || reply.axis > kMaxAxis) {
    return bad(
        absl::StrCat("axis ", reply.axis, " is outside [0, ", kMaxAxis, "]"));
  }
  if (fields[2] == "OK") {
    reply.rejected = false;
  } else if (fields[2] == "RJ") {
    reply.rejected = true;
  } else {
    return bad("reply flag is neither OK nor RJ");
  }
  if (fields[3] == "BUSY") {
    reply.busy = true;
  } else if (fields[3] != "IDLE") {
    return bad("status is neither BUSY nor IDLE");
  }
  if (fields[4].size() != 2) return bad("warning flag is not 2 characters");
  if (fields[4] != "--") reply.warning = std::string(fields[4]);
  for (size_t i = 5; i < fields.size(); ++i) {
    if (i > 5) reply.data += ' ';
    absl::StrAppend(&reply.data, fields[i]);
  }
  return reply;
}

std::vector<std::string> ParseWarningFlags(absl::string_view data) {
  std::vector<std::string> flags;
  bool count = true;  // the first field is the count
  for (absl::string_view field : absl::StrSplit(data, ' ', absl::SkipEmpty())) {
    if (flags.size() == kMaxWarningFlags) break;
    if (!count && field.size() == 2) flags.emplace_back(field);
    count = false;
  }
  return flags;
}

std::string DescribeWarning(absl::string_view flag) {
  struct Known {
    absl::string_view flag;
    absl::string_view meaning;
  };
  static constexpr Known kKnown[] = {
      {"FS", "stalled and stopped (obstruction or overload)"},
      {"FD", "driver disabled (over-temperature or supply out of range)"},
      {"FQ", "encoder error"},
      {"FZ", "peripheral inactive"},
      {"WR", "no reference position (not homed): home the stage"},
      {"WL", "unexpected limit trigger"},
      {"WH", "device temperature high"},
      {"WV", "supply voltage out of range"},
      {"WT", "system temperature high"},
      {"WM", "displaced while idle"},
      {"NC", "manual control active"},
      {"NI", "movement interrupted by a new command"},
      {"ND", "stream discontinuity"},
      {"NU", "setting update pending"},
      {"NJ", "joystick calibrating"},
  };
  for (const Known& known : kKnown) {
    if (known.flag == flag) {
      return absl::StrCat(flag, " (", known.meaning, ")");
    }
  }
  return std::string(flag);
}

bool IsFault(absl::string_view flag) { return !flag.empty() && flag[0] == 'F'; }

}  // namespace hdrstereo::zaber
