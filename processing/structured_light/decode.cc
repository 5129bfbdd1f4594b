// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/decode.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace hdrstereo::structured_light {
namespace {

constexpr int kMaxBits = 16;  // codes are kept in uint16_t

struct Thresholds {
  int min_contrast = 1;
  int min_lit = 1;
  int relative_q8 = 64;  // min relative contrast, x256
  int saturation = 255;
  int full_scale = 255;
};

// Decodes rows [begin, end) of one view. `grey[e][i]` is frame i of
// exposure e (single channel, type T).
template <typename T>
void DecodeRows(const std::vector<std::vector<cv::Mat>>& grey, int col_bits,
                int row_bits, const Thresholds& th,
                const std::vector<int32_t>& col_lut,
                const std::vector<int32_t>& row_lut, const cv::Range& rows,
                DecodedView* out) {
  const int width = grey[0][0].cols;
  const int n = static_cast<int>(grey[0].size());
  std::vector<uint16_t> code_c(width), code_r(width), minc(width);
  std::vector<uint16_t> best_c(width), best_r(width);
  std::vector<int32_t> best(width);
  std::vector<uint8_t> best_e(width), lit(width);
  const T sat = static_cast<T>(th.saturation);

  auto accumulate = [&](const std::vector<cv::Mat>& frames, int first, int bits,
                        int y, uint16_t* code) {
    for (int b = 0; b < bits; ++b) {
      const T* p = frames[first + 2 * b].ptr<T>(y);
      const T* q = frames[first + 2 * b + 1].ptr<T>(y);
      uint16_t* m = minc.data();
      // Branch-free so that it vectorises.
      for (int x = 0; x < width; ++x) {
        const T a = p[x], c = q[x];
        const T hi = a > c ? a : c;
        const T lo = a > c ? c : a;
        const uint16_t contrast =
            lo >= sat ? uint16_t{0} : static_cast<uint16_t>(hi - lo);
        code[x] = static_cast<uint16_t>((code[x] << 1) | (a > c ? 1 : 0));
        m[x] = contrast < m[x] ? contrast : m[x];
      }
    }
  };

  for (int y = rows.start; y < rows.end; ++y) {
    std::fill(best.begin(), best.end(), -1);
    std::fill(best_e.begin(), best_e.end(), uint8_t{255});
    std::fill(lit.begin(), lit.end(), uint8_t{0});
    for (size_t e = 0; e < grey.size(); ++e) {
      const std::vector<cv::Mat>& frames = grey[e];
      std::fill(code_c.begin(), code_c.end(), uint16_t{0});
      std::fill(code_r.begin(), code_r.end(), uint16_t{0});
      std::fill(minc.begin(), minc.end(), uint16_t{0xFFFF});
      accumulate(frames, 0, col_bits, y, code_c.data());
      accumulate(frames, 2 * col_bits, row_bits, y, code_r.data());
      const T* white = frames[n - 2].ptr<T>(y);
      const T* black = frames[n - 1].ptr<T>(y);
      for (int x = 0; x < width; ++x) {
        const int diff = static_cast<int>(white[x]) - black[x];
        const bool is_lit = diff >= th.min_lit;
        lit[x] = static_cast<uint8_t>(lit[x] | (is_lit ? 255 : 0));
        const int need =
            std::max(th.min_contrast, (diff * th.relative_q8 + 255) >> 8);
        const int score = is_lit && minc[x] >= need ? minc[x] : -1;
        if (score > best[x]) {
          best[x] = score;
          best_c[x] = code_c[x];
          best_r[x] = code_r[x];
          best_e[x] = static_cast<uint8_t>(e);
        }
      }
    }
    int32_t* col = out->column.ptr<int32_t>(y);
    int32_t* row = out->row.ptr<int32_t>(y);
    float* conf = out->confidence.ptr<float>(y);
    uint8_t* lit_out = out->lit.ptr<uint8_t>(y);
    uint8_t* exposure = out->exposure.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      lit_out[x] = lit[x];
      int32_t c = -1, r = -1;
      if (best[x] >= 0) {
        c = col_lut[best_c[x]];
        r = row_lut[best_r[x]];
      }
      if (c < 0 || r < 0) {
        col[x] = -1;
        row[x] = -1;
        conf[x] = 0;
        exposure[x] = 255;
      } else {
        col[x] = c;
        row[x] = r;
        conf[x] = static_cast<float>(best[x]) / th.full_scale;
        exposure[x] = best_e[x];
      }
    }
  }
}

std::vector<int32_t> GrayLut(int bits, int n) {
  std::vector<int32_t> lut(size_t{1} << bits);
  for (size_t g = 0; g < lut.size(); ++g) {
    const int v = FromGray(static_cast<int>(g));
    lut[g] = v < n ? v : -1;  // codes never projected are invalid
  }
  return lut;
}

}  // namespace

std::string FrameId(const Pattern& pattern) {
  return absl::StrCat(pattern.Id(), pattern.inverse ? "_inv" : "");
}

