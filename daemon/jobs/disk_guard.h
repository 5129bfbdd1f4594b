// SPDX-License-Identifier: GPL-3.0-or-later
//
// The disk guard: before a capture is queued, the bytes it will need are
// estimated and compared with the free space on the data root (statvfs), so
// that a night's run is refused at submission rather than found out by the
// write that fails.
//
// Needed bytes = frames x bytes per frame x (1 + processing_headroom)
//                + margin.
// Bytes per frame: the largest frame file of the most recent capture of the
// same kind (its files as they are on disk); before there is one,
// `frame_bytes_guess`.
#ifndef HDRSTEREO_DAEMON_JOBS_DISK_GUARD_H_
#define HDRSTEREO_DAEMON_JOBS_DISK_GUARD_H_

#include <cstdint>

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

class DiskGuard {
 public:
  DiskGuard(store::Store& store, DiskGuardOptions options)
      : store_(store), options_(options) {}

  // Free bytes for an unprivileged writer on the data root's filesystem.
  absl::StatusOr<int64_t> FreeBytes() const;
  // See the file comment.
  absl::StatusOr<int64_t> BytesPerFrame(io::CaptureKind kind) const;
  absl::StatusOr<int64_t> NeededBytes(io::CaptureKind kind,
                                      int64_t frames) const;
  // RESOURCE_EXHAUSTED with both numbers when `frames` more frames of
  // `kind` do not fit.
  absl::Status CheckRoomFor(io::CaptureKind kind, int64_t frames) const;
  // RESOURCE_EXHAUSTED naming both numbers unless a frame of `frame_bytes`
  // (twice, for the temporary copy's worst case) plus the margin fits.
  absl::Status CheckRoomForFrame(int64_t frame_bytes) const;
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
