// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/zaber/zaber_stage.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::zaber {
namespace {

// Zaber velocities are in microsteps per 1/1.6384 s.
constexpr double kVelocityUnitsPerMicrostepPerSecond = 1.6384;

}  // namespace

absl::StatusOr<std::unique_ptr<ZaberStage>> ZaberStage::Open(
    const ZaberOptions& options) {
  if (options.microstep_um <= 0 || options.travel_mm <= 0) {
    return absl::InvalidArgumentError(
        "zaber: microstep_um and travel_mm must be positive");
  }
  ASSIGN_OR_RETURN(std::unique_ptr<SerialLine> line,
                   OpenSerialLine(options.port, options.baud_rate));
  std::unique_ptr<ZaberStage> stage(new ZaberStage(options, std::move(line)));

  absl::StatusOr<Reply> speed = stage->Command("get maxspeed");
  if (!speed.ok()) {
    return absl::UnavailableError(
        absl::StrCat("no Zaber device ", options.device, " axis ", options.axis,
                     " on ", options.port, ": ", speed.status().message()));
  }
  double velocity = 0;
  if (!absl::SimpleAtod(speed->data, &velocity) || velocity <= 0) {
    return absl::UnavailableError(absl::StrCat(
        "zaber: unexpected maxspeed \"", speed->data, "\" on ", options.port));
  }
  stage->speed_mm_per_s_ = velocity / kVelocityUnitsPerMicrostepPerSecond *
                           options.microstep_um / 1000.0;
  return stage;
}

int64_t ZaberStage::ToMicrosteps(double mm) const {
  return std::llround(mm * 1000.0 / options_.microstep_um);
}

double ZaberStage::ToMillimetres(int64_t microsteps) const {
  return static_cast<double>(microsteps) * options_.microstep_um / 1000.0;
}

absl::StatusOr<std::string> ZaberStage::ReadLine(absl::Time deadline) {
  while (true) {
    size_t newline = pending_.find('\n');
    if (newline != std::string::npos) {
      std::string line = pending_.substr(0, newline);
      pending_.erase(0, newline + 1);
      return line;
    }
    // A device that never ends its line is garbling, not replying: the
    // buffer stays bounded and Command treats the line as garbage.
    if (pending_.size() > kMaxReplyBytes) {
      const std::string quoted = QuoteInput(pending_);
      pending_.clear();
      return absl::InvalidArgumentError(absl::StrCat(
          "a reply line longer than ", kMaxReplyBytes, " bytes: ", quoted));
    }
    absl::Duration left = deadline - absl::Now();
    if (left <= absl::ZeroDuration()) {
      return absl::DeadlineExceededError("no reply");
    }
    ASSIGN_OR_RETURN(std::string bytes, line_->Read(left));
    pending_ += bytes;
  }
}

absl::StatusOr<Reply> ZaberStage::CommandOnce(absl::string_view command) {
  std::string text = FormatCommand(options_.device, options_.axis, command);
  RETURN_IF_ERROR(line_->Write(text, options_.reply_timeout));
  const absl::Time deadline = absl::Now() + options_.reply_timeout;
  std::string info;  // the last "#" line seen instead of a reply
  while (true) {
    absl::StatusOr<std::string> line = ReadLine(deadline);
    if (!line.ok()) {
      // Info messages only ever follow a reply, so a "#" line and then
      // silence was the reply itself, scrambled into looking like one.
      if (absl::IsDeadlineExceeded(line.status()) && !info.empty()) {
        return ParseReply(info).status();
      }
      return line.status();
    }
    // Info ("#") and alert ("!") messages may arrive between replies.
    if (absl::StartsWith(*line, "#")) {
      info = *line;
      continue;
    }
    if (absl::StartsWith(*line, "!")) continue;
    ASSIGN_OR_RETURN(Reply reply, ParseReply(*line));
    if (reply.device != options_.device || reply.axis != options_.axis) {
      continue;  // another device on the chain
    }
    return reply;
  }
}