absl::StatusOr<DecodedView> Decode(const ViewFrames& view,
                                   const DecodeOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("decode: ", s.message()));
  }
  const cv::Size psize = view.projector_size;
  if (psize.width <= 0 || psize.height <= 0) {
    return absl::InvalidArgumentError("projector size must be positive");
  }
  const int col_bits = BitCount(psize.width);
  const int row_bits = BitCount(psize.height);
  if (col_bits > kMaxBits || row_bits > kMaxBits) {
    return absl::InvalidArgumentError(
        absl::StrFormat("projector %dx%d needs more than %d bits", psize.width,
                        psize.height, kMaxBits));
  }
  if (view.exposures.empty()) {
    return absl::InvalidArgumentError("no exposure given");
  }
  if (view.exposures.size() > 254) {
    return absl::InvalidArgumentError("at most 254 exposures");
  }
  const std::vector<Pattern> patterns = AllPatterns(psize);
  const size_t n = patterns.size();
  cv::Size size;
  int depth = -1;
  for (size_t e = 0; e < view.exposures.size(); ++e) {
    const std::vector<cv::Mat>& frames = view.exposures[e].frames;
    if (frames.size() != n) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "exposure %d: expected %d frames for a %dx%d projector (%d column "
          "and %d row bits, each with its inverse, white, black), got %d",
          e, n, psize.width, psize.height, col_bits, row_bits, frames.size()));
    }
    for (size_t i = 0; i < n; ++i) {
      const cv::Mat& f = frames[i];
      const std::string id = FrameId(patterns[i]);
      if (f.empty()) {
        return absl::InvalidArgumentError(
            absl::StrFormat("exposure %d: frame %s is missing", e, id));
      }
      if (f.depth() != CV_8U && f.depth() != CV_16U) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "exposure %d: frame %s must be 8- or 16-bit", e, id));
      }
      if (f.channels() != 1 && f.channels() != 3) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "exposure %d: frame %s must have 1 or 3 channels", e, id));
      }
      if (depth < 0) {
        depth = f.depth();
        size = f.size();
      }
      if (f.size() != size || f.depth() != depth) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "exposure %d: frame %s is %dx%d %d-bit but the first frame is "
            "%dx%d %d-bit",
            e, id, f.cols, f.rows, f.depth() == CV_8U ? 8 : 16, size.width,
            size.height, depth == CV_8U ? 8 : 16));
      }
    }
  }
  try {
    std::vector<std::vector<cv::Mat>> grey(view.exposures.size());
    for (size_t e = 0; e < grey.size(); ++e) {
      grey[e].resize(n);
      for (size_t i = 0; i < n; ++i) {
        const cv::Mat& f = view.exposures[e].frames[i];
        if (f.channels() == 3) {
          cv::cvtColor(f, grey[e][i], cv::COLOR_BGR2GRAY);
        } else {
          grey[e][i] = f;
        }
      }
    }
    Thresholds th;
    th.full_scale = depth == CV_8U ? 255 : 65535;
    th.min_contrast = std::max(
        1, static_cast<int>(std::ceil(options.min_contrast * th.full_scale)));
    th.min_lit = std::max(
        1, static_cast<int>(std::ceil(options.min_lit * th.full_scale)));
    th.relative_q8 = std::clamp(
        static_cast<int>(std::lround(options.min_relative_contrast * 256)), 0,
        256);
    th.saturation = std::clamp(
        static_cast<int>(std::floor(options.saturation * th.full_scale)), 1,
        th.full_scale);
    const std::vector<int32_t> col_lut = GrayLut(col_bits, psize.width);
    const std::vector<int32_t> row_lut = GrayLut(row_bits, psize.height);

    DecodedView out;
    out.column.create(size, CV_32SC1);
    out.row.create(size, CV_32SC1);
    out.confidence.create(size, CV_32FC1);
    out.lit.create(size, CV_8UC1);
    out.exposure.create(size, CV_8UC1);
    const int stripes = std::max(1, size.height / 16);
    cv::parallel_for_(
        cv::Range(0, size.height),
        [&](const cv::Range& rows) {
          if (depth == CV_8U) {
            DecodeRows<uint8_t>(grey, col_bits, row_bits, th, col_lut, row_lut,
                                rows, &out);
          } else {
            DecodeRows<uint16_t>(grey, col_bits, row_bits, th, col_lut, row_lut,
                                 rows, &out);
          }
        },
        stripes);
    out.valid_pixels = cv::countNonZero(out.column >= 0);
    out.lit_pixels = cv::countNonZero(out.lit);
    const int total = size.area();
    if (out.lit_pixels == 0) {
      out.warnings.push_back(absl::StrFormat(
          "no pixel is lit by the projector (white - black < %.3g of full "
          "scale everywhere): all-invalid map",
          options.min_lit));
    } else if (out.valid_pixels < total / 100) {
      out.warnings.push_back(absl::StrFormat(
          "only %d of %d pixels decoded (%d lit): check exposure and "
          "projector",
          out.valid_pixels, total, out.lit_pixels));
    }
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("decode: ", e.what()));
  }
}

}  // namespace hdrstereo::structured_light
