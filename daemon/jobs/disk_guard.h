// SPDX-License-Identifier: GPL-3.0-or-later
//
// The disk guard: before a capture is queued, the bytes it will need are
// estimated and compared with the free space on the data root (statvfs), so
// that a night's run is refused at submission rather than found out by the
// write that fails; while it runs, the rest of its plan must still fit.
//
// Bytes per frame: the largest frame file of the most recent capture of the
// same kind (its files as they are on disk); before there is one,
// `frame_bytes_guess`. A running capture uses its own largest frame once it
// has delivered one (FrameSizeEstimate).
//
// Two checks, one estimate:
// - Admission (SubmitCapture, CheckRoomFor): frames x bytes per frame x
//   (1 + processing_headroom) + margin must fit in the free space less what
//   the unfinished captures (queued, running, paused) still need
//   (PendingCaptureBytes): space is promised in submission order.
// - At every frame boundary of the running capture (CheckRoomForRest, one of
//   its suspenders): the frames it has not written yet x bytes per frame +
//   margin must fit in the free space. The promises are not subtracted: the
//   running capture's own is among them (it would be suspended for space
//   promised to itself, for good), and the captures queued behind it were
//   admitted with its need already subtracted (captures run one at a time,
//   in order). Nor is the processing headroom counted: it is for the
//   processing jobs that come later, and a capture is not held for them.
//   So a capture admitted by the first check passes the second unless the
//   space went to something else or its frames are larger than estimated.
#ifndef HDRSTEREO_DAEMON_JOBS_DISK_GUARD_H_
#define HDRSTEREO_DAEMON_JOBS_DISK_GUARD_H_

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "daemon/store/store.h"
#include "processing/io/capture_layout.h"

namespace hdrstereo::jobs {

struct DiskGuardOptions {
  int64_t margin_bytes = int64_t{256} << 20;
  // Processing results (radiance maps, disparities, reports) need about
  // this much again, relative to the frames.
  double processing_headroom = 1.0;
  int64_t frame_bytes_guess = int64_t{32} << 20;  // a 24 MP RAW file
};

// The per-frame size estimate of a running capture: the largest frame it
// has delivered (frames recorded before a restart included) once it has
// one; before that `before_first`, what DiskGuard::BytesPerFrame says for
// its kind.
struct FrameSizeEstimate {
  int64_t before_first = 0;
  int64_t largest_so_far = 0;  // 0: no frame delivered yet

  void Delivered(int64_t frame_bytes) {
    largest_so_far = std::max(largest_so_far, frame_bytes);
  }
  int64_t bytes() const {
    return largest_so_far > 0 ? largest_so_far : before_first;
  }
};

// What the frames a running capture has not written yet need on the data
// root (see the file comment).
struct RestOfPlan {
  int64_t frames = 0;  // not written yet; a frame being written counts
  int64_t bytes_per_frame = 0;
  int64_t margin = 0;

  int64_t NeededBytes() const { return frames * bytes_per_frame + margin; }
};

// OK when `free` bytes on the data root `root` hold `rest`; otherwise
// RESOURCE_EXHAUSTED naming both numbers: "disk has 1.2 GB free on the data
// root R, the rest of the plan needs 2.3 GB (115 frames of 20.0 MB and a
// 0 B margin); ...".
absl::Status CheckRestFits(const RestOfPlan& rest, int64_t free,
                           const std::filesystem::path& root);

class DiskGuard {
 public:
  DiskGuard(store::Store& store, DiskGuardOptions options)
      : store_(store), options_(options) {}

  // Free bytes for an unprivileged writer on the data root's filesystem.
  absl::StatusOr<int64_t> FreeBytes() const;
  // See the file comment.
  absl::StatusOr<int64_t> BytesPerFrame(io::CaptureKind kind) const;
  // The largest frame file of capture `capture_id` on disk; 0 when it has
  // none.
  absl::StatusOr<int64_t> LargestFrame(int64_t capture_id) const;
  absl::StatusOr<int64_t> NeededBytes(io::CaptureKind kind,
                                      int64_t frames) const;
  // RESOURCE_EXHAUSTED with both numbers when `frames` more frames of
  // `kind` do not fit.
  absl::Status CheckRoomFor(io::CaptureKind kind, int64_t frames) const;
  // The disk condition of a running capture at a frame boundary:
  // CheckRestFits for `frames` more frames of `bytes_per_frame` with the
  // guard's margin and the data root's free space.
  absl::Status CheckRoomForRest(int64_t frames, int64_t bytes_per_frame) const;
  // What the unfinished (queued, running, paused) capture jobs still need.
  absl::StatusOr<int64_t> PendingCaptureBytes() const;

 private:
  store::Store& store_;
  const DiskGuardOptions options_;
};

// "1.2 GB", "340 kB": for messages.
std::string HumanBytes(int64_t bytes);

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_DISK_GUARD_H_
