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
  // false: every bit required and the relative test not applied (see
  // FinestStripesResolved).
  bool relative = true;
  int saturation = 255;
  int full_scale = 255;
};

// One axis of the code: `bits` planes, code of position p = gray(p +
// offset), `extent` projector columns or rows, at least `required` leading
// bits per pixel.
struct Axis1D {
  int bits = 0;
  int offset = 0;
  int extent = 0;
  int required = 0;
  // min_bits mode: codes are read down to their last usable bit, one bit
  // may straddle its stripe edge. Otherwise every bit must count.
  bool partial = false;
  // Full codes -> position (-1 = never projected).
  std::vector<int32_t> lut;
};

// Position of every full code: FromGray(code) - offset, -1 outside
// [0, extent) (codes never projected).
std::vector<int32_t> GrayLut(int bits, int offset, int extent) {
  std::vector<int32_t> lut(size_t{1} << bits);
  for (size_t g = 0; g < lut.size(); ++g) {
    const int v = FromGray(static_cast<int>(g)) - offset;
    lut[g] = v >= 0 && v < extent ? v : -1;
  }
  return lut;
}

// The projector position a pixel stands for when it read the `k` most
// significant of the axis' bits of `code` (the middle of the positions
// those bits allow, within [0, extent)); -1 when none is projected.
// `edge` > 0: bit edge - 1 (0 = most significant) had no contrast while the
// finer bits did, i.e. the pixel straddles that plane's stripe edge. In a
// Gray code only one bit changes across an edge, so the code with that bit
// flipped must be the neighbouring one, and the pixel stands for the edge
// between the two; otherwise it is invalid.
int32_t Position(uint32_t code, int k, int edge, const Axis1D& axis) {
  if (k == axis.bits && edge == 0) return axis.lut[code];
  const int free_bits = axis.bits - k;
  const uint32_t prefix = code >> free_bits;
  const int binary = FromGray(static_cast<int>(prefix));
  int lo = 0, hi = 0;
  if (edge > 0) {
    const int other = FromGray(static_cast<int>(prefix ^ (1u << (k - edge))));
    if (std::abs(other - binary) != 1) return -1;
    lo = hi = (std::max(binary, other) << free_bits) - axis.offset;
  } else {
    lo = (binary << free_bits) - axis.offset;
    hi = lo + (1 << free_bits) - 1;
  }
  const int a = std::max(lo, 0), b = std::min(hi, axis.extent - 1);
  if (a > b) return -1;
  return (a + b) / 2;
}

