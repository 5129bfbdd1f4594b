// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/camera_model.h"

#include <tiffio.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "hardware/sim/noise.h"

namespace hdrstereo::sim {
namespace {

// The signal as a fraction of full well, in [0, 1]: clipped at full well
// (+inf included); a negative value (read noise) and NaN read as 0, so that
// what indexes a table or is rounded to an integer is always in range.
double WellFraction(float electrons, double full_well) {
  const double x = electrons / full_well;
  return x > 0 ? std::min(x, 1.0) : 0.0;
}

}  // namespace

cv::Mat ExposeSensor(const cv::Mat& radiance, const SensorModel& sensor,
                     const ExposureSettings& settings, uint64_t noise_seed) {
  CV_Assert(radiance.type() == CV_32FC3);
  cv::Mat electrons(radiance.size(), CV_32FC3);
  const double gain =
      settings.exposure_s * sensor.electrons_per_exposure * settings.iso / 100;
  const bool noisy = sensor.shot_noise || sensor.read_noise_e > 0;
  const int width = radiance.cols;
  cv::parallel_for_(
      cv::Range(0, radiance.rows),
      [&](const cv::Range& rows) {
        for (int y = rows.start; y < rows.end; ++y) {
          const auto* in = radiance.ptr<cv::Vec3f>(y);
          auto* out = electrons.ptr<cv::Vec3f>(y);
          for (int x = 0; x < width; ++x) {
            double n[3] = {0, 0, 0};
            if (noisy) {
              // Three standard normals per pixel from two Box-Muller pairs
              // of 32-bit uniforms (one hash chain per pixel).
              const uint64_t h1 = SplitMix64(HashCombine(
                  noise_seed, static_cast<uint64_t>(y) * width + x));
              const uint64_t h2 = SplitMix64(h1);
              constexpr double k32 = 1.0 / 4294967296.0;
              const double u1 = ((h1 >> 32) + 0.5) * k32;
              const double u2 = ((h1 & 0xffffffffu) + 0.5) * k32;
              const double u3 = ((h2 >> 32) + 0.5) * k32;
              const double u4 = ((h2 & 0xffffffffu) + 0.5) * k32;
              constexpr double kTwoPi = 6.283185307179586;
              const double r1 = std::sqrt(-2.0 * std::log(u1));
              const double r2 = std::sqrt(-2.0 * std::log(u3));
              n[0] = r1 * std::cos(kTwoPi * u2);
              n[1] = r1 * std::sin(kTwoPi * u2);
              n[2] = r2 * std::cos(kTwoPi * u4);
            }
            for (int c = 0; c < 3; ++c) {
              double e = static_cast<double>(in[x][c]) * gain;
              // Noise on an infinite signal (a point light touching a
              // surface) would make it inf - inf = NaN: it stays saturated.
              if (noisy && std::isfinite(e)) {
                double sigma2 = sensor.read_noise_e * sensor.read_noise_e;
                if (sensor.shot_noise) sigma2 += e;
                e += std::sqrt(sigma2) * n[c];
              }
              out[x][c] = static_cast<float>(e);
            }
          }
        }
      },
      std::max(1, radiance.rows / 16));
  return electrons;
}

cv::Mat Digitize(const cv::Mat& electrons, const SensorModel& sensor,
                 int bits) {
  CV_Assert(electrons.type() == CV_32FC3 && (bits == 8 || bits == 16));
  const ResponseCurve& response =
      bits == 8 ? sensor.response : sensor.raw_response;
  const double max_value = bits == 8 ? 255.0 : 65535.0;
  // Look-up table over x quantised to 1/kSteps; x = 1 (full well) maps to
  // response(1) = 1 exactly, i.e. to max_value.
  constexpr int kSteps = 1 << 16;
  std::vector<uint16_t> lut(kSteps + 1);
  for (int i = 0; i <= kSteps; ++i) {
    lut[i] = static_cast<uint16_t>(std::lround(
        std::clamp(response.Evaluate(static_cast<double>(i) / kSteps), 0.0,
                   1.0) *
        max_value));
  }
  const double full_well = sensor.full_well_e;
  cv::Mat out(electrons.size(), bits == 8 ? CV_8UC3 : CV_16UC3);
  const int n = electrons.cols * 3;
  cv::parallel_for_(cv::Range(0, electrons.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const float* in = electrons.ptr<float>(y);
      uint8_t* o8 = out.ptr<uint8_t>(y);
      uint16_t* o16 = out.ptr<uint16_t>(y);
      for (int i = 0; i < n; ++i) {
        const double x = WellFraction(in[i], full_well);
        const uint16_t v = lut[static_cast<int>(std::lround(x * kSteps))];
        if (bits == 8) {
          o8[i] = static_cast<uint8_t>(v);
        } else {
          o16[i] = v;
        }
      }
    }
  });
  return out;
}

