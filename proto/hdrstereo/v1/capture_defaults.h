// SPDX-License-Identifier: GPL-3.0-or-later
//
// What the daemon puts into a CapturePlan's unset (zero) fields (jobs.proto
// says "0 = default"): part of the wire contract, so that the daemon applies
// them (daemon/jobs/capture_plan.cc) and clients can say them (the CLI's
// help prints these) from one place.
#ifndef HDRSTEREO_PROTO_HDRSTEREO_V1_CAPTURE_DEFAULTS_H_
#define HDRSTEREO_PROTO_HDRSTEREO_V1_CAPTURE_DEFAULTS_H_

#include <array>

namespace hdrstereo::v1 {

inline constexpr int kDefaultViews = 2;            // left + right
inline constexpr double kDefaultBaselineMm = 150;  // between views
inline constexpr double kDefaultCalibrationExposureS = 1.0 / 60;
// The calibration chessboard: inner corners along a row and down a column,
// and the edge of a square.
inline constexpr int kDefaultBoardColumns = 9;
inline constexpr int kDefaultBoardRows = 6;
inline constexpr double kDefaultBoardSquareMm = 25;
// The thesis' bracket (Fig. 3.2), longest first.
inline constexpr std::array<double, 8> kDefaultStereoExposuresS = {
    1.0 / 15,  1.0 / 30,  1.0 / 60,   1.0 / 125,
    1.0 / 250, 1.0 / 500, 1.0 / 1000, 1.0 / 2000};
// Structured light is captured at two exposures.
inline constexpr std::array<double, 2> kDefaultStructuredLightExposuresS = {
    1.0 / 30, 1.0 / 125};

}  // namespace hdrstereo::v1

#endif  // HDRSTEREO_PROTO_HDRSTEREO_V1_CAPTURE_DEFAULTS_H_
