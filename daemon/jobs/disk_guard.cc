// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/disk_guard.h"

#include <sys/statvfs.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "daemon/jobs/capture_plan.h"
#include "daemon/store/job_repository.h"
#include "hdrstereo/v1/jobs.pb.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::jobs {

std::string HumanBytes(int64_t bytes) {
  const double b = static_cast<double>(bytes);
  if (b >= 1e9) return absl::StrFormat("%.1f GB", b / 1e9);
  if (b >= 1e6) return absl::StrFormat("%.1f MB", b / 1e6);
  if (b >= 1e3) return absl::StrFormat("%.0f kB", b / 1e3);
  return absl::StrCat(bytes, " B");
}

absl::StatusOr<int64_t> DiskGuard::FreeBytes() const {
  struct statvfs fs;
  const std::string root = store_.files().root().string();
  if (statvfs(root.c_str(), &fs) != 0) {
    return absl::InternalError(
        absl::StrCat("statvfs(", root, "): ", std::strerror(errno)));
  }
  return static_cast<int64_t>(fs.f_bavail) * static_cast<int64_t>(fs.f_frsize);
}

absl::StatusOr<int64_t> DiskGuard::BytesPerFrame(io::CaptureKind kind) const {
  std::optional<int64_t> latest;  // the most recent capture of `kind`
  {
    absl::MutexLock lock(&store_.db().mutex());
    ASSIGN_OR_RETURN(store::Statement stmt, store_.db().Prepare(R"sql(
SELECT c.id FROM captures c JOIN frames f ON f.capture_id = c.id
WHERE c.kind = ?1 ORDER BY c.id DESC LIMIT 1)sql"));
    stmt.Bind(1, io::CaptureKindName(kind));
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (row) latest = stmt.ColumnInt(0);
  }
  int64_t largest = 0;
  if (latest.has_value()) {
    ASSIGN_OR_RETURN(largest, LargestFrame(*latest));
  }
  return largest > 0 ? largest : options_.frame_bytes_guess;
}

absl::StatusOr<int64_t> DiskGuard::LargestFrame(int64_t capture_id) const {
  std::vector<std::pair<std::string, std::string>> frames;  // session, path
  {
    absl::MutexLock lock(&store_.db().mutex());
    ASSIGN_OR_RETURN(store::Statement stmt, store_.db().Prepare(R"sql(
SELECT s.name, f.path FROM frames f
JOIN captures c ON c.id = f.capture_id JOIN sessions s ON s.id = c.session_id
WHERE f.capture_id = ?1 LIMIT 256)sql"));
    stmt.Bind(1, capture_id);
    while (true) {
      ASSIGN_OR_RETURN(bool row, stmt.Step());
      if (!row) break;
      frames.emplace_back(stmt.ColumnText(0), stmt.ColumnText(1));
    }
  }
  int64_t largest = 0;
  for (const auto& [session, path] : frames) {
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(
        store_.files().SessionDir(session) / path, ec);
    if (!ec) largest = std::max(largest, static_cast<int64_t>(size));
  }
  return largest;
}

absl::StatusOr<int64_t> DiskGuard::NeededBytes(io::CaptureKind kind,
                                               int64_t frames) const {
  ASSIGN_OR_RETURN(int64_t per_frame, BytesPerFrame(kind));
  return static_cast<int64_t>(std::ceil(static_cast<double>(frames) *
                                        static_cast<double>(per_frame) *
                                        (1 + options_.processing_headroom))) +
         options_.margin_bytes;
}

absl::Status DiskGuard::CheckRoomFor(io::CaptureKind kind,
                                     int64_t frames) const {
  ASSIGN_OR_RETURN(int64_t free, FreeBytes());
  ASSIGN_OR_RETURN(int64_t pending, PendingCaptureBytes());
  ASSIGN_OR_RETURN(int64_t per_frame, BytesPerFrame(kind));
  ASSIGN_OR_RETURN(int64_t needed, NeededBytes(kind, frames));
  if (free - pending >= needed) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat(
      "not enough disk space: the data root ", store_.files().root().string(),
      " has ", HumanBytes(free), " free",
      pending > 0 ? absl::StrCat(" (", HumanBytes(pending),
                                 " of it promised to queued captures)")
                  : "",
      "; this capture needs about ", HumanBytes(needed), " (", frames,
      " frames of ", HumanBytes(per_frame), ", processing headroom and a ",
      HumanBytes(options_.margin_bytes),
      " margin); free space or use a smaller plan"));
}

absl::Status CheckRestFits(const RestOfPlan& rest, int64_t free,
                           const std::filesystem::path& root) {
  const int64_t needed = rest.NeededBytes();
  if (free >= needed) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat(
      "disk has ", HumanBytes(free), " free on the data root ", root.string(),
      ", the rest of the plan needs ", HumanBytes(needed), " (", rest.frames,
      " frames of ", HumanBytes(rest.bytes_per_frame), " and a ",
      HumanBytes(rest.margin),
      " margin); the capture resumes by itself once space is freed"));
}

absl::Status DiskGuard::CheckRoomForRest(int64_t frames,
                                         int64_t bytes_per_frame) const {
  ASSIGN_OR_RETURN(int64_t free, FreeBytes());
  return CheckRestFits({.frames = frames,
                        .bytes_per_frame = bytes_per_frame,
                        .margin = options_.margin_bytes},
                       free, store_.files().root());
}

absl::StatusOr<int64_t> DiskGuard::PendingCaptureBytes() const {
  store::JobRepository jobs(store_);
  int64_t total = 0;
  for (int64_t after = 0;;) {
    ASSIGN_OR_RETURN(std::vector<store::JobRecord> page,
                     jobs.List({.session = "",
                                .states = {store::JobState::kQueued,
                                           store::JobState::kRunning,
                                           store::JobState::kPaused},
                                .after_id = after,
                                .limit = 500}));
    if (page.empty()) break;
    after = page.back().id;
    for (const store::JobRecord& job : page) {
      v1::CapturePlan plan;
      if (job.kind != store::JobKind::kCapture ||
          !plan.ParseFromString(job.request)) {
        continue;
      }
      int64_t left =
          std::max<int64_t>(0, job.progress_total - job.progress_done);
      // A capture that has not metered its scene yet has no frames to
      // count: it was admitted for the default bracket's, and is promised
      // those until it has chosen.
      if (job.progress_total == 0 && ChoosesExposuresAtTheRig(plan)) {
        left = static_cast<int64_t>(
            ExpandPlan(WithDefaultExposures(plan), {}, 0).size());
      }
      ASSIGN_OR_RETURN(io::CaptureKind kind, PlanKind(plan));
      ASSIGN_OR_RETURN(int64_t needed, NeededBytes(kind, left));
      total += needed - options_.margin_bytes;  // one margin for all
    }
  }
  return total;
}

}  // namespace hdrstereo::jobs