// Decodes rows [begin, end) of one view. `grey[e][i]` is frame i of
// exposure e (single channel, type T).
template <typename T>
void DecodeRows(const std::vector<std::vector<cv::Mat>>& grey,
                const Axis1D& cols, const Axis1D& rows_axis,
                const Thresholds& th, const cv::Range& rows, DecodedView* out) {
  const int width = grey[0][0].cols;
  const int n = static_cast<int>(grey[0].size());
  std::vector<uint16_t> code_c(width), code_r(width), minc(width), need(width);
  std::vector<uint8_t> bits_c(width), bits_r(width), run(width);
  std::vector<uint8_t> edge_c(width), edge_r(width);
  std::vector<uint8_t> best_edge_c(width), best_edge_r(width);
  std::vector<uint16_t> best_c(width), best_r(width), best_minc(width);
  std::vector<uint8_t> best_bits_c(width), best_bits_r(width);
  std::vector<int32_t> best(width);
  std::vector<uint8_t> best_e(width), lit(width);
  const T sat = static_cast<T>(th.saturation);

  // Every bit must count: the code and the running minimum contrast over
  // all bits of both axes (compared with need[x] afterwards).
  auto accumulate_full = [&](const std::vector<cv::Mat>& frames, int first,
                             int bits, int y, uint16_t* code) {
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
  // min_bits mode: a bit counts while every more significant one did (run)
  // and its contrast reaches need[x]; the first bit that does not may be an
  // edge bit (Position) as long as finer bits count after it.
  auto accumulate_partial = [&](const std::vector<cv::Mat>& frames, int first,
                                int bits, int y, uint16_t* code, uint8_t* count,
                                uint8_t* edge) {
    std::fill(run.begin(), run.end(), uint8_t{1});
    for (int b = 0; b < bits; ++b) {
      const T* p = frames[first + 2 * b].ptr<T>(y);
      const T* q = frames[first + 2 * b + 1].ptr<T>(y);
      uint16_t* m = minc.data();
      uint8_t* r = run.data();
      const uint16_t* nd = need.data();
      for (int x = 0; x < width; ++x) {
        const T a = p[x], c = q[x];
        const T hi = a > c ? a : c;
        const T lo = a > c ? c : a;
        const uint16_t contrast =
            lo >= sat ? uint16_t{0} : static_cast<uint16_t>(hi - lo);
        code[x] = static_cast<uint16_t>((code[x] << 1) | (a > c ? 1 : 0));
        const uint8_t ok = contrast >= nd[x] ? 1 : 0;
        const uint8_t take_edge =
            static_cast<uint8_t>(r[x] & (ok ^ 1) & (edge[x] == 0));
        edge[x] = take_edge ? static_cast<uint8_t>(b + 1) : edge[x];
        const uint8_t counts = static_cast<uint8_t>(r[x] & (ok | take_edge));
        r[x] = counts;
        count[x] = static_cast<uint8_t>(count[x] + counts);
        m[x] = counts && ok && contrast < m[x] ? contrast : m[x];
      }
    }
    // An edge bit with no counted bit after it is just the end of the code.
    for (int x = 0; x < width; ++x) {
      if (edge[x] != 0 && edge[x] == count[x]) {
        count[x] = static_cast<uint8_t>(count[x] - 1);
        edge[x] = 0;
      }
    }
  };

  for (int y = rows.start; y < rows.end; ++y) {
    std::fill(best.begin(), best.end(), -1);
    std::fill(best_e.begin(), best_e.end(), uint8_t{255});
    std::fill(lit.begin(), lit.end(), uint8_t{0});
    for (size_t e = 0; e < grey.size(); ++e) {
      const std::vector<cv::Mat>& frames = grey[e];
      const T* white = frames[n - 2].ptr<T>(y);
      const T* black = frames[n - 1].ptr<T>(y);
      for (int x = 0; x < width; ++x) {
        const int diff = static_cast<int>(white[x]) - black[x];
        const bool is_lit = diff >= th.min_lit;
        lit[x] = static_cast<uint8_t>(lit[x] | (is_lit ? 255 : 0));
        // An unlit pixel counts no bit.
        need[x] = static_cast<uint16_t>(
            is_lit
                ? std::max(th.min_contrast,
                           th.relative ? (diff * th.relative_q8 + 255) >> 8 : 0)
                : 0xFFFF);
      }
      std::fill(code_c.begin(), code_c.end(), uint16_t{0});
      std::fill(code_r.begin(), code_r.end(), uint16_t{0});
      std::fill(bits_c.begin(), bits_c.end(), uint8_t{0});
      std::fill(bits_r.begin(), bits_r.end(), uint8_t{0});
      std::fill(edge_c.begin(), edge_c.end(), uint8_t{0});
      std::fill(edge_r.begin(), edge_r.end(), uint8_t{0});
      std::fill(minc.begin(), minc.end(), uint16_t{0xFFFF});
      if (cols.partial) {
        accumulate_partial(frames, 0, cols.bits, y, code_c.data(),
                           bits_c.data(), edge_c.data());
        accumulate_partial(frames, 2 * cols.bits, rows_axis.bits, y,
                           code_r.data(), bits_r.data(), edge_r.data());
      } else {
        accumulate_full(frames, 0, cols.bits, y, code_c.data());
        accumulate_full(frames, 2 * cols.bits, rows_axis.bits, y,
                        code_r.data());
        for (int x = 0; x < width; ++x) {
          const bool all = minc[x] >= need[x];
          bits_c[x] = all ? static_cast<uint8_t>(cols.bits) : 0;
          bits_r[x] = all ? static_cast<uint8_t>(rows_axis.bits) : 0;
        }
      }
      for (int x = 0; x < width; ++x) {
        // More bits first, then the weakest counted bit's contrast.
        const bool enough = need[x] != 0xFFFF && bits_c[x] >= cols.required &&
                            bits_r[x] >= rows_axis.required;
        const int score =
            enough ? ((bits_c[x] + bits_r[x]) << 16) | minc[x] : -1;
        if (score > best[x]) {
          best[x] = score;
          best_c[x] = code_c[x];
          best_r[x] = code_r[x];
          best_bits_c[x] = bits_c[x];
          best_bits_r[x] = bits_r[x];
          best_edge_c[x] = edge_c[x];
          best_edge_r[x] = edge_r[x];
          best_minc[x] = minc[x];
          best_e[x] = static_cast<uint8_t>(e);
        }
      }
    }
    int32_t* col = out->column.ptr<int32_t>(y);
    int32_t* row = out->row.ptr<int32_t>(y);
    uint8_t* col_bits = out->column_bits.ptr<uint8_t>(y);
    uint8_t* row_bits = out->row_bits.ptr<uint8_t>(y);
    float* conf = out->confidence.ptr<float>(y);
    uint8_t* lit_out = out->lit.ptr<uint8_t>(y);
    uint8_t* exposure = out->exposure.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      lit_out[x] = lit[x];
      int32_t c = -1, r = -1;
      if (best[x] >= 0) {
        c = Position(best_c[x], best_bits_c[x], best_edge_c[x], cols);
        r = Position(best_r[x], best_bits_r[x], best_edge_r[x], rows_axis);
      }
      if (c < 0 || r < 0) {
        col[x] = -1;
        row[x] = -1;
        col_bits[x] = 0;
        row_bits[x] = 0;
        conf[x] = 0;
        exposure[x] = 255;
      } else {
        col[x] = c;
        row[x] = r;
        col_bits[x] = best_bits_c[x];
        row_bits[x] = best_bits_r[x];
        conf[x] = static_cast<float>(best_minc[x]) / th.full_scale;
        exposure[x] = best_e[x];
      }
    }
  }
}