cv::Mat MosaicBayer(const cv::Mat& electrons, const SensorModel& sensor) {
  CV_Assert(electrons.type() == CV_32FC3);
  cv::Mat raw(electrons.size(), CV_16UC1);
  for (int y = 0; y < electrons.rows; ++y) {
    const auto* in = electrons.ptr<cv::Vec3f>(y);
    auto* out = raw.ptr<uint16_t>(y);
    for (int x = 0; x < electrons.cols; ++x) {
      // BGR channel index: red = 2, green = 1, blue = 0.
      const int c = (y % 2 == 0) ? (x % 2 == 0 ? 2 : 1) : (x % 2 == 0 ? 1 : 0);
      const double v =
          WellFraction(in[x][c], sensor.full_well_e) * sensor.raw_white_level;
      out[x] = static_cast<uint16_t>(std::lround(v));
    }
  }
  return raw;
}

namespace {

// libtiff on a growing in-memory buffer.
struct MemoryFile {
  std::string data;
  toff_t pos = 0;
};

tmsize_t MemRead(thandle_t h, void* buf, tmsize_t size) {
  auto* f = static_cast<MemoryFile*>(h);
  if (f->pos >= f->data.size()) return 0;
  const tmsize_t n =
      std::min<tmsize_t>(size, static_cast<tmsize_t>(f->data.size() - f->pos));
  std::memcpy(buf, f->data.data() + f->pos, n);
  f->pos += n;
  return n;
}

tmsize_t MemWrite(thandle_t h, void* buf, tmsize_t size) {
  auto* f = static_cast<MemoryFile*>(h);
  if (f->pos + size > f->data.size()) f->data.resize(f->pos + size);
  std::memcpy(f->data.data() + f->pos, buf, size);
  f->pos += size;
  return size;
}

toff_t MemSeek(thandle_t h, toff_t off, int whence) {
  auto* f = static_cast<MemoryFile*>(h);
  switch (whence) {
    case SEEK_SET:
      f->pos = off;
      break;
    case SEEK_CUR:
      f->pos += off;
      break;
    case SEEK_END:
      f->pos = f->data.size() + off;
      break;
  }
  return f->pos;
}

int MemClose(thandle_t) { return 0; }
toff_t MemSize(thandle_t h) { return static_cast<MemoryFile*>(h)->data.size(); }
int MemMap(thandle_t, void**, toff_t*) { return 0; }
void MemUnmap(thandle_t, void*, toff_t) {}

}  // namespace

