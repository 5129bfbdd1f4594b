// SPDX-License-Identifier: GPL-3.0-or-later
//
// From scene radiance to pixel values, like a DSLR:
//   electrons = radiance * exposure_s * electrons_per_exposure * iso / 100
//               + shot noise (Poisson, Gaussian approximation) + read noise;
//   x = min(electrons, full_well) / full_well   (full-well clipping);
//   value = round(response(x) * max_value)      (8 or 16 bit).
// Noise is seeded and counter-based: the same seed gives the same bytes on
// any number of threads.
#ifndef HDRSTEREO_HARDWARE_SIM_CAMERA_MODEL_H_
#define HDRSTEREO_HARDWARE_SIM_CAMERA_MODEL_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "absl/status/statusor.h"
#include "hardware/sim/scene.h"

namespace hdrstereo::sim {

struct ExposureSettings {
  double exposure_s = 1.0 / 125;
  double iso = 100;
  double aperture_f = 8;  // not rendered (pinhole); written to EXIF
};

// Signal in electrons (CV_32FC3, BGR), noise included, not yet clipped.
// `noise_seed` selects the noise realisation; an infinite radiance stays
// +inf (no noise is added to it).
cv::Mat ExposeSensor(const cv::Mat& radiance, const SensorModel& sensor,
                     const ExposureSettings& settings, uint64_t noise_seed);

// Full-well clipping, response curve and quantisation. bits == 8 uses
// sensor.response (CV_8UC3); bits == 16 uses sensor.raw_response
// (CV_16UC3, linear by default). A pixel at or above full well (+inf
// included) is exactly 255 / 65535; a value below 0 electrons (read noise)
// or NaN is read as 0 electrons, as if no light had reached the pixel.
cv::Mat Digitize(const cv::Mat& electrons, const SensorModel& sensor, int bits);

// RGGB Bayer mosaic of the electrons, clipped as Digitize clips them,
// linear, 0 .. raw_white_level (CV_16UC1). Pixel (x, y) keeps red for even x
// and y, blue for odd x and y, green otherwise.
cv::Mat MosaicBayer(const cv::Mat& electrons, const SensorModel& sensor);

// A DNG (uncompressed 16-bit CFA, RGGB, white level from the sensor), written
// with libtiff, readable by LibRaw.
absl::StatusOr<std::string> EncodeDng(const cv::Mat& bayer,
                                      const SensorModel& sensor,
                                      const ExposureSettings& settings);

enum class ImageFormat {
  kPng,     // 8-bit
  kJpeg,    // 8-bit, quality 95
  kTiff16,  // 16-bit linear "raw-ish"
  kDng,     // Bayer RAW
};
absl::string_view ImageFormatName(ImageFormat format);  // "png", ...
absl::StatusOr<ImageFormat> ParseImageFormat(absl::string_view name);

// cv::imencode for PNG/JPEG/TIFF; `image` must already have the right depth.
absl::StatusOr<std::string> EncodeImage(const cv::Mat& image,
                                        ImageFormat format);

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_CAMERA_MODEL_H_
