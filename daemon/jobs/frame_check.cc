// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/frame_check.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/io/exif.h"
#include "processing/io/sha256.h"

namespace hdrstereo::jobs {
namespace {

std::string Seconds(double s) {
  if (s > 0 && s < 1) return absl::StrFormat("1/%.4g s", 1.0 / s);
  return absl::StrFormat("%.4g s", s);
}

// |log2(a / b)|: the difference in stops (f-numbers: 2 stops per doubling).
double Stops(double a, double b) { return std::abs(std::log2(a / b)); }

}  // namespace

CameraReport ReadCameraReport(const hardware::Frame& frame) {
  CameraReport report;
  const io::ExifInfo exif = frame.format == hardware::ImageFormat::kRaw
                                ? io::ReadRawMetadata(frame.bytes)
                                : io::ParseExifFromFile(frame.bytes);
  report.exposure_s = exif.exposure_s;
  report.iso = exif.iso;
  report.aperture_f = exif.aperture;
  report.time_ms = io::ExifCaptureTimeMs(exif);
  report.time_has_subseconds =
      report.time_ms.has_value() && !exif.subsec_time_original.empty();
  if (!report.time_ms.has_value() &&
      frame.camera_time != absl::InfinitePast()) {
    report.time_ms = absl::ToUnixMillis(frame.camera_time);
  }
  report.file_name = frame.camera_file_name;
  report.stored_to = frame.stored_to;
  report.sha256 = io::Sha256Hex(frame.bytes);
  return report;
}

void FrameChecker::Remember(const CameraReport& report) {
  if (!report.sha256.empty()) hashes_.insert(report.sha256);
  if (!report.file_name.empty() && report.time_ms.has_value()) {
    names_and_times_.emplace(report.file_name, *report.time_ms);
  }
  if (report.time_has_subseconds) precise_times_.insert(*report.time_ms);
}

std::optional<Mismatch> FrameChecker::Check(
    const hardware::ExposureSettings& requested,
    const CameraReport& report) const {
  // The previous image again: the most harmful, since every later frame
  // would be shifted by one. (A file name alone proves nothing: many
  // cameras name every RAM capture capt0000.jpg.)
  const bool same_bytes = hashes_.contains(report.sha256);
  const bool same_name_and_time =
      !report.file_name.empty() && report.time_ms.has_value() &&
      names_and_times_.contains({report.file_name, *report.time_ms});
  const bool same_precise_time =
      report.time_has_subseconds && precise_times_.contains(*report.time_ms);
  if (same_bytes || same_name_and_time || same_precise_time) {
    return Mismatch{
        store::EventKind::kPreviousFile,
        absl::StrCat(
            "the camera delivered a frame already taken in this capture (",
            report.file_name.empty() ? "" : report.file_name,
            report.file_name.empty() ? "" : ", ",
            same_bytes ? "identical bytes"
                       : "the same camera time " +
                             std::to_string(*report.time_ms) + " ms",
            ") instead of a new one")};
  }
  if (report.stored_to == hardware::StoredTo::kCard) {
    return Mismatch{
        store::EventKind::kCardTarget,
        absl::StrCat("the camera stored ",
                     report.file_name.empty() ? "the frame" : report.file_name,
                     " on its card, not in RAM: the capture "
                     "target changed")};
  }
  if (report.exposure_s.has_value() && requested.exposure_s > 0 &&
      !(Stops(*report.exposure_s, requested.exposure_s) <=
        kExposureToleranceStops)) {
    return Mismatch{
        store::EventKind::kWrongExposure,
        absl::StrFormat("the camera exposed %s, not the %s set (%.2f stops "
                        "off; at most 1/6 is accepted)",
                        Seconds(*report.exposure_s),
                        Seconds(requested.exposure_s),
                        Stops(*report.exposure_s, requested.exposure_s))};
  }
  if (report.iso.has_value() && requested.iso > 0 &&
      std::abs(*report.iso - requested.iso) > 0.5) {
    return Mismatch{
        store::EventKind::kWrongIso,
        absl::StrFormat("the camera used ISO %g, not the ISO %d set",
                        *report.iso, requested.iso)};
  }
  if (report.aperture_f.has_value() && requested.aperture_f > 0 &&
      !(2 * Stops(*report.aperture_f, requested.aperture_f) <=
        kExposureToleranceStops)) {
    return Mismatch{
        store::EventKind::kWrongAperture,
        absl::StrFormat("the camera used f/%.3g, not the f/%.3g set",
                        *report.aperture_f, requested.aperture_f)};
  }
  return std::nullopt;
}

}  // namespace hdrstereo::jobs