absl::StatusOr<Reply> ZaberStage::Command(absl::string_view command) {
  // For messages: the empty command is the bare address, a status request.
  const std::string quoted =
      command.empty() ? absl::StrCat("\"/", options_.device, " ", options_.axis,
                                     "\" (status request)")
                      : absl::StrCat("\"", command, "\"");
  std::lock_guard<std::mutex> lock(mutex_);
  absl::Status last;
  for (int attempt = 0; attempt <= options_.retries; ++attempt) {
    absl::StatusOr<Reply> reply = CommandOnce(command);
    if (reply.ok()) {
      if (reply->rejected) {
        return absl::FailedPreconditionError(absl::StrCat(
            "stage rejected ", quoted, ": ", reply->data,
            reply->warning.empty()
                ? ""
                : absl::StrCat(" (warning ", DescribeWarning(reply->warning),
                               ")")));
      }
      return reply;
    }
    if (absl::IsUnavailable(reply.status())) return reply.status();
    // Missing or garbled reply: drop whatever is buffered and resend.
    last = reply.status();
    pending_.clear();
    line_->DiscardInput();
  }
  if (absl::IsDeadlineExceeded(last)) {
    return absl::DeadlineExceededError(
        absl::StrCat("stage on ", options_.port, " did not answer ", quoted,
                     " within ", absl::FormatDuration(options_.reply_timeout),
                     " (", options_.retries + 1, " tries)"));
  }
  return absl::DataLossError(absl::StrCat("stage on ", options_.port,
                                          " answered ", quoted,
                                          " with garbage: ", last.message()));
}

absl::Status ZaberStage::WaitUntilIdle(absl::Duration timeout,
                                       absl::string_view what,
                                       double target_mm) {
  const absl::Time deadline = absl::Now() + timeout;
  while (true) {
    // An empty command returns the status without doing anything.
    ASSIGN_OR_RETURN(Reply reply, Command(""));
    if (IsFault(reply.warning)) {
      Stop().IgnoreError();
      return absl::AbortedError(absl::StrCat(what, " failed: stage reports ",
                                             DescribeWarning(reply.warning)));
    }
    if (!reply.busy) {
      if (reply.warning == "NI") {
        return absl::AbortedError(absl::StrCat(what, " was interrupted (",
                                               DescribeWarning("NI"), ")"));
      }
      return absl::OkStatus();
    }
    if (absl::Now() >= deadline) {
      Stop().IgnoreError();
      absl::StatusOr<hardware::StageState> state = State();
      return hardware::StalledError(absl::StrFormat(
          "%s did not finish within %s (target %.3f mm, stopped at %s); is "
          "the stage stalled?",
          what, absl::FormatDuration(timeout), target_mm,
          state.ok() ? absl::StrFormat("%.3f mm", state->position_mm)
                     : std::string("an unknown position")));
    }
    absl::SleepFor(options_.poll_interval);
  }
}

absl::Status ZaberStage::Home() {
  ASSIGN_OR_RETURN(Reply reply, Command("home"));
  absl::Duration ideal = absl::Seconds(options_.travel_mm / speed_mm_per_s_);
  return WaitUntilIdle(
      ideal * options_.move_time_factor + options_.move_time_margin, "homing",
      0.0);
}

absl::Status ZaberStage::MoveTo(double position_mm) {
  if (!std::isfinite(position_mm) || position_mm < 0 ||
      position_mm > options_.travel_mm) {
    return absl::InvalidArgumentError(
        absl::StrFormat("stage target %g mm is outside the travel [0, %g] mm",
                        position_mm, options_.travel_mm));
  }
  ASSIGN_OR_RETURN(hardware::StageState before, State());
  ASSIGN_OR_RETURN(Reply reply, Command(absl::StrCat(
                                    "move abs ", ToMicrosteps(position_mm))));
  absl::Duration ideal = absl::Seconds(
      std::abs(position_mm - before.position_mm) / speed_mm_per_s_);
  return WaitUntilIdle(
      ideal * options_.move_time_factor + options_.move_time_margin,
      absl::StrFormat("move to %.3f mm", position_mm), position_mm);
}

absl::StatusOr<hardware::StageState> ZaberStage::State() {
  ASSIGN_OR_RETURN(Reply position, Command("get pos"));
  int64_t microsteps = 0;
  if (!absl::SimpleAtoi(position.data, &microsteps)) {
    return absl::DataLossError(
        absl::StrCat("stage position \"", position.data, "\" is not a number"));
  }
  ASSIGN_OR_RETURN(Reply warnings, Command("warnings"));
  hardware::StageState state;
  state.position_mm = ToMillimetres(microsteps);
  state.busy = position.busy;
  state.warning_flags = ParseWarningFlags(warnings.data);
  state.homed =
      std::find(state.warning_flags.begin(), state.warning_flags.end(), "WR") ==
      state.warning_flags.end();
  return state;
}

absl::Status ZaberStage::Stop() {
  absl::StatusOr<Reply> reply = Command("stop");
  return reply.ok() ? absl::OkStatus() : reply.status();
}

}  // namespace hdrstereo::zaber