absl::StatusOr<std::string> EncodeDng(const cv::Mat& bayer,
                                      const SensorModel& sensor,
                                      const ExposureSettings& settings) {
  if (bayer.type() != CV_16UC1 || bayer.empty()) {
    return absl::InvalidArgumentError("EncodeDng needs a CV_16UC1 mosaic");
  }
  MemoryFile file;
  TIFF* tif = TIFFClientOpen("sim.dng", "w", &file, MemRead, MemWrite, MemSeek,
                             MemClose, MemSize, MemMap, MemUnmap);
  if (tif == nullptr) return absl::InternalError("TIFFClientOpen failed");
  const uint32_t w = bayer.cols, h = bayer.rows;
  const uint8_t dng_version[4] = {1, 4, 0, 0};
  const uint8_t dng_backward[4] = {1, 1, 0, 0};
  const uint16_t cfa_dim[2] = {2, 2};
  const uint8_t cfa_pattern[4] = {0, 1, 1, 2};  // R G / G B
  // sRGB/D65 XYZ-to-camera matrix: the simulated sensor's RGB is sRGB-linear.
  const float color_matrix[9] = {3.2406f, -1.5372f, -0.4986f, -0.9689f, 1.8758f,
                                 0.0415f, 0.0557f,  -0.2040f, 1.0570f};
  const float neutral[3] = {1.0f, 1.0f, 1.0f};
  const uint32_t white = static_cast<uint32_t>(sensor.raw_white_level);
  const std::string description = absl::StrCat(
      "hdrstereo-sim exposure_s=", settings.exposure_s, " iso=", settings.iso);
  bool ok = TIFFSetField(tif, TIFFTAG_SUBFILETYPE, 0) &&
            TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, w) &&
            TIFFSetField(tif, TIFFTAG_IMAGELENGTH, h) &&
            TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 16) &&
            TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1) &&
            TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE) &&
            TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_CFA) &&
            TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG) &&
            TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, h) &&
            TIFFSetField(tif, TIFFTAG_MAKE, "hdrstereo") &&
            TIFFSetField(tif, TIFFTAG_MODEL, "sim") &&
            TIFFSetField(tif, TIFFTAG_IMAGEDESCRIPTION, description.c_str()) &&
            TIFFSetField(tif, TIFFTAG_DNGVERSION, dng_version) &&
            TIFFSetField(tif, TIFFTAG_DNGBACKWARDVERSION, dng_backward) &&
            TIFFSetField(tif, TIFFTAG_UNIQUECAMERAMODEL, "hdrstereo sim") &&
            TIFFSetField(tif, TIFFTAG_CFAREPEATPATTERNDIM, cfa_dim) &&
            TIFFSetField(tif, TIFFTAG_CFAPATTERN, 4, cfa_pattern) &&
            TIFFSetField(tif, TIFFTAG_COLORMATRIX1, 9, color_matrix) &&
            TIFFSetField(tif, TIFFTAG_CALIBRATIONILLUMINANT1, 21) &&
            TIFFSetField(tif, TIFFTAG_ASSHOTNEUTRAL, 3, neutral) &&
            TIFFSetField(tif, TIFFTAG_WHITELEVEL, 1, &white);
  if (ok) {
    for (uint32_t y = 0; y < h && ok; ++y) {
      ok = TIFFWriteScanline(tif, const_cast<uint16_t*>(bayer.ptr<uint16_t>(y)),
                             y, 0) == 1;
    }
  }
  if (ok) ok = TIFFWriteDirectory(tif) == 1;
  TIFFClose(tif);
  if (!ok) return absl::InternalError("libtiff failed to write the DNG");
  return std::move(file.data);
}

absl::string_view ImageFormatName(ImageFormat format) {
  switch (format) {
    case ImageFormat::kPng:
      return "png";
    case ImageFormat::kJpeg:
      return "jpeg";
    case ImageFormat::kTiff16:
      return "tiff";
    case ImageFormat::kDng:
      return "dng";
  }
  return "png";
}

absl::StatusOr<ImageFormat> ParseImageFormat(absl::string_view name) {
  if (name == "png") return ImageFormat::kPng;
  if (name == "jpeg" || name == "jpg") return ImageFormat::kJpeg;
  if (name == "tiff" || name == "tif") return ImageFormat::kTiff16;
  if (name == "dng") return ImageFormat::kDng;
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown image format \"", name, "\" (use png, jpeg, tiff or dng)"));
}

absl::StatusOr<std::string> EncodeImage(const cv::Mat& image,
                                        ImageFormat format) {
  std::string ext;
  std::vector<int> params;
  switch (format) {
    case ImageFormat::kPng:
      ext = ".png";
      params = {cv::IMWRITE_PNG_COMPRESSION, 1};
      break;
    case ImageFormat::kJpeg:
      ext = ".jpg";
      params = {cv::IMWRITE_JPEG_QUALITY, 95};
      break;
    case ImageFormat::kTiff16:
      ext = ".tiff";
      break;
    case ImageFormat::kDng:
      return absl::InvalidArgumentError("use EncodeDng for DNG");
  }
  std::vector<uint8_t> buffer;
  try {
    if (!cv::imencode(ext, image, buffer, params)) {
      return absl::InternalError(
          absl::StrCat("cv::imencode(", ext, ") failed"));
    }
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("cv::imencode(", ext, "): ", e.what()));
  }
  return std::string(buffer.begin(), buffer.end());
}

}  // namespace hdrstereo::sim
