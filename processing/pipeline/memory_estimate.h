// SPDX-License-Identifier: GPL-3.0-or-later
//
// How much memory a pipeline run needs at most, from the sizes of what it
// reads: so that hdrstereod can refuse, before starting, a processing job
// that cannot fit, naming what it would need, and hdrstereo-proc can say
// how the estimate compared with what the run took.
//
// Each step's peak is a sum of the images it holds at once, with the
// step's own working set in bytes per pixel measured on a 24-megapixel
// session (docs/results.md, "Sessions from 24-megapixel cameras"); steps
// that may run at the same time (neither needs the other, up to `threads`
// of them) add up.
#ifndef HDRSTEREO_PROCESSING_PIPELINE_MEMORY_ESTIMATE_H_
#define HDRSTEREO_PROCESSING_PIPELINE_MEMORY_ESTIMATE_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "processing/pipeline/pipeline.h"

namespace hdrstereo::pipeline {

// The sizes a run's memory depends on.
struct RunShape {
  cv::Size image;               // the stereo frames
  int bytes_per_pixel = 3;      // as decoded: channels x bytes a sample
  int exposures = 0;            // stereo frames a view
  cv::Size sl_image;            // the structured-light frames; empty: none
  int sl_bytes_per_sample = 1;  // kept grey: 1 (8-bit) or 2 (16-bit)
  int sl_frames = 0;            // structured-light frames a view
};

struct MemoryEstimate {
  int64_t peak_bytes = 0;
  // The steps whose peaks add up to it ("hdr + sl_groundtruth").
  std::string steps;
  // "about 6.2 GiB at the peak (hdr + sl_groundtruth: 6000 x 4000 frames,
  // 8 exposures a view, 84 structured-light frames a view)".
  std::string Describe(const RunShape& shape) const;
};

// `steps` as ResolveSteps gives them (all of them when empty), the
// options' threads and matching_width. INVALID_ARGUMENT for an unknown
// step or a shape without stereo frames.
absl::StatusOr<MemoryEstimate> EstimateMemory(const RunShape& shape,
                                              const RunOptions& options);

// The shape of a session on disk: the size and sample type of its first
// stereo frame and first structured-light frame (each decoded once), the
// frames counted per view. FAILED_PRECONDITION without stereo frames.
absl::StatusOr<RunShape> ShapeOfSession(const SessionInput& input);

// "6.2 GiB", "512 MiB".
std::string FormatBytes(int64_t bytes);

// Has glibc map every allocation of 1 MiB or more (the images) on its own,
// so that a freed image goes back to the system at once; the estimate
// assumes it. With glibc's default threshold, which grows to 32 MiB, the
// heap kept about 1.4 GB of freed frames at the peak of a 24-megapixel run
// (6.9 GiB instead of 5.5). Called once by each process that runs the
// pipeline, before it starts.
void ReturnFreedImagesToTheSystem();

}  // namespace hdrstereo::pipeline

#endif  // HDRSTEREO_PROCESSING_PIPELINE_MEMORY_ESTIMATE_H_
