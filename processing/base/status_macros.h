// SPDX-License-Identifier: GPL-3.0-or-later
//
// RETURN_IF_ERROR and ASSIGN_OR_RETURN: the status plumbing every layer uses
// (hardware, processing, daemon, clients). Debian 12's abseil has no public
// status macros, so they live here, once.
//
//   RETURN_IF_ERROR(WriteFileAtomically(path, bytes));
//   ASSIGN_OR_RETURN(cv::Mat image, ReadImage(path));
#ifndef HDRSTEREO_PROCESSING_BASE_STATUS_MACROS_H_
#define HDRSTEREO_PROCESSING_BASE_STATUS_MACROS_H_

#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

// Evaluates `expr` (an absl::Status) once and returns it from the enclosing
// function when it is not OK. The function may return absl::Status or any
// absl::StatusOr<T>.
#define RETURN_IF_ERROR(expr)                                         \
  do {                                                                \
    if (::absl::Status hdrstereo_status_ = (expr);                    \
        !hdrstereo_status_.ok()) {                                    \
      return hdrstereo_status_;                                       \
    }                                                                 \
  } while (false)

// Evaluates `expr` (an absl::StatusOr<T>) once; returns its status when it
// is not OK, else moves the value into `lhs`, which is a declaration
// (`auto x`, `cv::Mat image`) or an existing variable. `lhs` must not
// contain an unparenthesised comma.
#define ASSIGN_OR_RETURN(lhs, expr)                                      \
  HDRSTEREO_ASSIGN_OR_RETURN_IMPL_(                                      \
      HDRSTEREO_STATUS_CONCAT_(hdrstereo_statusor_, __LINE__), lhs, expr)

#define HDRSTEREO_ASSIGN_OR_RETURN_IMPL_(statusor, lhs, expr) \
  auto statusor = (expr);                                     \
  if (!statusor.ok()) return std::move(statusor).status();    \
  lhs = *std::move(statusor)

#define HDRSTEREO_STATUS_CONCAT_INNER_(a, b) a##b
#define HDRSTEREO_STATUS_CONCAT_(a, b) HDRSTEREO_STATUS_CONCAT_INNER_(a, b)

#endif  // HDRSTEREO_PROCESSING_BASE_STATUS_MACROS_H_
