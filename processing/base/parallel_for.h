// SPDX-License-Identifier: GPL-3.0-or-later
//
// ParallelFor(n, threads, unit): unit(0) .. unit(n - 1) on up to `threads`
// threads (the caller's among them), each index once; the first error stops
// the units not yet started and is returned. For independent units of work
// that take seconds (matchings, fusions, tone mappings), not for pixels.
#ifndef HDRSTEREO_PROCESSING_BASE_PARALLEL_FOR_H_
#define HDRSTEREO_PROCESSING_BASE_PARALLEL_FOR_H_

#include <functional>

#include "absl/status/status.h"

namespace hdrstereo {

absl::Status ParallelFor(int n, int threads,
                         const std::function<absl::Status(int)>& unit);

}  // namespace hdrstereo

#endif  // HDRSTEREO_PROCESSING_BASE_PARALLEL_FOR_H_