// With every bit required: whether the camera resolves the finest stripes,
// which are 2 projector pixels wide. The projector pixels one camera pixel
// spans: the mean step between valid 4-neighbours' positions (the larger of
// the column and row step; steps above 64 are depth edges and left out),
// with the positions rounded down to multiples of 4 first, so that
// aliased finest bits (unequal parts of two stripes, which pass a contrast
// floor in a beat pattern) do not shorten the steps. Above 2, every pixel
// sees several of the finest stripes. Fewer than 100 pairs: unknown, false.
bool FinestStripesResolved(const DecodedView& d) {
  constexpr int kFinestStripe = 2;
  constexpr int kEdgeStep = 64;
  const cv::Mat& c = d.column;
  const cv::Mat& r = d.row;
  int64_t pairs = 0, sum = 0;
  auto add = [&](int y0, int x0, int y1, int x1) {
    const int32_t a = c.at<int32_t>(y0, x0), b = c.at<int32_t>(y1, x1);
    if (a < 0 || b < 0) return;
    const int step = 4 * std::max(std::abs((a >> 2) - (b >> 2)),
                                  std::abs((r.at<int32_t>(y0, x0) >> 2) -
                                           (r.at<int32_t>(y1, x1) >> 2)));
    if (step > kEdgeStep) return;
    ++pairs;
    sum += step;
  };
  for (int y = 0; y < c.rows; ++y) {
    for (int x = 0; x < c.cols; ++x) {
      if (x + 1 < c.cols) add(y, x, y, x + 1);
      if (y + 1 < c.rows) add(y, x, y + 1, x);
    }
  }
  return pairs >= 100 && sum <= kFinestStripe * pairs;
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
  const int col_bits =
      view.column_bits > 0 ? view.column_bits : BitCount(psize.width);
  const int row_bits =
      view.row_bits > 0 ? view.row_bits : BitCount(psize.height);
  if (col_bits > kMaxBits || row_bits > kMaxBits) {
    return absl::InvalidArgumentError(
        absl::StrFormat("projector %dx%d needs more than %d bits", psize.width,
                        psize.height, kMaxBits));
  }
  if (view.column_offset < 0 || view.row_offset < 0 ||
      psize.width + view.column_offset > (1 << col_bits) ||
      psize.height + view.row_offset > (1 << row_bits)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "codes of %d column and %d row bits with offsets %d and %d cannot "
        "code a %dx%d projector",
        col_bits, row_bits, view.column_offset, view.row_offset, psize.width,
        psize.height));
  }
  if (view.exposures.empty()) {
    return absl::InvalidArgumentError("no exposure given");
  }
  if (view.exposures.size() > 254) {
    return absl::InvalidArgumentError("at most 254 exposures");
  }
  const std::vector<Pattern> patterns = AllPatterns(col_bits, row_bits);
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
    // With every bit required, first without the relative test; then again
    // with it if the reads show the finest stripes unresolved.
    th.relative = options.min_bits > 0;
    th.saturation = std::clamp(
        static_cast<int>(std::floor(options.saturation * th.full_scale)), 1,
        th.full_scale);
    auto required = [&](int bits) {
      return options.min_bits == 0 ? bits : std::min(options.min_bits, bits);
    };
    const Axis1D cols{
        .bits = col_bits,
        .offset = view.column_offset,
        .extent = psize.width,
        .required = required(col_bits),
        .partial = options.min_bits > 0,
        .lut = GrayLut(col_bits, view.column_offset, psize.width)};
    const Axis1D rows_axis{
        .bits = row_bits,
        .offset = view.row_offset,
        .extent = psize.height,
        .required = required(row_bits),
        .partial = options.min_bits > 0,
        .lut = GrayLut(row_bits, view.row_offset, psize.height)};

    DecodedView out;
    out.column.create(size, CV_32SC1);
    out.row.create(size, CV_32SC1);
    out.confidence.create(size, CV_32FC1);
    out.lit.create(size, CV_8UC1);
    out.exposure.create(size, CV_8UC1);
    out.column_bits.create(size, CV_8UC1);
    out.row_bits.create(size, CV_8UC1);
    out.column_code_bits = col_bits;
    out.row_code_bits = row_bits;
    const int stripes = std::max(1, size.height / 16);
    const auto decode = [&] {
      cv::parallel_for_(
          cv::Range(0, size.height),
          [&](const cv::Range& rows) {
            if (depth == CV_8U) {
              DecodeRows<uint8_t>(grey, cols, rows_axis, th, rows, &out);
            } else {
              DecodeRows<uint16_t>(grey, cols, rows_axis, th, rows, &out);
            }
          },
          stripes);
    };
    decode();
    if (!th.relative && !FinestStripesResolved(out)) {
      th.relative = true;
      decode();
    }
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
